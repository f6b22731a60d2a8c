// hf_footage_probe: runs the footage geometry kit on a real clip (image folder, image list or video) and prints
// the horizon estimate and per-frame raw and smoothed ego motion as JSON.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "hazardforge/footage/attitude.hpp"
#include "hazardforge/footage/camera_height.hpp"
#include "hazardforge/footage/ego_motion.hpp"
#include "hazardforge/footage/horizon.hpp"
#include "hazardforge/footage/lever_arm.hpp"
#include "hazardforge/image_file.hpp"
#include "hazardforge/process_memory.hpp"

namespace fs = std::filesystem;
using hf::Json;

namespace {

struct Clip {
  std::vector<cv::Mat> frames;
  std::vector<double> t;
  std::vector<std::optional<double>> ref_speed;
};

std::vector<double> parse_list(const std::string& s) {
  std::vector<double> v;
  std::stringstream ss(s);
  std::string tok;
  while (std::getline(ss, tok, ',')) v.push_back(std::stod(tok));
  return v;
}

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

Json num(double v) { return std::isfinite(v) ? Json(std::round(v * 1e4) / 1e4) : Json(nullptr); }

// The frame, or an empty Mat after printing why it cannot be used.
cv::Mat read_image(const fs::path& file, const std::string& what) {
  try {
    return hf::read_color_image(file, what);
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return {};
  }
}

}  // namespace

