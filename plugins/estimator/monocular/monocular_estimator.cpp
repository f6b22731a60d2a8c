// Monocular estimator: places each tracked box on the road (pinhole range or ground contact) and
// differentiates the track's positions over time.
#include "monocular_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace hf {

namespace monocular {

double pinhole_depth(double fy, double real_height_m, double box_height_px) {
  return fy * real_height_m / box_height_px;
}

cv::Vec3d place_at_depth(const CameraModel& cam, const cv::Point2d& px, double depth) {
  const cv::Vec3d p_cam((px.x - cam.cx) * depth / cam.fx, (px.y - cam.cy) * depth / cam.fy, depth);
  return cam.cam_to_ego(p_cam);
}

std::optional<double> horizon_row(const CameraModel& cam, double u) {
  // A pixel's ray (a, b, 1) in camera axes is parallel to the road when its ego z component vanishes:
  // R20 a + R21 b + R22 = 0.
  const cv::Matx33d& R = cam.R_ego_cam;
  if (std::abs(R(2, 1)) < 1e-9) return std::nullopt;
  const double a = (u - cam.cx) / cam.fx;
  const double b = -(R(2, 0) * a + R(2, 2)) / R(2, 1);
  return cam.cy + cam.fy * b;
}

std::optional<double> ls_slope(const std::vector<double>& t, const std::vector<double>& y) {
  const size_t n = std::min(t.size(), y.size());
  if (n < 2) return std::nullopt;
  double mt = 0, my = 0;
  for (size_t i = 0; i < n; ++i) {
    mt += t[i];
    my += y[i];
  }
  mt /= static_cast<double>(n);
  my /= static_cast<double>(n);
  double stt = 0, sty = 0;
  for (size_t i = 0; i < n; ++i) {
    stt += (t[i] - mt) * (t[i] - mt);
    sty += (t[i] - mt) * (y[i] - my);
  }
  if (stt < 1e-12) return std::nullopt;
  return sty / stt;
}

}  // namespace monocular

