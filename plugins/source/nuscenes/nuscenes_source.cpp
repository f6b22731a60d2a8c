// NuScenesSource: keyframes, camera calibration, ego motion and annotations from the nuScenes tables.
#include "nuscenes_source.hpp"

#include "hazardforge/angles.hpp"
#include "hazardforge/image_file.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <unordered_map>

#include <opencv2/imgproc.hpp>

#include "nuscenes_tables.hpp"

namespace hf::source {

namespace fs = std::filesystem;
using nuscenes::Table;
using nuscenes::Tables;

namespace {

// Share of an annotated object hidden in the cameras: the middle of its visibility bin. nuScenes' visibility
// table has four fixed tokens, "1".."4" for 0-40, 40-60, 60-80 and 80-100 % visible (its schema); the table
// itself is not needed. 0 (nothing said) when the row has no known token.
double hidden_share(const Json& annotation) {
  const auto it = annotation.find("visibility_token");
  if (it == annotation.end() || !it->is_string()) return 0.0;
  const std::string& v = it->get_ref<const std::string&>();
  if (v == "1") return 0.8;
  if (v == "2") return 0.5;
  if (v == "3") return 0.3;
  if (v == "4") return 0.1;
  return 0.0;
}

const Json kDefaultLabelMap = {
    {"vehicle.car", "car"},
    {"vehicle.truck", "truck"},
    {"vehicle.trailer", "truck"},
    {"vehicle.construction", "truck"},
    {"vehicle.bus", "bus"},
    {"vehicle.motorcycle", "motorcycle"},
    {"vehicle.bicycle", "bicycle"},
    {"human.pedestrian", "person"},
    {"vehicle.emergency.ambulance", "truck"},
    {"vehicle.emergency.police", "car"},
};

cv::Vec3d vec3(const std::vector<double>& v) {
  return {v[0], v[1], v[2]};
}

double yaw_of(const cv::Matx33d& R) {
  return std::atan2(R(1, 0), R(0, 0));
}

// Central difference over neighbours (one-sided at the ends) of a per-keyframe quantity.
template <class T, class Diff>
std::optional<T> central(const std::vector<T>& v, const std::vector<double>& t, size_t i, Diff diff) {
  if (v.size() < 2) return std::nullopt;
  const size_t a = i == 0 ? 0 : i - 1, b = i + 1 == v.size() ? i : i + 1;
  const double dt = t[b] - t[a];
  if (!(dt > 0)) return std::nullopt;
  return diff(v[b], v[a]) * (1.0 / dt);
}

}  // namespace

std::string map_label(const std::string& category, const Json& label_map) {
  std::string best_key, best;
  for (auto it = label_map.begin(); it != label_map.end(); ++it) {
    const std::string& k = it.key();
    const bool match = category == k || (category.size() > k.size() &&
                                         category.compare(0, k.size(), k) == 0 && category[k.size()] == '.');
    if (match && k.size() > best_key.size()) {
      best_key = k;
      best = it->is_string() ? it->get<std::string>() : "";
    }
  }
  return best;
}

ComponentInfo NuScenesSource::describe() {
  ComponentInfo i =
      base_info("nuscenes", "nuScenes camera keyframes with calibration, ego poses and 3D annotations");
  i.doc =
      "Reads scene, sample, sample_data, ego_pose, calibrated_sensor, sensor (and, for annotations, "
      "sample_annotation, instance, category) of <dataroot>/<version>; log/attribute/visibility/map are not "
      "needed (an annotation's visibility token becomes its hidden share, AnnotatedObject::occlusion). Emits "
      "the keyframes of `channel`. Ego velocity: central difference of neighbouring keyframe "
      "poses. "
      "Object velocity: the devkit's box_velocity (neighbouring annotations of the instance, at most "
      "max_velocity_dt apart, twice that for a centred difference). Annotations are expressed in the ego "
      "frame "
      "of the camera sample_data's ego pose.";
  i.params = {
      ParamSpec::path("dataroot", "${HAZARDFORGE_SHARED}/data/nuscenes")
          .describe("nuScenes root (holds samples/)"),
      ParamSpec::string("version", "v1.0-mini").describe("table folder below dataroot"),
      ParamSpec::string_list("scenes", {}).describe("scene names (empty = every scene whose images exist)"),
      ParamSpec::string("channel", "CAM_FRONT").describe("camera channel"),
      ParamSpec::boolean("annotations", true).describe("attach sample annotations (ego frame) to each frame"),
      ParamSpec::number("max_velocity_dt", 1.5)
          .range(0.01, 100)
          .describe(
              "max time between neighbouring annotations for an object velocity, s (doubled when centred)"),
      ParamSpec::object("label_map", kDefaultLabelMap)
          .describe(
              "category prefix -> project class; the longest matching prefix wins, no match = empty label"),
      ParamSpec::boolean("images_required", true)
          .describe("fail on a missing image (false: a black frame of the recorded size is emitted instead)"),
      ParamSpec::integer("resize_width", 0)
          .range(0, 16384)
          .describe("output width (0 = keep; aspect kept if only one is set)"),
      ParamSpec::integer("resize_height", 0).range(0, 16384).describe("output height (0 = keep)"),
      ParamSpec::number("scene_gap_s", 1.0)
          .range(0, 1e6)
          .describe("time inserted between consecutive scenes, s"),
      ParamSpec::integer("max_frames", -1).range(-1, std::nullopt).describe("frames to emit (-1 = all)"),
      ParamSpec::boolean("ego_track", true)
          .describe("attach the scene's whole recorded ego track (Frame::ego_track, source 'dataset': poses "
                    "in the world frame, t in stream seconds) to every frame, so planners can plan against "
                    "where the ego really goes"),
  };
  return i;
}

void NuScenesSource::open(StageContext& ctx) {
  const Params& p = ctx.params();
  dataroot_ = p.get_path("dataroot");
  const std::string version = p.get_string("version"), channel = p.get_string("channel");
  const bool with_ann = p.get_bool("annotations");
  const double max_dt = p.get_double("max_velocity_dt");
  const Json label_map = p.raw("label_map");
  for (auto it = label_map.begin(); it != label_map.end(); ++it)
    if (!it->is_string()) throw Error("parameter 'label_map': value of '" + it.key() + "' is not a string");
  images_required_ = p.get_bool("images_required");
  ego_track_ = p.get_bool("ego_track");
  resize_w_ = static_cast<int>(p.get_int("resize_width"));
  resize_h_ = static_cast<int>(p.get_int("resize_height"));
  const double gap = p.get_double("scene_gap_s");
  const fs::path table_dir = dataroot_ / version;
  const Tables T = Tables::load(table_dir, with_ann);

  // Keyframe sample_data of the channel, by sample token.
  std::set<std::string> sensors;
  for (const Json& s : T.sensor.records())
    if (T.sensor.str(s, "channel") == channel) sensors.insert(T.sensor.str(s, "token"));
  if (sensors.empty())
    throw Error("nuScenes table '" + T.sensor.file().string() + "': no sensor with channel '" + channel +
                "'");
  std::set<std::string> calibs;
  for (const Json& c : T.calibrated_sensor.records())
    if (sensors.count(T.calibrated_sensor.str(c, "sensor_token")))
      calibs.insert(T.calibrated_sensor.str(c, "token"));
  std::unordered_map<std::string, const Json*> keyframe_of_sample;
  for (const Json& sd : T.sample_data.records()) {
    if (!calibs.count(T.sample_data.str(sd, "calibrated_sensor_token"))) continue;
    if (!T.sample_data.boolean(sd, "is_key_frame")) continue;
    keyframe_of_sample[T.sample_data.str(sd, "sample_token")] = &sd;
  }
  std::unordered_map<std::string, std::vector<const Json*>> anns_of_sample;
  if (with_ann)
    for (const Json& a : T.sample_annotation.records())
      anns_of_sample[T.sample_annotation.str(a, "sample_token")].push_back(&a);

  // Scenes in table order, filtered by name.
  std::vector<std::string> wanted = p.get_strings("scenes");
  std::vector<const Json*> scenes;
  std::vector<std::string> names;
  for (const Json& s : T.scene.records()) names.push_back(T.scene.str(s, "name"));
  for (const std::string& w : wanted)
    if (std::find(names.begin(), names.end(), w) == names.end()) {
      std::string list;
      for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
      throw Error("nuScenes table '" + T.scene.file().string() + "': no scene named '" + w +
                  "' (has: " + list + ")");
    }

  for (const Json& scene : T.scene.records()) {
    const std::string name = T.scene.str(scene, "name");
    if (!wanted.empty() && std::find(wanted.begin(), wanted.end(), name) == wanted.end()) continue;
    // Walk the sample chain; bound the walk so a cyclic `next` cannot hang the run.
    std::vector<KeyFrame> kfs;
    std::string tok = T.scene.str(scene, "first_sample_token");
    for (size_t guard = 0; !tok.empty(); ++guard) {
      if (guard > T.sample.records().size())
        throw Error("nuScenes table '" + T.sample.file().string() + "': the 'next' chain of scene " + name +
                    " loops");
      const Json& sample = T.sample.at(tok, "scene " + name);
      auto kf_it = keyframe_of_sample.find(tok);
      if (kf_it == keyframe_of_sample.end())
        throw Error("nuScenes table '" + T.sample_data.file().string() + "': sample '" + tok + "' of scene " +
                    name + " has no " + channel + " keyframe");
      const Json& sd = *kf_it->second;
      KeyFrame k;
      k.scene = name;
      k.scene_description = scene.value("description", "");
      k.sample_token = tok;
      k.sample_data_token = T.sample_data.str(sd, "token");
      k.filename = T.sample_data.str(sd, "filename");
      k.timestamp_us = T.sample_data.i64(sd, "timestamp");
      const std::string sd_ref = "sample_data '" + k.sample_data_token + "'";
      const Json& cs = T.calibrated_sensor.at(T.sample_data.str(sd, "calibrated_sensor_token"), sd_ref);
      const std::vector<double> K = [&] {
        auto it = cs.find("camera_intrinsic");
        std::vector<double> v;
        if (it != cs.end() && it->is_array() && it->size() == 3)
          for (const Json& row : *it)
            if (row.is_array() && row.size() == 3)
              for (const Json& x : row)
                if (x.is_number() && std::isfinite(x.get<double>())) v.push_back(x.get<double>());
        if (v.size() != 9)
          throw Error("nuScenes table '" + T.calibrated_sensor.file().string() + "': record '" +
                      T.calibrated_sensor.str(cs, "token") +
                      "': field 'camera_intrinsic' is not a 3x3 matrix");
        return v;
      }();
      k.camera.width = static_cast<int>(T.sample_data.i64(sd, "width"));
      k.camera.height = static_cast<int>(T.sample_data.i64(sd, "height"));
      if (!(K[0] > 0) || !(K[4] > 0)) {
        std::ostringstream os;
        os << "field 'camera_intrinsic' has focal lengths fx = " << K[0] << ", fy = " << K[4]
           << "; both must be positive";
        T.calibrated_sensor.bad_record(cs, os.str());
      }
      k.camera.fx = K[0];
      k.camera.cx = K[2];
      k.camera.fy = K[4];
      k.camera.cy = K[5];
      k.camera.R_ego_cam = T.calibrated_sensor.rotation(cs, "rotation");
      k.camera.t_ego_cam = vec3(T.calibrated_sensor.nums(cs, "translation", 3));
      const Json& pose = T.ego_pose.at(T.sample_data.str(sd, "ego_pose_token"), sd_ref);
      k.R_world_ego = T.ego_pose.rotation(pose, "rotation");
      k.t_world_ego = vec3(T.ego_pose.nums(pose, "translation", 3));
      k.pose_timestamp_us = T.ego_pose.i64(pose, "timestamp");
      // Velocities are differences over time: a repeated or backwards timestamp doubles or flips them.
      if (!kfs.empty() && k.timestamp_us <= kfs.back().timestamp_us)
        T.sample_data.bad_record(sd, "field 'timestamp' = " + std::to_string(k.timestamp_us) +
                                         " is not after the previous keyframe's " +
                                         std::to_string(kfs.back().timestamp_us) + " (scene " + name +
                                         "); keyframe timestamps must increase strictly");
      kfs.push_back(std::move(k));
      tok = T.sample.str(sample, "next");
    }
    if (kfs.empty()) continue;
    // An unnamed scene is only taken when its images are here; a named one must be complete.
    if (wanted.empty() && images_required_ && !fs::exists(dataroot_ / kfs.front().filename)) {
      ctx.log(LogLevel::kInfo, "nuScenes scene " + name + " skipped: its " + channel + " images are not in " +
                                   dataroot_.string());
      continue;
    }

    // Ego motion by central differences of neighbouring keyframe poses (one-sided at the ends).
    std::vector<double> ts, pose_ts;
    std::vector<cv::Vec3d> pos;
    std::vector<double> yaw;
    // Differences in integer microseconds first: epoch seconds as doubles lose ~0.3 us.
    const int64_t t0_us = kfs.front().timestamp_us;
    for (const KeyFrame& k : kfs) {
      ts.push_back(static_cast<double>(k.timestamp_us - t0_us) * 1e-6);
      pose_ts.push_back(static_cast<double>(k.pose_timestamp_us - t0_us) * 1e-6);
      pos.push_back(k.t_world_ego);
      yaw.push_back(yaw_of(k.R_world_ego));
    }
    const double t_offset = frames_.empty() ? -ts.front() : frames_.back().t + gap - ts.front();
    for (size_t i = 0; i < kfs.size(); ++i) {
      KeyFrame& k = kfs[i];
      k.t = ts[i] + t_offset;
      k.scene_start = i == 0;
      cv::Matx44d T_we = cv::Matx44d::eye();
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) T_we(r, c) = k.R_world_ego(r, c);
        T_we(r, 3) = k.t_world_ego[r];
      }
      k.ego.T_world_ego = T_we;
      k.ego.source = "dataset";
      auto v =
          central(pos, pose_ts, i, [](const cv::Vec3d& b, const cv::Vec3d& a) { return cv::Vec3d(b - a); });
      if (v) {
        k.ego.velocity_world = *v;
        k.ego.speed_mps = cv::norm(*v);
      }
      if (auto w = central(yaw, pose_ts, i, [](double b, double a) { return angle_diff(b, a); }))
        k.ego.yaw_rate = *w;

      if (!with_ann) continue;
      auto ann = std::make_shared<Annotations>();
      if (v) ann->ego_velocity_ego = k.R_world_ego.t() * *v;
      const cv::Matx33d R_ew = k.R_world_ego.t();
      auto sample_time_us = [&](const Json& a) {
        const std::string st = T.sample_annotation.str(a, "sample_token");
        return T.sample.i64(
            T.sample.at(st, "sample_annotation '" + T.sample_annotation.str(a, "token") + "'"), "timestamp");
      };
      auto it = anns_of_sample.find(k.sample_token);
      if (it != anns_of_sample.end()) {
        for (const Json* ap : it->second) {
          const Json& a = *ap;
          const std::string atok = T.sample_annotation.str(a, "token");
          const std::string ref = "sample_annotation '" + atok + "'";
          AnnotatedObject o;
          o.instance_id = T.sample_annotation.str(a, "instance_token");
          const Json& inst = T.instance.at(o.instance_id, ref);
          o.category = T.category.str(
              T.category.at(T.instance.str(inst, "category_token"), "instance '" + o.instance_id + "'"),
              "name");
          o.label = map_label(o.category, label_map);
          const cv::Vec3d c_world = vec3(T.sample_annotation.nums(a, "translation", 3));
          o.center_ego = R_ew * (c_world - k.t_world_ego);
          const std::vector<double> wlh = T.sample_annotation.nums(a, "size", 3);
          o.size_lwh = cv::Vec3d(wlh[1], wlh[0], wlh[2]);  // nuScenes stores [w, l, h]
          o.yaw_ego = yaw_of(R_ew * T.sample_annotation.rotation(a, "rotation"));
          o.num_points = static_cast<int>(T.sample_annotation.i64(a, "num_lidar_pts") +
                                          T.sample_annotation.i64(a, "num_radar_pts"));
          o.occlusion = hidden_share(a);
          // The devkit's box_velocity: neighbouring annotations of the instance, centred when both exist.
          const std::string prev = T.sample_annotation.str(a, "prev"),
                            next = T.sample_annotation.str(a, "next");
          if (!prev.empty() || !next.empty()) {
            const Json& first = prev.empty() ? a : T.sample_annotation.at(prev, ref + " (prev)");
            const Json& last = next.empty() ? a : T.sample_annotation.at(next, ref + " (next)");
            const double dt = static_cast<double>(sample_time_us(last) - sample_time_us(first)) * 1e-6;
            const double allowed = (!prev.empty() && !next.empty()) ? 2 * max_dt : max_dt;
            if (dt > 0 && dt <= allowed) {
              const cv::Vec3d v_world = (vec3(T.sample_annotation.nums(last, "translation", 3)) -
                                         vec3(T.sample_annotation.nums(first, "translation", 3))) *
                                        (1.0 / dt);
              o.velocity_ego = R_ew * v_world;
            }
          }
          ann->objects.push_back(std::move(o));
        }
      }
      k.annotations = std::move(ann);
    }
    // The recorded ego track of the whole scene, known in advance from the poses.
    auto track = std::make_shared<EgoTrack>();
    track->source = "dataset";
    for (const KeyFrame& k : kfs)
      track->samples.push_back({k.t, k.t_world_ego[0], k.t_world_ego[1], yaw_of(k.R_world_ego),
                                k.ego.speed_mps.value_or(0.0), k.ego.yaw_rate.value_or(0.0)});
    track->validate("nuScenes scene " + (kfs.empty() ? std::string() : kfs.front().scene));
    for (KeyFrame& k : kfs) {
      if (ego_track_) k.ego_track = track;
      frames_.push_back(std::move(k));
    }
  }
  if (frames_.empty())
    throw Error("nuScenes dataroot '" + dataroot_.string() + "': no scene with " + channel + " images found");
  if (const long long m = p.get_int("max_frames"); m >= 0 && static_cast<size_t>(m) < frames_.size())
    frames_.resize(static_cast<size_t>(m));
  if (images_required_)
    for (const KeyFrame& k : frames_)
      if (!fs::exists(dataroot_ / k.filename))
        throw Error("nuScenes image '" + (dataroot_ / k.filename).string() + "' (sample_data '" +
                    k.sample_data_token + "') does not exist");
  ctx.log(LogLevel::kInfo,
          "nuScenes " + version + ": " + std::to_string(frames_.size()) + " " + channel + " keyframes");
}