int main(int argc, char** argv) {
  hf::keep_freed_memory_for_reuse();  // the host's allocator policy, so the timings are the pipeline's
  CLI::App app{"Horizon and ego motion from a monocular front-camera clip, as JSON"};
  std::string images, video, list;
  double fps = 0, fx = 0, fy = 0, cx = -1, cy = -1, hfov = 0, ref_horizon = std::nan("");
  std::string dist;
  int max_frames = 0;
  std::optional<double> pitch_deg, roll_deg;
  app.add_option("--images", images, "folder of frames (sorted by name)");
  app.add_option("--video", video, "video file");
  app.add_option("--list", list, "text file: one 'image_path timestamp_s [reference_speed_mps]' per line");
  app.add_option("--fps", fps, "frame rate for --images (and --video when the container lacks it)");
  app.add_option("--fx", fx);
  app.add_option("--fy", fy, "default fx");
  app.add_option("--cx", cx, "default image centre");
  app.add_option("--cy", cy, "default image centre");
  app.add_option("--hfov", hfov, "horizontal field of view, deg (when fx is not given)");
  std::optional<double> height_opt;
  app.add_option("--height", height_opt,
                 "camera height above the road, m (default: from the lane-line spacing, else 1.5 as the pipeline)");
  double forward = 1.5;
  app.add_option("--forward", forward, "camera position ahead of the rear axle, m (the yaw pivot)");
  app.add_option("--dist", dist, "distortion k1,k2,p1,p2[,k3]: frames are undistorted with K first");
  app.add_option("--max-frames", max_frames, "use at most this many frames (0 = all)");
  app.add_option("--pitch-deg", pitch_deg, "use this pitch for the odometry instead of the estimated one");
  app.add_option("--roll-deg", roll_deg, "use this roll for the odometry instead of the estimated one");
  std::string debug_dir;
  app.add_option("--debug-dir", debug_dir, "write each frame (with the horizon drawn) and its bird's-eye view here");
  app.add_option("--ref-horizon", ref_horizon, "reference horizon row at cx, reported beside the estimate");
  bool no_lever_arm = false;
  app.add_flag(
      "--no-lever-arm", no_lever_arm,
      "between frames 0.15 s and more apart, take the distance from the road view alone (not also from the "
      "camera's lever arm in the bends)");
  bool no_far_scene = false;
  app.add_flag(
      "--no-far-scene", no_far_scene,
      "between video-rate frames, take the ego's turn from the road alone (not the far scene's shift)");
  CLI11_PARSE(app, argc, argv);

  Clip clip;
  auto push = [&](cv::Mat img, double t, std::optional<double> ref) {
    if (img.empty()) return false;
    clip.frames.push_back(std::move(img));
    clip.t.push_back(t);
    clip.ref_speed.push_back(ref);
    return !(max_frames > 0 && static_cast<int>(clip.frames.size()) >= max_frames);
  };
  if (!list.empty()) {
    std::ifstream in(list);
    if (!in) {
      std::cerr << "cannot read " << list << "\n";
      return 2;
    }
    std::string line;
    const fs::path base = fs::path(list).parent_path();
    while (std::getline(in, line)) {
      std::stringstream ss(line);
      std::string path;
      double t = 0;
      if (!(ss >> path >> t)) continue;
      std::optional<double> ref;
      double r;
      if (ss >> r) ref = r;
      fs::path p(path);
      if (p.is_relative()) p = base / p;
      const cv::Mat img = read_image(p, "image '" + p.string() + "' (listed in " + list + ")");
      if (img.empty()) return 2;
      if (!push(img, t, ref)) break;
    }
  } else if (!images.empty()) {
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(images)) {
      const std::string ext = e.path().extension().string();
      if (ext == ".png" || ext == ".jpg" || ext == ".jpeg") files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
    if (fps <= 0) {
      std::cerr << "--images needs --fps\n";
      return 2;
    }
    for (size_t i = 0; i < files.size(); ++i) {
      const cv::Mat img = read_image(files[i], "image '" + files[i].string() + "'");
      if (img.empty()) return 2;
      if (!push(img, i / fps, std::nullopt)) break;
    }
  } else if (!video.empty()) {
    cv::VideoCapture cap(video);
    if (!cap.isOpened()) {
      std::cerr << "cannot open video " << video << "\n";
      return 2;
    }
    if (fps <= 0) fps = cap.get(cv::CAP_PROP_FPS);
    if (!(fps > 0)) {
      std::cerr << "video " << video << " has no frame rate: pass --fps\n";
      return 2;
    }
    cv::Mat img;
    for (int i = 0; cap.read(img); ++i)
      if (!push(img.clone(), i / fps, std::nullopt)) break;
  } else {
    std::cerr << "give --images, --video or --list\n";
    return 2;
  }
  if (clip.frames.empty()) {
    std::cerr << "no frames read\n";
    return 2;
  }
  const int w = clip.frames[0].cols, h = clip.frames[0].rows;
  const double height = height_opt.value_or(1.5);
  if (fx <= 0) {
    if (hfov <= 0) {
      std::cerr << "give --fx or --hfov\n";
      return 2;
    }
    fx = 0.5 * w / std::tan(0.5 * hfov * M_PI / 180.0);
  }
  if (fy <= 0) fy = fx;
  if (cx < 0) cx = 0.5 * w;
  if (cy < 0) cy = 0.5 * h;
  hf::CameraModel intr = hf::CameraModel::pinhole(w, h, fx, fy, cx, cy, height, 0.0, forward, 0.0);
  if (!dist.empty()) {
    const std::vector<double> d = parse_list(dist);
    const cv::Mat K(intr.K());
    for (cv::Mat& f : clip.frames) {
      cv::Mat u;
      cv::undistort(f, u, K, d);
      f = u;
    }
  }

  using Clock = std::chrono::steady_clock;
  auto t0 = Clock::now();
  hf::footage::HorizonEstimator horizon(intr);
  for (size_t i = 0; i < clip.frames.size(); ++i) horizon.add(clip.frames[i], clip.t[i]);
  const auto est = horizon.result();
  const double horizon_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();

  Json out;
  out["frames"] = clip.frames.size();
  out["image"] = {w, h};
  out["intrinsics"] = {{"fx", fx}, {"fy", fy}, {"cx", cx}, {"cy", cy}, {"height_m", height}};
  Json hj = nullptr;
  if (est) {
    hj = {{"horizon_y", num(est->horizon_y)},
          {"pitch_deg", num(est->pitch_rad * 180 / M_PI)},
          {"roll_deg", num(est->roll_rad * 180 / M_PI)},
          {"roll_sigma_deg", num(est->roll_sigma_rad * 180 / M_PI)},
          {"horizon_sigma_px", num(est->horizon_sigma_px)},
          {"confidence", num(est->confidence)},
          {"frames_used", est->frames_used},
          {"method", est->method},
          {"samples", {{"vanishing_point", est->vanishing_points}, {"flow_foe", est->foe_points},
                       {"road_homography", est->homographies}, {"ground_motion", est->ground_motions}}},
          {"cue_rows", {{"vanishing_point", num(est->vp_row)}, {"flow_foe", num(est->foe_row)},
                        {"road_homography", num(est->homography_row)}, {"ground_motion", num(est->ground_motion_row)}}},
          {"notes", est->notes}};
    if (std::isfinite(est->travel_x)) hj["travel_x"] = num(est->travel_x);
    if (std::isfinite(ref_horizon)) {
      hj["reference_horizon_y"] = ref_horizon;
      hj["horizon_error_px"] = num(est->horizon_y - ref_horizon);
      const double ref_pitch = std::atan2(cy - ref_horizon, fy);
      hj["reference_pitch_deg_at_zero_roll"] = num(ref_pitch * 180 / M_PI);
    }
  }
  out["horizon"] = hj;
  out["horizon_ms_per_frame"] = num(horizon_ms / clip.frames.size());

  hf::footage::HorizonEstimate used;
  if (est) used = *est;
  if (pitch_deg) used.pitch_rad = *pitch_deg * M_PI / 180;
  if (roll_deg) used.roll_rad = *roll_deg * M_PI / 180;
  if (!est && !pitch_deg) {
    out["ego_motion"] = nullptr;
    out["error"] = "no horizon evidence and no --pitch-deg: ego motion needs the camera pitch";
    std::cout << out.dump(2) << "\n";
    return 1;
  }
  const hf::CameraModel cam = hf::footage::HorizonEstimator::apply(intr, used);
  out["odometry_camera"] = {{"pitch_deg", num(cam.pitch() * 180 / M_PI)}, {"roll_deg", num(cam.roll() * 180 / M_PI)},
                            {"from", pitch_deg ? "command line" : "horizon estimate"}};
  hf::footage::GroundOdometry odo(cam);
  std::vector<hf::footage::EgoMotionSample> raw;
  t0 = Clock::now();
  hf::footage::AttitudeOptions far_opt;  // the heading step between video-rate frames, as the video source
  if (est) far_opt.travel_x = est->travel_x;
  hf::footage::AttitudeTracker far_scene(cam, far_opt);
  double far_ms = 0;  // the far-scene tracker's share of odo_ms
  for (size_t i = 0; i < clip.frames.size(); ++i) {
    const auto f0 = Clock::now();
    far_scene.add(clip.frames[i], clip.t[i]);
    far_ms += std::chrono::duration<double, std::milli>(Clock::now() - f0).count();
    raw.push_back(odo.add(clip.frames[i], static_cast<int64_t>(i), clip.t[i],
                          no_far_scene ? std::nullopt : far_scene.last_turn()));
  }
  const double odo_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  // Camera height from the lane-line spacing (the same pass in the pipeline): speeds scale with the height.
  t0 = Clock::now();
  hf::footage::CameraHeightEstimator height_est(cam);
  for (const cv::Mat& f : clip.frames) height_est.add(f);
  const auto hest = height_est.result();
  out["height_ms_per_frame"] = num(std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / clip.frames.size());
  out["height_estimate"] = hest ? Json{{"height_m", num(hest->height_m)}, {"sigma_m", num(hest->sigma_m)},
                                       {"confidence", num(hest->confidence)}, {"frames_used", hest->frames_used},
                                       {"note", hest->note}}
                                : Json(nullptr);
  if (const auto m = height_est.markings()) out["road_markings"] = *m;
  double used_height = height;
  if (!height_opt && hest) used_height = hest->height_m;
  out["odometry_height_m"] = num(used_height);
  out["odometry_height_from"] = height_opt ? "command line" : hest ? "lane-line spacing" : "default 1.5 m";
  hf::footage::rescale_height(raw, used_height / height);
  // The distance from the camera's lever arm in the bends (height-independent: after the rescale), as the
  // video source.
  if (!no_lever_arm) {
    const hf::footage::LeverArmOptions lo =
        est ? hf::footage::with_travel_column({}, cam, est->travel_x) : hf::footage::LeverArmOptions{};
    const auto scale = hf::footage::apply_lever_arm(raw, cam.cam_to_ego({0, 0, 0})[0], lo);
    out["lever_arm"] = {{"lever_m", num(scale.lever_m())},
                        {"bias_deg", num(scale.bias() * 180 / M_PI)},
                        {"bias_sigma_deg", num(scale.bias_sigma() * 180 / M_PI)},
                        {"straight_pairs", scale.straight_pairs()}};
  }
  if (!debug_dir.empty()) {
    fs::create_directories(debug_dir);
    hf::footage::GroundOdometry dbg(cam);
    for (size_t i = 0; i < clip.frames.size(); ++i) {
      dbg.add(clip.frames[i], static_cast<int64_t>(i), clip.t[i]);
      char name[64];
      std::snprintf(name, sizeof name, "/bev_%04zu.png", i);
      cv::imwrite(debug_dir + name, dbg.last_bev());
      cv::Mat f = clip.frames[i].clone();
      const auto y0 = cam.horizon_y(0), y1 = cam.horizon_y(w - 1);
      if (y0 && y1) cv::line(f, cv::Point(0, static_cast<int>(*y0)), cv::Point(w - 1, static_cast<int>(*y1)), {0, 0, 255}, 2);
      if (std::isfinite(ref_horizon)) cv::line(f, cv::Point(0, static_cast<int>(ref_horizon)), cv::Point(w - 1, static_cast<int>(ref_horizon)), {0, 255, 0}, 1);
      cv::line(f, cv::Point(0, h - dbg.bonnet_rows()), cv::Point(w - 1, h - dbg.bonnet_rows()), {255, 0, 0}, 1);
      cv::resize(f, f, cv::Size(), 0.5, 0.5);
      std::snprintf(name, sizeof name, "/frame_%04zu.png", i);
      cv::imwrite(debug_dir + name, f);
    }
  }
  hf::footage::SmoothReport smoothing;
  const auto smooth = hf::footage::smooth_ego_motion(raw, {}, &smoothing);
  out["smoother"] = {{"noise_scale", num(smoothing.noise_scale)},
                     {"scatter_frames", smoothing.scatter_frames},
                     {"rejected", smoothing.rejected},
                     {"restarts", smoothing.restarts}};
  out["odometry_ms_per_frame"] = num(odo_ms / clip.frames.size());  // with the far-scene tracker, as in the source
  out["far_scene_ms_per_frame"] = num(far_ms / clip.frames.size());
  out["bonnet_rows"] = odo.bonnet_rows();

  Json frames = Json::array();
  std::vector<double> rel_raw, rel_smooth, sp_raw, sp_smooth, yaw_smooth;
  int measured = 0;
  for (size_t i = 0; i < raw.size(); ++i) {
    Json f = {{"frame", i},
              {"t", num(clip.t[i])},
              {"measured", raw[i].measured},
              {"raw_speed", num(raw[i].speed_mps)},
              {"raw_yaw_rate", num(raw[i].yaw_rate)},
              {"raw_speed_sigma", num(raw[i].speed_sigma)},
              {"speed_cue", hf::footage::speed_cue_name(raw[i].speed_cue)},
              {"quality", num(raw[i].quality)},
              {"inliers", raw[i].inliers},
              {"kept", smooth[i].measured},
              {"speed", num(smooth[i].speed_mps)},
              {"speed_sigma", num(smooth[i].speed_sigma)},
              {"yaw_rate", num(smooth[i].yaw_rate)},
              {"yaw_rate_sigma", num(smooth[i].yaw_rate_sigma)}};
    if (raw[i].road_speed_mps) f["road_speed"] = num(*raw[i].road_speed_mps);
    if (raw[i].lever_speed_mps) {
      f["lever_speed"] = num(*raw[i].lever_speed_mps);
      f["lever_speed_sigma"] = num(raw[i].lever_speed_sigma);
    }
    if (const auto& tv = raw[i].two_view)
      f["two_view"] = {{"turn_deg", num(tv->yaw * 180 / M_PI)},
                       {"heading_deg", num(tv->heading * 180 / M_PI)},
                       {"heading_sigma_deg", num(tv->heading_sigma * 180 / M_PI)},
                       {"inliers", tv->inliers}};
    if (raw[i].measured) {
      ++measured;
      sp_raw.push_back(raw[i].speed_mps);
    }
    sp_smooth.push_back(smooth[i].speed_mps);
    yaw_smooth.push_back(smooth[i].yaw_rate);
    if (clip.ref_speed[i]) {
      const double r = *clip.ref_speed[i];
      f["ref_speed"] = num(r);
      if (r > 0.5) {
        if (raw[i].measured) rel_raw.push_back(std::abs(raw[i].speed_mps - r) / r);
        rel_smooth.push_back(std::abs(smooth[i].speed_mps - r) / r);
      }
    }
    frames.push_back(f);
  }
  out["summary"] = {{"measured_frames", measured},
                    {"median_raw_speed", num(median(sp_raw))},
                    {"median_smoothed_speed", num(median(sp_smooth))},
                    {"median_smoothed_yaw_rate", num(median(yaw_smooth))}};
  if (!rel_smooth.empty()) {
    out["summary"]["median_rel_speed_error_raw"] = num(median(rel_raw));
    out["summary"]["median_rel_speed_error_smoothed"] = num(median(rel_smooth));
  }
  out["per_frame"] = frames;
  std::cout << out.dump(2) << "\n";
  return 0;
}