ComponentInfo MonocularEstimator::describe() {
  ComponentInfo i = Estimator::base_info(
      "monocular",
      "distance (pinhole d = f*H/h or road contact), lateral offset, velocity, heading per track");
  i.doc =
      "Places the bottom-centre of each tracked box in the ego frame: at the pinhole depth d = fy*H/h (H = "
      "the "
      "class's real height from the class size priors, h = box height in px), or where the pixel's ray meets "
      "the "
      "road plane. distance_m is the longitudinal (ego x) distance from distance_origin. Velocity is the "
      "least-squares slope of the track's last velocity_window positions (matched frames only) against frame "
      "time, measured in a frame fixed to the world: the dataset's ego pose when the frame has one, else "
      "dead "
      "reckoning from the ego speed (and yaw rate); that slope is the absolute velocity v_abs, rotated into "
      "the "
      "current ego axes. velocity_rel = v_abs - v_ego; speed_mps = |v_abs|; heading_rad = atan2(v_abs.y, "
      "v_abs.x) relative to the ego heading. Without any ego speed the positions are differentiated in the "
      "ego "
      "frame: velocity_rel only, no speed or heading. scale_rate = d ln(h)/dt over the same window. Emits "
      "one ObjectStates per frame, stamped with the frame's time. See docs/risk-metrics.md.";
  i.params.push_back(ParamSpec::path("class_sizes", "")
                         .describe("YAML of per-class real sizes (m); empty = <share>/class_sizes.yaml"));
  i.params.push_back(
      ParamSpec::string("distance_method", "pinhole")
          .one_of({"pinhole", "ground", "fused"})
          .describe("pinhole: d = fy*H/h; ground: bottom-centre ray meets the road plane; fused: "
                    "ground when the bottom edge is well below the horizon and not clipped"));
  i.params.push_back(
      ParamSpec::number("fused_horizon_margin_px", 40.0)
          .range(0, 10000)
          .describe("fused: use ground only when the bottom edge is at least this far below the "
                    "horizon row (px)"));
  i.params.push_back(ParamSpec::number("border_margin_px", 2.0)
                         .range(0, 10000)
                         .describe("fused: a bottom edge within this many px of the image's bottom border is "
                                   "treated as clipped (pinhole is used)"));
  i.params.push_back(
      ParamSpec::string("distance_origin", "camera")
          .one_of({"camera", "bumper", "ego_origin"})
          .describe("where distance_m is measured from along ego x: the camera (the paper's d), "
                    "the front bumper (ego x = front_overhang), or the ego origin (rear axle)"));
  i.params.push_back(ParamSpec::number("front_overhang", 3.4)
                         .range(0, 20)
                         .describe("ego x of the front bumper (m), used with distance_origin: bumper"));
  i.params.push_back(
      ParamSpec::integer("velocity_window", 5)
          .range(2, 1000)
          .describe("positions (matched frames) in the least-squares velocity and scale-rate fit"));
  i.params.push_back(ParamSpec::integer("velocity_min_age", 3)
                         .range(2, 1000)
                         .describe("positions a track needs before velocity and scale rate are reported "
                                   "(<= velocity_window)"));
  i.params.push_back(
      ParamSpec::number("ego_speed_mps", -1.0)
          .range(-1, 200)
          .describe("ego speed used when the frame carries none (m/s); -1 = unknown (no absolute "
                    "velocity, heading or ego speed in the output)"));
  i.params.push_back(
      ParamSpec::boolean("use_yaw_rate", true)
          .describe("dead reckoning (frames without an ego pose) turns the ego by the frame's yaw "
                    "rate; false = the ego is assumed to drive straight"));
  i.params.push_back(
      ParamSpec::integer("max_misses", 2)
          .range(0, 100000)
          .describe("tracks missed for more consecutive frames than this (their box is held or "
                    "predicted by the tracker) are not estimated"));
  i.params.push_back(ParamSpec::number("min_box_height_px", 2.0)
                         .range(0.01, 10000)
                         .describe("boxes shorter than this (px) are not estimated"));
  for (ParamSpec& p : Corridor::params()) i.params.push_back(std::move(p));
  return i;
}

void MonocularEstimator::open(StageContext& ctx) {
  const Params& p = ctx.params();
  std::filesystem::path sizes = p.get_path("class_sizes");
  if (sizes.empty()) sizes = std::filesystem::path(share_dir()) / "class_sizes.yaml";
  priors_ = ClassPriors::load(sizes.string());
  ctx.record_resource(sizes);
  corridor_ = Corridor::from(p);
  const std::string m = p.get_string("distance_method");
  method_ = m == "ground" ? Method::kGround : m == "fused" ? Method::kFused : Method::kPinhole;
  const std::string o = p.get_string("distance_origin");
  origin_ = o == "bumper" ? Origin::kBumper : o == "ego_origin" ? Origin::kEgoOrigin : Origin::kCamera;
  front_overhang_ = p.get_double("front_overhang");
  horizon_margin_px_ = p.get_double("fused_horizon_margin_px");
  border_margin_px_ = p.get_double("border_margin_px");
  window_ = static_cast<size_t>(p.get_int("velocity_window"));
  min_age_ = static_cast<size_t>(p.get_int("velocity_min_age"));
  if (min_age_ > window_)
    throw Error("stage 'monocular': velocity_min_age (" + std::to_string(min_age_) +
                ") must not exceed velocity_window (" + std::to_string(window_) + ")");
  const double ego = p.get_double("ego_speed_mps");
  if (ego >= 0) ego_speed_param_ = ego;
  use_yaw_rate_ = p.get_bool("use_yaw_rate");
  min_box_height_px_ = p.get_double("min_box_height_px");
  max_misses_ = static_cast<int>(p.get_int("max_misses"));
  history_.clear();
}