bool NuScenesSource::next(StageContext& /*ctx*/, Outputs& out) {
  if (pos_ >= frames_.size()) return false;
  const KeyFrame& k = frames_[pos_];
  const fs::path file = dataroot_ / k.filename;
  cv::Mat img;
  if (fs::exists(file)) {
    img =
        read_color_image(file, "nuScenes image '" + file.string() + "' (frame " + std::to_string(pos_) + ")");
  } else if (images_required_) {
    throw Error("nuScenes image '" + file.string() + "' (frame " + std::to_string(pos_) + ") does not exist");
  } else {
    img = cv::Mat(k.camera.height, k.camera.width, CV_8UC3, cv::Scalar::all(0));
  }
  if (img.cols != k.camera.width || img.rows != k.camera.height)
    throw Error("nuScenes image '" + file.string() + "' is " + std::to_string(img.cols) + "x" +
                std::to_string(img.rows) + " but sample_data '" + k.sample_data_token + "' records " +
                std::to_string(k.camera.width) + "x" + std::to_string(k.camera.height));
  Frame f;
  f.index = static_cast<int64_t>(pos_);
  f.timestamp = k.t;
  f.camera = k.camera;
  int ow = resize_w_, oh = resize_h_;
  if (ow == 0 && oh > 0) ow = static_cast<int>(std::lround(static_cast<double>(img.cols) * oh / img.rows));
  if (oh == 0 && ow > 0) oh = static_cast<int>(std::lround(static_cast<double>(img.rows) * ow / img.cols));
  if (ow > 0 && (ow != img.cols || oh != img.rows)) {
    cv::resize(img, f.image, cv::Size(ow, oh), 0, 0, ow < img.cols ? cv::INTER_AREA : cv::INTER_LINEAR);
    f.camera = k.camera.scaled_to(ow, oh);
  } else {
    f.image = img;
  }
  f.ego = k.ego;
  f.source_id = k.filename;
  f.origin = {"nuscenes", k.scene, k.scene_description, std::nullopt};
  f.meta = {{"scene_start", k.scene_start},
            {"sample_token", k.sample_token},
            {"sample_data_token", k.sample_data_token},
            {"timestamp_us", k.timestamp_us},
            {"file", k.filename}};
  f.ego_track = k.ego_track;
  f.stream_end = frames_.back().t;
  f.annotations = k.annotations;
  const double ts = f.timestamp;
  out.emit_packet("frames", Packet::make<Frame>(std::move(f), ts));
  ++pos_;
  return true;
}

}  // namespace hf::source