cv::Matx44d MonocularEstimator::reference_pose(const Frame& frame, Reference ref, double ego_speed) {
  if (ref != reference_) {
    history_.clear();
    odometry_ = {0, 0, 0};
    last_t_ = frame.timestamp;
    reference_ = ref;
  }
  if (ref == Reference::kPose) return *frame.ego.T_world_ego;
  if (ref == Reference::kOdometry) {
    // Constant speed and yaw rate between frames: the ego moves along the chord of a circular arc.
    const double dt = frame.timestamp - last_t_;
    const double dyaw = (use_yaw_rate_ && frame.ego.yaw_rate) ? *frame.ego.yaw_rate * dt : 0.0;
    const double chord =
        std::abs(dyaw) > 1e-12 ? ego_speed * dt * std::sin(dyaw / 2) / (dyaw / 2) : ego_speed * dt;
    const double mid = odometry_[2] + dyaw / 2;
    odometry_ += cv::Vec3d(chord * std::cos(mid), chord * std::sin(mid), dyaw);
    last_t_ = frame.timestamp;
  }
  if (ref == Reference::kEgo) return cv::Matx44d::eye();
  const double c = std::cos(odometry_[2]), s = std::sin(odometry_[2]);
  return {c, -s, 0, odometry_[0], s, c, 0, odometry_[1], 0, 0, 1, 0, 0, 0, 0, 1};
}

ObjectStates MonocularEstimator::estimate(StageContext& ctx, const Tracks& tracks, const Frame& frame) {
  CameraModel cam = frame.camera;
  if (!cam.valid())
    throw Error(
        "frame " + std::to_string(frame.index) + " (" + frame.source_id +
        "): the camera model has no intrinsics (width, height, fx, fy); the monocular estimator needs them");
  // Boxes are in the frame image's pixels; a source may describe the camera at another resolution.
  if (!frame.image.empty() && (frame.image.cols != cam.width || frame.image.rows != cam.height))
    cam = cam.scaled_to(frame.image.cols, frame.image.rows);

  const double t = frame.timestamp;
  ObjectStates out;
  out.frame_index = frame.index;
  out.timestamp = t;
  out.ego_speed_mps = frame.ego.speed_mps ? frame.ego.speed_mps : ego_speed_param_;
  // The ego's velocity in its own axes: from the dataset's world velocity when it has one, else along +x.
  std::optional<cv::Vec2d> v_ego;
  if (frame.ego.velocity_world && frame.ego.T_world_ego) {
    const cv::Matx44d& T = *frame.ego.T_world_ego;
    const cv::Vec3d& w = *frame.ego.velocity_world;
    const cv::Vec3d v(T(0, 0) * w[0] + T(1, 0) * w[1] + T(2, 0) * w[2],
                      T(0, 1) * w[0] + T(1, 1) * w[1] + T(2, 1) * w[2],
                      T(0, 2) * w[0] + T(1, 2) * w[1] + T(2, 2) * w[2]);
    v_ego = cv::Vec2d(v[0], v[1]);
    if (!out.ego_speed_mps) out.ego_speed_mps = std::hypot(v[0], v[1]);
  } else if (out.ego_speed_mps) {
    v_ego = cv::Vec2d(*out.ego_speed_mps, 0.0);
  }
  out.ego_yaw_rate = frame.ego.yaw_rate;
  const Reference ref = !v_ego                  ? Reference::kEgo
                        : frame.ego.T_world_ego ? Reference::kPose
                                                : Reference::kOdometry;
  const cv::Matx44d T_ref_ego = reference_pose(frame, ref, out.ego_speed_mps.value_or(0.0));
  const double origin_x = origin_ == Origin::kCamera   ? cam.t_ego_cam[0]
                          : origin_ == Origin::kBumper ? front_overhang_
                                                       : 0.0;
  out.distance_origin_x = origin_x;

  std::set<int64_t> alive;
  for (const Track& tr : tracks.items) {
    alive.insert(tr.id);
    const double h = tr.box.height;
    if (!(h >= min_box_height_px_) || tr.misses > max_misses_) continue;
    if (!priors_.has(tr.label)) {
      if (warned_labels_.insert(tr.label).second)
        ctx.log(LogLevel::kWarning, "no size prior for class '" + tr.label +
                                        "' in the class size priors; its tracks are not estimated");
      continue;
    }
    const ClassSize& size = priors_.at(tr.label);
    const cv::Point2d bottom(tr.box.x + tr.box.width / 2.0, tr.box.y + tr.box.height);

    ObjectState s;
    s.track_id = tr.id;
    s.label = tr.label;
    s.score = tr.score;
    s.box = tr.box;
    s.box_height_px = h;
    s.age = tr.age;
    s.misses = tr.misses;
    s.annotation_index = tr.annotation_index;
    s.width_m = size.width;
    s.length_m = size.length;

    std::optional<cv::Vec3d> ground;
    bool use_ground = false;
    if (method_ != Method::kPinhole) ground = cam.pixel_to_ground(bottom);
    if (method_ == Method::kGround) {
      use_ground = ground.has_value();  // at or above the horizon the road plane gives no range
    } else if (method_ == Method::kFused && ground) {
      const std::optional<double> hz = monocular::horizon_row(cam, bottom.x);
      const bool below = hz && bottom.y - *hz >= horizon_margin_px_;
      const bool clipped = bottom.y >= cam.height - border_margin_px_;
      use_ground = below && !clipped;
    }
    cv::Vec3d p;
    if (use_ground) {
      p = *ground;
      s.distance_method = "ground";
    } else {
      p = monocular::place_at_depth(cam, bottom, monocular::pinhole_depth(cam.fy, size.height, h));
      s.distance_method = "pinhole";
    }
    s.distance_m = p[0] - origin_x;
    s.lateral_m = p[1];

    std::deque<Sample>& hist = history_[tr.id];
    // A held or predicted box (missed detection) is not a measurement: it would drag the velocity towards the
    // tracker's prediction.
    if (tr.misses == 0) {
      const cv::Vec4d q = T_ref_ego * cv::Vec4d(p[0], p[1], p[2], 1.0);
      if (!hist.empty() && std::abs(hist.back().t - t) < 1e-9) hist.pop_back();
      hist.push_back({t, q[0], q[1], std::log(h)});
      while (hist.size() > window_) hist.pop_front();
    }
    if (hist.size() >= min_age_) {
      std::vector<double> ts, xs, ys, ls;
      for (const Sample& q : hist) {
        ts.push_back(q.t);
        xs.push_back(q.x);
        ys.push_back(q.y);
        ls.push_back(q.log_h);
      }
      const auto vx = monocular::ls_slope(ts, xs), vy = monocular::ls_slope(ts, ys);
      if (vx && vy) {
        if (ref == Reference::kEgo) {
          s.velocity_rel = cv::Vec2d(*vx, *vy);
        } else {
          // Slope in the world-fixed frame = absolute velocity; rotate it into the current ego axes.
          const cv::Vec2d a(T_ref_ego(0, 0) * *vx + T_ref_ego(1, 0) * *vy,
                            T_ref_ego(0, 1) * *vx + T_ref_ego(1, 1) * *vy);
          s.velocity_rel = a - *v_ego;
          s.speed_mps = std::hypot(a[0], a[1]);
          s.heading_rad = std::atan2(a[1], a[0]);
        }
      }
      s.scale_rate = monocular::ls_slope(ts, ls);
    }
    s.in_path = corridor_.contains(out, s);
    out.objects.push_back(std::move(s));
  }
  for (auto it = history_.begin(); it != history_.end();)
    it = alive.count(it->first) ? std::next(it) : history_.erase(it);
  return out;
}

}  // namespace hf
