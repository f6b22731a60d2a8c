// Kalman estimator: fused pinhole/ground range, per-track filter moved by the ego, keypoint scale updates.
#include "kalman_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <hazardforge/angles.hpp>
#include <hazardforge/number_text.hpp>

namespace hf {

namespace {

// Whether a box ending near the picture's bottom edge is cut there although the detector did not say so: the
// track's predicted state puts the object's ground contact below the picture. The box then ends where the
// detector lost the object's lower part (a dark underbody or shadow close in front), not at its ground
// contact: on the KITTI raw clip a car 5 m ahead, its bumper below the picture, got a box ending 10 px above
// the border (just outside the detector's margin) and was read 1.2 m too far. Only boxes ending within 4 % of
// the picture's height of the edge are questioned, so a state predicted too close cannot silence the range of
// a box that plainly ends on the road.
bool cut_below_picture(const CameraModel& cam, const estimation::TrackFilter& f, const cv::Rect2f& box,
                       int rows) {
  if (box.y + box.height < rows * (1.0 - 0.04)) return false;
  const cv::Vec4d& x = f.state();
  const auto px = cam.project_ego(cv::Vec3d(x[0], x[1], 0.0));
  return px && px->y > rows;
}

// Heading change and translation of the ego from the previous to the current frame, in the previous frame.
estimation::EgoDelta delta_from_poses(const cv::Matx44d& prev, const cv::Matx44d& cur) {
  const cv::Matx44d d = prev.inv() * cur;
  estimation::EgoDelta e;
  e.dx = d(0, 3);
  e.dy = d(1, 3);
  e.dyaw = std::atan2(d(1, 0), d(0, 0));
  e.absolute = true;
  return e;
}

estimation::EgoDelta delta_from_speed(double speed, std::optional<double> yaw_rate, double dt) {
  // Constant speed and yaw rate: the ego moves along the chord of a circular arc.
  estimation::EgoDelta e;
  e.dyaw = yaw_rate ? *yaw_rate * dt : 0.0;
  const double chord =
      std::abs(e.dyaw) > 1e-12 ? speed * dt * std::sin(e.dyaw / 2) / (e.dyaw / 2) : speed * dt;
  e.dx = chord * std::cos(e.dyaw / 2);
  e.dy = chord * std::sin(e.dyaw / 2);
  e.absolute = true;
  return e;
}
}  // namespace

ComponentInfo KalmanEstimator::describe() {
  ComponentInfo i = Estimator::base_info(
      "kalman",
      "filtered range, lateral offset and rates per track (fused range cues, keypoint scale change)");
  i.doc =
      "Per track a Kalman filter over the object's ground point (x, y) and velocity in the ego frame. "
      "Predicted "
      "with constant velocity and moved by the ego's motion between frames (dataset poses; else ego speed "
      "and "
      "yaw rate; else the velocity is relative to the ego). Range measurement: the pinhole depth fy*H/h and "
      "the "
      "ground-contact depth; per track the ground cue's inverse depth is fitted as a + b x the pinhole's "
      "(pitch "
      "offset a, scale b; priors from pitch_sd_deg, height_rel_sd and ground_height_sd), mapped onto the "
      "pinhole "
      "scale, cleared of the frame's common offset (the body's pitch: the median residual of the frame's "
      "tracks) and fused by the cues' frame-to-frame noise. That noise is learnt from the recording: the box "
      "edge jitter from the second difference of 1/h over consecutive boxes (prior box_jitter_px), the "
      "ground "
      "cue's from the residuals and their lag correlation (prior pitch_jitter_deg); the log ends with both. "
      "A "
      "box touching the top or bottom border gives no pinhole range, one touching the bottom no ground "
      "range. "
      "Updates are gated (99.9 % Mahalanobis gate, and the class's max speed from share/hazard_limits.yaml); "
      "after three rejected updates in a row the track's state restarts. The keypoint scale ratio r of the "
      "box "
      "between frames (KLT corners, median pairwise distance ratio) updates closing/depth = (r-1)/dt. A "
      "track "
      "relabelled (car -> truck) is rescaled by the ratio of the class heights, so its TTC does not jump. "
      "Within a class group the size prior is the voted label's unless the heights the ground-contact range "
      "gives the track's whole boxes rule it out (posterior below 5 % with half the prior on the vote; "
      "size_from_ground); the state's label is the class that sizes it. "
      "Process noise: accel_sd_fraction x the class's max acceleration. Velocity, heading and scale_rate are "
      "reported after min_updates measurements (from the first, with the prior's wide covariance, by "
      "default); "
      "a track is reported until max_gap_s after its last accepted measurement; the state's covariance goes "
      "into ObjectState::covariance.";
  i.params = {
      ParamSpec::path("class_sizes", "")
          .describe("YAML of per-class real sizes (m); empty = <share>/class_sizes.yaml"),
      ParamSpec::path("limits", "")
          .describe("YAML of per-class kinematic limits; empty = <share>/hazard_limits.yaml"),
      ParamSpec::number("height_rel_sd", 0.10)
          .range(0, 1)
          .describe("relative spread of a class's real height"),
      ParamSpec::number("box_jitter_px", 1.5)
          .range(0, 100)
          .describe("detector jitter of a box edge (px): the prior until the boxes' own frame-to-frame noise "
                    "measures it"),
      ParamSpec::number("pitch_sd_deg", 0.5).range(0, 10).describe("uncertainty of the camera pitch (deg)"),
      ParamSpec::number("pitch_jitter_deg", 0.25)
          .range(0, 10)
          .describe("frame-to-frame pitch of the vehicle body (deg): the prior until the tracks' ground and "
                    "pinhole ranges measure it"),
      ParamSpec::number("ground_height_sd", 0.1)
          .range(0, 5)
          .describe("road surface height at the object relative to the ego's ground plane (m, 1 sigma)"),
      ParamSpec::number("min_horizon_gap_px", 10.0)
          .range(0, 10000)
          .describe("ground range only for box bottoms at least this far below the horizon (px)"),
      ParamSpec::number("border_margin_px", 2.0)
          .range(0, 1000)
          .describe(
              "box edges this close to the image border are truncated (in addition to the detector's flags)"),
      ParamSpec::boolean("keypoints", true).describe("update closing/depth from the keypoint scale change"),
      ParamSpec::number("keypoint_band_m", 5.0)
          .range(0, 1000)
          .describe("keypoint scale only for objects within this lateral distance of the ego (m)"),
      ParamSpec::number("keypoint_floor", 0.003)
          .range(0, 1)
          .describe("minimum standard error of ln(scale ratio) per frame pair"),
      ParamSpec::integer("min_updates", 1)
          .range(1, 1000)
          .describe(
              "measurements a track needs before velocity, heading and scale rate are reported (1: from "
              "the first frame, the prior's velocity with its wide covariance)"),
      ParamSpec::boolean("size_from_ground", true)
          .describe(
              "within a class group (car, truck, bus) size a track by the class whose height agrees with "
              "the height its ground-contact range gives its whole boxes, when that rules the detector's "
              "label out (a car called bus or truck, an SUV called truck); false = always the voted "
              "label's size"),
      ParamSpec::number("max_gap_s", 0.5)
          .range(0, 100)
          .describe("a track whose last accepted measurement is older than this (s) is not reported (held, "
                    "truncated or gated boxes are predicted until then)"),
      ParamSpec::number("accel_sd_fraction", 0.5)
          .range(0.01, 10)
          .describe("process noise: white-noise acceleration = this x the class's max_accel_mps2"),
      ParamSpec::number("ego_speed_mps", -1.0)
          .range(-1, 200)
          .describe("ego speed when the frame carries none (m/s); -1 = unknown (relative velocities)"),
      ParamSpec::string("distance_origin", "bumper")
          .one_of({"camera", "bumper", "ego_origin"})
          .describe("where distance_m is measured from along ego x (bumper = as the ground-truth gap)"),
      ParamSpec::number("front_overhang", 3.4).range(0, 20).describe("ego x of the front bumper (m)"),
  };
  for (ParamSpec& p : Corridor::params()) i.params.push_back(std::move(p));
  return i;
}

void KalmanEstimator::open(StageContext& ctx) {
  const Params& p = ctx.params();
  std::filesystem::path sizes = p.get_path("class_sizes");
  if (sizes.empty()) sizes = std::filesystem::path(share_dir()) / "class_sizes.yaml";
  priors_ = ClassPriors::load(sizes.string());
  ctx.record_resource(sizes);
  std::filesystem::path limits = p.get_path("limits");
  if (limits.empty()) limits = LimitsTable::default_path();
  limits_ = LimitsTable::load(limits.string());
  ctx.record_resource(limits);
  cfg_.height_rel_sd = p.get_double("height_rel_sd");
  cfg_.box_jitter_px = p.get_double("box_jitter_px");
  cfg_.pitch_sd_deg = p.get_double("pitch_sd_deg");
  cfg_.ground_height_sd = p.get_double("ground_height_sd");
  cfg_.min_horizon_gap_px = p.get_double("min_horizon_gap_px");
  cfg_.border_margin_px = p.get_double("border_margin_px");
  cfg_.keypoints = p.get_bool("keypoints");
  cfg_.keypoint_floor = p.get_double("keypoint_floor");
  cfg_.keypoint_band_m = p.get_double("keypoint_band_m");
  cfg_.min_updates = static_cast<int>(p.get_int("min_updates"));
  cfg_.size_from_ground = p.get_bool("size_from_ground");
  cfg_.max_gap_s = p.get_double("max_gap_s");
  cfg_.accel_sd_fraction = p.get_double("accel_sd_fraction");
  const double ego = p.get_double("ego_speed_mps");
  if (ego >= 0) cfg_.ego_speed_param = ego;
  cfg_.origin = p.get_string("distance_origin");
  cfg_.front_overhang = p.get_double("front_overhang");
  corridor_ = Corridor::from(p);
  tracks_.clear();
  keypoints_ = estimation::KeypointScaleTracker();
  jitter_ = estimation::RobustSpread();
  pitch_rows_ = estimation::RobustSpread();
  lag_products_ = estimation::LagCorrelation();
  noise_rows2_ = 0.0;
  cfg_.pitch_jitter_deg = p.get_double("pitch_jitter_deg");
}

void KalmanEstimator::finish(StageContext& ctx, Outputs& /*out*/) {
  std::string msg = "noise learnt from the recording: box edge jitter " + num_text(box_jitter_px(), 2) +
                    " px (stated " + num_text(cfg_.box_jitter_px, 2) + ", " + std::to_string(jitter_.size()) +
                    " box triples)";
  if (last_camera_)
    msg += ", ground-contact noise as a pitch " + num_text(pitch_jitter_deg(*last_camera_), 2) +
           " deg (body pitch, slopes, occluded box bottoms; stated " + num_text(cfg_.pitch_jitter_deg, 2) +
           ", " + std::to_string(pitch_rows_.size()) + " ground/pinhole residuals, lag correlation " +
           num_text(std::clamp(lag_products_.correlation(), 0.0, 0.9), 2) + ")";
  ctx.log(LogLevel::kInfo, msg);
}

void KalmanEstimator::drop_shadowed(ObjectStates& out) const {
  // A track held or predicted by the tracker while another track of the same kind of object is measured on
  // (nearly) the same box is that object's stale twin (the tracker started a new id instead of re-matching):
  // reporting both would count one vehicle twice.
  auto measured = [](const ObjectState& s) {
    return s.distance_method != "predicted" && s.distance_method != "rejected";
  };
  std::vector<ObjectState> kept;
  kept.reserve(out.objects.size());
  for (const ObjectState& s : out.objects) {
    bool shadowed = false;
    if (!measured(s))
      for (const ObjectState& o : out.objects) {
        if (&o == &s || !measured(o) || !groups_.same(o.label, s.label)) continue;
        const float inter = (o.box & s.box).area();
        const float uni = o.box.area() + s.box.area() - inter;
        if (uni > 0 && inter / uni >= 0.5f) {
          shadowed = true;
          break;
        }
      }
    if (!shadowed) kept.push_back(s);
  }
  out.objects = std::move(kept);
}

estimation::RangeAlignment KalmanEstimator::new_alignment(const CameraModel& cam) const {
  // Offset: a pitch error of pitch_sd_deg moves the horizon by fy tan(pitch), i.e. the ground cue's inverse
  // depth by tan(pitch) / hc. Scale: the class height's spread and a road surface off the ego's plane (dz /
  // hc).
  const double hc = std::max(cam.height_above_ground(), 0.1);
  const double offset_sd = std::tan(cfg_.pitch_sd_deg * kRadPerDeg) / hc;
  const double g = cfg_.ground_height_sd / hc;
  return estimation::RangeAlignment(offset_sd, std::sqrt(cfg_.height_rel_sd * cfg_.height_rel_sd + g * g));
}

double KalmanEstimator::ground_offset_of_frame(const CameraModel& cam, const Tracks& tracks,
                                               const cv::Size& image_size, const Config& live,
                                               double frame_t) {
  Config boxes_only = live;  // the residuals' share of box noise, without the pitch jitter being learnt
  boxes_only.pitch_jitter_deg = 0.0;
  // The ego's body pitches on every bump and brake, and the horizon row with it: every object's ground cue in
  // this frame is off by the same inverse depth (a row offset dv moves 1/z by dv / (fy hc) whatever the
  // distance). Each established track's residual against its own fit, g - a - b p, measures that offset;
  // their weighted median is removed from every ground cue of the frame. (One track alone then agrees with
  // itself: a frame's pitch and a track's range cannot be told apart from one object.)
  std::vector<std::pair<double, double>> res;  // residual, weight
  for (const Track& tr : tracks.items) {
    if (tr.misses != 0 || !priors_.has(tr.label)) continue;
    const auto m = tracks_.find(tr.id);
    if (m == tracks_.end() || m->second.label != tr.label || m->second.alignment.frames() < 3) continue;
    const unsigned truncated = tr.truncated | truncation_flags(tr.box, image_size, cfg_.border_margin_px);
    const RangeCue c = range_cue(cam, tr.box, truncated, priors_.at(tr.label).height, boxes_only);
    if (!c.pinhole_depth || !c.ground_depth) continue;
    const estimation::RangeAlignment& al = m->second.alignment;
    const double zg = *c.ground_depth, zp = *c.pinhole_depth;
    const double var = c.ground_noise_var / std::pow(zg, 4) +
                       al.scale() * al.scale() * c.pinhole_noise_var / std::pow(zp, 4);
    if (!(var > 0)) continue;
    const double rho = 1.0 / zg - al.offset() - al.scale() / zp;
    res.emplace_back(rho, 1.0 / var);
    // The same residual in image rows, without the box noise it carries, teaches the body's pitch jitter.
    const double row = cam.fy * cam.height_above_ground();
    const double noise_rows2 = var * row * row;
    pitch_rows_.add(rho * row);
    // Consecutive residuals of one track: the body's pitch moves in slow waves, and noise that persists over
    // frames averages out far less than white noise.
    TrackMemory& mem = m->second;
    if (mem.last_residual_rows && mem.last_residual_t < frame_t)
      lag_products_.add_pair(*mem.last_residual_rows, rho * row);
    mem.last_residual_rows = rho * row;
    mem.last_residual_t = frame_t;
    noise_rows2_ +=
        (noise_rows2 - noise_rows2_) / static_cast<double>(std::min<std::size_t>(pitch_rows_.size(), 400));
  }
  if (res.empty()) return 0.0;
  std::sort(res.begin(), res.end());
  double total = 0.0;
  for (const auto& r : res) total += r.second;
  double acc = 0.0;
  for (const auto& r : res) {
    acc += r.second;
    if (acc >= total / 2) return r.first;
  }
  return res.back().first;
}

void KalmanEstimator::learn_jitter(TrackMemory& mem, const Track& tr, unsigned truncated, double t) {
  // Three consecutive whole boxes at even spacing: the second difference of 1/h is zero for an object closing
  // at constant speed (h = fy H / z), so h^2 times it is the box height's noise: variance 6 x (2 x edge
  // jitter^2).
  const bool whole = !(truncated & (truncation::kTop | truncation::kBottom)) && tr.box.height > 1.0f;
  if (tr.misses != 0 || !whole || mem.label != tr.label) {
    mem.heights = 0;
    return;
  }
  if (mem.heights > 0 && !(t > mem.height_t[mem.heights - 1])) return;
  if (mem.heights == 3) {
    std::rotate(mem.height.begin(), mem.height.begin() + 1, mem.height.end());
    std::rotate(mem.height_t.begin(), mem.height_t.begin() + 1, mem.height_t.end());
    mem.heights = 2;
  }
  mem.height[mem.heights] = tr.box.height;
  mem.height_t[mem.heights] = t;
  ++mem.heights;
  if (mem.heights < 3) return;
  const double d1 = mem.height_t[1] - mem.height_t[0], d2 = mem.height_t[2] - mem.height_t[1];
  if (std::abs(d1 - d2) > 0.2 * std::max(d1, d2)) return;
  const double h = mem.height[1];
  jitter_.add(h * h * (1.0 / mem.height[0] - 2.0 / mem.height[1] + 1.0 / mem.height[2]) / std::sqrt(12.0));
}

double KalmanEstimator::box_jitter_px() const {
  return std::max(jitter_.blended(cfg_.box_jitter_px, kPriorSamples), 0.1);
}

double KalmanEstimator::pitch_jitter_deg(const CameraModel& cam) const {
  const double prior = cfg_.pitch_jitter_deg;
  if (pitch_rows_.size() == 0) return prior;
  // The residuals' spread in rows, less the part the boxes' own noise explains.
  const double measured2 = std::max(0.0, std::pow(pitch_rows_.sigma(), 2) - noise_rows2_);
  const double prior_rows = cam.fy * std::tan(prior * kRadPerDeg);
  const double n = static_cast<double>(pitch_rows_.size());
  // Persistent noise: an AR(1) process with lag correlation phi has (1 + phi) / (1 - phi) times the variance
  // of white noise when averaged over many frames.
  const double phi = std::clamp(lag_products_.correlation(), 0.0, 0.9);
  const double effective2 = measured2 * (1.0 + phi) / (1.0 - phi);
  const double rows =
      estimation::RobustSpread::blend(prior_rows, kPriorSamples, std::max(std::sqrt(effective2), 0.05), n);
  return std::atan(rows / cam.fy) / kRadPerDeg;
}

RangeCue KalmanEstimator::range_cue(const CameraModel& cam, const cv::Rect2f& box, unsigned truncated,
                                    double real_height, const Config& c) {
  RangeCue r;
  const double h = box.height;
  const double j2 = c.box_jitter_px * c.box_jitter_px;
  const cv::Point2d bottom(box.x + box.width / 2.0, box.y + box.height);
  if (!(truncated & (truncation::kTop | truncation::kBottom)) && h > 1.0) {
    const double z = cam.fy * real_height / h;
    // d = fy H / h: relative error of H and of h (two edges' jitter) add in quadrature.
    const double rel2 = c.height_rel_sd * c.height_rel_sd + 2.0 * j2 / (h * h);
    r.pinhole_depth = z;
    r.pinhole_var = z * z * rel2;
    r.pinhole_noise_var = z * z * 2.0 * j2 / (h * h);
  }
  if (!(truncated & truncation::kBottom)) {
    const std::optional<cv::Vec3d> g = cam.pixel_to_ground(bottom);
    if (g) {
      const cv::Vec3d pc = cam.ego_to_cam(*g);
      const double z = pc[2];
      const double hc = cam.height_above_ground();
      // Rows below the horizon: v - v_h = fy hc / z (level camera). A row error dv moves the depth by
      // z^2 / (fy hc) dv; a pitch error acts as a row error of fy * dpitch; a road surface dz off the plane
      // scales the depth by dz / hc.
      const double gap_px = cam.fy * hc / std::max(z, 1e-6);
      if (z > 0.5 && gap_px >= c.min_horizon_gap_px && hc > 0) {
        const double k = z * z / (cam.fy * hc);
        const double pitch_px = cam.fy * std::tan(c.pitch_sd_deg * kRadPerDeg);
        const double var = k * k * (j2 + pitch_px * pitch_px) + std::pow(z * c.ground_height_sd / hc, 2);
        r.ground_depth = z;
        r.ground_var = var;
        // From frame to frame the row also moves with the body's pitch (bumps, braking).
        const double jitter_px = cam.fy * std::tan(c.pitch_jitter_deg * kRadPerDeg);
        r.ground_noise_var = k * k * (j2 + jitter_px * jitter_px);
      }
    }
  }
  fuse(r, false);
  return r;
}

void KalmanEstimator::fuse(RangeCue& r, bool by_noise) {
  if (r.pinhole_depth && r.ground_depth) {
    // Both cues: by inverse variance, of their whole expected errors, or (on one scale, where the lasting
    // errors are the track's fit's) of their frame-to-frame noise alone.
    const double wp = 1.0 / (by_noise ? std::max(r.pinhole_noise_var, 1e-12) : *r.pinhole_var);
    const double wg = 1.0 / (by_noise ? std::max(r.ground_noise_var, 1e-12) : *r.ground_var);
    r.depth = (wp * *r.pinhole_depth + wg * *r.ground_depth) / (wp + wg);
    r.var = 1.0 / (wp + wg);
    r.noise_var = (wp * wp * r.pinhole_noise_var + wg * wg * r.ground_noise_var) / ((wp + wg) * (wp + wg));
    r.method = "fused";
  } else if (r.pinhole_depth) {
    r.depth = r.pinhole_depth;
    r.var = r.pinhole_var;
    r.noise_var = r.pinhole_noise_var;
    r.method = "pinhole";
  } else if (r.ground_depth) {
    r.depth = r.ground_depth;
    r.var = r.ground_var;
    r.noise_var = r.ground_noise_var;
    r.method = "ground";
  } else {
    r.depth.reset();
    r.var.reset();
    r.noise_var.reset();
    r.method.clear();
  }
}

RangeCue KalmanEstimator::aligned(const RangeCue& cue, const estimation::RangeAlignment& fit,
                                  double frame_offset) {
  if (!cue.ground_depth) return cue;
  RangeCue r = cue;
  const double zg = *cue.ground_depth;
  const double inv = fit.to_pinhole(1.0 / zg - frame_offset);
  if (inv > 1e-3) {
    // z = 1 / ((1/zg - a) / b): a depth error dzg moves z by (z / zg)^2 / b dzg.
    const double z = 1.0 / inv;
    const double k = z * z / (zg * zg) / fit.scale();
    r.ground_depth = z;
    r.ground_var = *cue.ground_var * k * k;
    r.ground_noise_var = cue.ground_noise_var * k * k;
  } else {
    // The track's fit puts this bottom row at or above its horizon: the ground cue says nothing here.
    r.ground_depth.reset();
    r.ground_var.reset();
    r.ground_noise_var = 0.0;
  }
  fuse(r, true);
  return r;
}

void KalmanEstimator::add_height_sample(TrackMemory& mem, const CameraModel& cam, const cv::Rect2f& box,
                                        unsigned truncated, const Config& live, double frame_offset) const {
  if (!cfg_.size_from_ground || (truncated & (truncation::kTop | truncation::kBottom)) || box.height <= 1.0f)
    return;
  // The cue's pinhole half does not matter here; only its ground range (camera height and pitch).
  const RangeCue cue = range_cue(cam, box, truncated, 1.0, live);
  if (!cue.ground_depth || !cue.ground_var) return;
  // Less the frame's common offset (the body's pitch), as every ground cue of the frame.
  const double inv = 1.0 / *cue.ground_depth - frame_offset;
  if (!(inv > 1e-3)) return;
  const double z = 1.0 / inv;
  const double j = live.box_jitter_px;
  // The ground range's lasting error (pitch, road height) and its frame-to-frame one (the body's pitch as
  // learnt from the recording: slopes and bumps that do not average out over a track's few frames), and the
  // box height's two edges.
  const double var = (*cue.ground_var + cue.ground_noise_var) / (*cue.ground_depth * *cue.ground_depth) +
                     2.0 * j * j / (static_cast<double>(box.height) * box.height);
  // A far box's ground range says little about its height (at 0.5 deg of pitch a car 40 m ahead is 25 % off).
  if (var > kMaxHeightSampleVar) return;
  if (mem.log_height.size() == kHeightSamples) {
    mem.log_height.erase(mem.log_height.begin());
    mem.log_height_var.erase(mem.log_height_var.begin());
  }
  mem.log_height.push_back(std::log(box.height * z / cam.fy));
  mem.log_height_var.push_back(var);
}

std::string KalmanEstimator::size_class(const TrackMemory& mem, const std::string& voted,
                                        std::string* why) const {
  if (why) why->clear();
  const std::string& current = mem.filter.initialised() ? mem.label : voted;
  if (!cfg_.size_from_ground || mem.log_height.size() < kMinHeightSamples) return voted;
  std::vector<std::pair<std::string, double>> cand;  // class, ln height
  for (const auto& [name, sz] : priors_.all())
    if (groups_.same(name, voted) && sz.height > 0) cand.emplace_back(name, std::log(sz.height));
  if (cand.size() < 2) return voted;
  // The median implied height; its error is mostly the track's lasting one (pitch, road height, the
  // object's own height within its class), which does not average out over frames.
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double m = median(mem.log_height);
  const double var = cfg_.height_rel_sd * cfg_.height_rel_sd + median(mem.log_height_var);
  // Posterior over the group's classes: the detector's vote holds half the prior, the others share the rest.
  std::vector<double> lp;
  double top = -1e300;
  for (const auto& [name, lh] : cand) {
    const double prior = name == voted ? 0.5 : 0.5 / static_cast<double>(cand.size() - 1);
    lp.push_back(std::log(prior) - (m - lh) * (m - lh) / (2.0 * var));
    top = std::max(top, lp.back());
  }
  double sum = 0;
  for (double& v : lp) sum += (v = std::exp(v - top));
  auto post = [&](const std::string& name) {
    for (size_t i = 0; i < cand.size(); ++i)
      if (cand[i].first == name) return lp[i] / sum;
    return 0.0;
  };
  // Keep an override while the evidence still allows it; follow the vote while the evidence allows that;
  // else the class the heights point to.
  std::string pick;
  if (current != voted && post(current) >= kHeightRuleOut)
    pick = current;
  else if (post(voted) >= kHeightRuleOut)
    return voted;
  else
    pick = cand[static_cast<size_t>(std::max_element(lp.begin(), lp.end()) - lp.begin())].first;
  if (why && pick != voted) {
    *why = "labelled '" + voted + "' by the detector, sized as '" + pick +
           "': its ground-contact range puts " + "its whole boxes at a median height of " +
           num_text(std::exp(m), 2) + " m (" + std::to_string(mem.log_height.size()) + " boxes; '" + voted +
           "' " + num_text(priors_.at(voted).height, 2) + " m, '" + pick + "' " +
           num_text(priors_.at(pick).height, 2) + " m)";
  }
  return pick;
}

ObjectStates KalmanEstimator::estimate(StageContext& ctx, const Tracks& tracks, const Frame& frame) {
  CameraModel cam = frame.camera;
  if (!cam.valid())
    throw Error(
        "frame " + std::to_string(frame.index) + " (" + frame.source_id +
        "): the camera model has no intrinsics (width, height, fx, fy); the kalman estimator needs them");
  if (!frame.image.empty() && (frame.image.cols != cam.width || frame.image.rows != cam.height))
    cam = cam.scaled_to(frame.image.cols, frame.image.rows);
  const cv::Size image_size(cam.width, cam.height);
  const double t = frame.timestamp;
  const double cam_x = cam.t_ego_cam[0];

  ObjectStates out;
  out.frame_index = frame.index;
  out.timestamp = t;
  out.ego_speed_mps = frame.ego.speed_mps ? frame.ego.speed_mps : cfg_.ego_speed_param;
  out.ego_yaw_rate = frame.ego.yaw_rate;
  double ego_vx = 0.0;  // the ego's velocity along its own x
  if (frame.ego.velocity_world && frame.ego.T_world_ego) {
    const cv::Matx44d& T = *frame.ego.T_world_ego;
    const cv::Vec3d& w = *frame.ego.velocity_world;
    ego_vx = T(0, 0) * w[0] + T(1, 0) * w[1] + T(2, 0) * w[2];
    if (!out.ego_speed_mps)
      out.ego_speed_mps = std::hypot(ego_vx, T(0, 1) * w[0] + T(1, 1) * w[1] + T(2, 1) * w[2]);
  } else if (out.ego_speed_mps) {
    ego_vx = *out.ego_speed_mps;
  }
  const bool absolute = frame.ego.T_world_ego.has_value() || out.ego_speed_mps.has_value();
  if (!absolute) ego_vx = 0.0;
  out.distance_origin_x = cfg_.origin == "camera"   ? cam_x
                          : cfg_.origin == "bumper" ? cfg_.front_overhang
                                                    : 0.0;

  estimation::EgoDelta delta;
  if (have_last_ && t > last_t_) {
    if (frame.ego.T_world_ego && last_pose_)
      delta = delta_from_poses(*last_pose_, *frame.ego.T_world_ego);
    else if (out.ego_speed_mps)
      delta = delta_from_speed(*out.ego_speed_mps, frame.ego.yaw_rate, t - last_t_);
  }
  delta.absolute = absolute;
  if (frame.ego.T_world_ego)
    last_pose_ = *frame.ego.T_world_ego;
  else
    last_pose_.reset();
  last_t_ = t;
  have_last_ = true;

  // Keypoint scale ratios of this frame's matched boxes.
  std::map<int64_t, estimation::ScaleRatio> ratios;
  if (cfg_.keypoints && !frame.image.empty()) {
    // Only objects that could come into the ego's path need the closing-speed cue; tracking corners costs a
    // few milliseconds per box, so boxes whose state lies farther than keypoint_band_m to the side (or
    // behind) are left to the range cues. A track seen for the first time is always measured.
    std::map<int64_t, cv::Rect2f> boxes;
    for (const Track& tr : tracks.items) {
      if (tr.misses != 0) continue;
      auto m = tracks_.find(tr.id);
      if (m != tracks_.end() && m->second.filter.initialised()) {
        const cv::Vec4d& x = m->second.filter.state();
        if (std::abs(x[1]) > cfg_.keypoint_band_m || x[0] <= cam_x) continue;
      }
      boxes[tr.id] = tr.box;
    }
    ratios = keypoints_.update(frame.image, t, boxes);
  }

  // This frame's noise model: the box jitter and the body's pitch as learnt so far.
  Config live = cfg_;
  live.box_jitter_px = box_jitter_px();
  live.pitch_jitter_deg = pitch_jitter_deg(cam);
  const double frame_offset = ground_offset_of_frame(cam, tracks, image_size, live, t);
  last_camera_ = cam;
  std::set<int64_t> alive;
  for (const Track& tr : tracks.items) {
    alive.insert(tr.id);
    if (!priors_.has(tr.label)) {
      if (warned_.insert(tr.label).second)
        ctx.log(LogLevel::kWarning,
                "no size prior for class '" + tr.label + "'; its tracks are not estimated");
      continue;
    }
    auto found = tracks_.find(tr.id);
    if (found == tracks_.end()) {
      estimation::TrackFilterConfig fc;
      if (limits_.has(tr.label)) {
        const KinematicLimits& L = limits_.at(tr.label);
        fc.max_speed_mps = L.max_speed_mps;
        fc.accel_sd = cfg_.accel_sd_fraction * L.max_accel_mps2;
        fc.init_velocity_sd = std::min(L.max_speed_mps / 3.0, 15.0);
      }
      found = tracks_.emplace(tr.id, TrackMemory(estimation::TrackFilter(fc), tr.label, new_alignment(cam)))
                  .first;
    }
    TrackMemory& mem = found->second;
    estimation::TrackFilter& f = mem.filter;
    unsigned truncated = tr.truncated | truncation_flags(tr.box, image_size, cfg_.border_margin_px);
    if (f.initialised()) f.predict(t, delta);
    if (f.initialised() && !(truncated & truncation::kBottom) &&
        cut_below_picture(cam, f, tr.box, image_size.height))
      truncated |= truncation::kBottom;
    if (tr.misses == 0) add_height_sample(mem, cam, tr.box, truncated, live, frame_offset);
    std::string why;
    const std::string sized_as = size_class(mem, tr.label, &why);
    const ClassSize& size = priors_.at(sized_as);
    // The class that sizes the track changed (the detector's vote, or the ground range's evidence): the
    // state's range was measured on the other class's height. Fused ranges are on the pinhole cue's scale
    // (the ground cue is aligned to it), so range and relative velocity scale with the ratio of the heights,
    // and the track's cue ratio moves by the same factor; TTC stays where it was.
    if (mem.label != sized_as) {
      if (f.initialised() && priors_.has(mem.label)) {
        const double k = size.height / priors_.at(mem.label).height;
        f.rescale(k, cam_x, ego_vx);
        mem.alignment.rescale_pinhole(k);
      }
      if (limits_.has(sized_as)) {
        const KinematicLimits& L = limits_.at(sized_as);
        f.set_class_limits(L.max_speed_mps, cfg_.accel_sd_fraction * L.max_accel_mps2);
      }
      if (!why.empty())
        ctx.log(LogLevel::kInfo,
                "frame " + std::to_string(frame.index) + ", track " + std::to_string(tr.id) + ": " + why);
    }
    mem.label = sized_as;

    ObjectState s;
    s.track_id = tr.id;
    s.label = sized_as;
    s.score = tr.score;
    s.box = tr.box;
    s.box_height_px = tr.box.height;
    s.age = tr.age;
    s.misses = tr.misses;
    s.annotation_index = tr.annotation_index;
    s.width_m = size.width;
    s.length_m = size.length;
    s.truncated = truncated;
    s.distance_method = "predicted";

    if (tr.misses == 0) {
      learn_jitter(mem, tr, s.truncated, t);
      RangeCue cue = range_cue(cam, tr.box, s.truncated, size.height, live);
      if (cue.pinhole_depth && cue.ground_depth) {
        const double zg = *cue.ground_depth, zp = *cue.pinhole_depth;
        mem.alignment.add(1.0 / zg, 1.0 / zp, cue.ground_noise_var / std::pow(zg, 4),
                          cue.pinhole_noise_var / std::pow(zp, 4));
      }
      cue = aligned(cue, mem.alignment, frame_offset);
      if (cue.depth) {
        const cv::Point2d bottom(tr.box.x + tr.box.width / 2.0, tr.box.y + tr.box.height);
        const cv::Vec3d p = cam.cam_to_ego(cv::Vec3d((bottom.x - cam.cx) * *cue.depth / cam.fx,
                                                     (bottom.y - cam.cy) * *cue.depth / cam.fy, *cue.depth));
        // Along the viewing ray the depth error moves x and y together; across it, the column's jitter (and a
        // side cut off by the border) moves y.
        const cv::Vec2d a((p[0] - cam_x) / *cue.depth, (p[1] - cam.t_ego_cam[1]) / *cue.depth);
        double lat_px = live.box_jitter_px;
        if (s.truncated & (truncation::kLeft | truncation::kRight)) lat_px += tr.box.width / 2.0;
        const double lat = lat_px * *cue.depth / cam.fx;
        const double v = *cue.noise_var;
        cv::Matx22d R(a[0] * a[0] * v, a[0] * a[1] * v, a[0] * a[1] * v, a[1] * a[1] * v + lat * lat);
        const cv::Vec2d z(p[0], p[1]);
        if (!f.initialised()) {
          f.init(t, z, R);
        } else {
          const auto u = f.update_position(z, R);
          if (u == estimation::TrackFilter::Update::kImpossible ||
              u == estimation::TrackFilter::Update::kGated)
            s.distance_method = "rejected";
          else
            s.distance_method = cue.method;
        }
        if (s.distance_method == "predicted") s.distance_method = cue.method;
      } else if (f.initialised() && f.state()[0] - cam_x > 0.5) {
        // No range from this box (cut off at the top or bottom: a car close ahead, a person crossing close in
        // front seen from the waist up), but its column still says where across the view it is: the point
        // of the box's centre at the predicted depth lies on the object's vertical, so the ray from the
        // camera through it bounds the sideways position. Without it a crossing person's offset stays where
        // the last whole box put it while the person walks into the ego's path.
        const double depth = f.state()[0] - cam_x;
        const cv::Point2d c(tr.box.x + tr.box.width / 2.0, tr.box.y + tr.box.height / 2.0);
        const cv::Vec3d p = cam.cam_to_ego(
            cv::Vec3d((c.x - cam.cx) * depth / cam.fx, (c.y - cam.cy) * depth / cam.fy, depth));
        double lat_px = live.box_jitter_px;
        if (s.truncated & (truncation::kLeft | truncation::kRight)) lat_px += tr.box.width / 2.0;
        const double sd = lat_px * depth / cam.fx;
        const cv::Vec2d origin(cam.t_ego_cam[0], cam.t_ego_cam[1]);
        if (f.update_bearing(origin, cv::Vec2d(p[0], p[1]) - origin, sd * sd) ==
            estimation::TrackFilter::Update::kAccepted)
          s.distance_method = "bearing";
      }
      auto r = ratios.find(tr.id);
      if (f.initialised() && r != ratios.end() && r->second.valid()) {
        const estimation::ScaleRatio& q = r->second;
        const double ls = std::max(q.log_sigma, cfg_.keypoint_floor);
        const double sd = q.ratio * ls / q.dt;
        f.update_inverse_ttc(q.inverse_ttc(), sd * sd, cam_x, ego_vx);
      }
    }
    if (!f.initialised()) continue;
    const cv::Vec4d& x = f.state();
    // An extrapolated state is reported for a short gap only, and never once it has been carried into the ego
    // (a collision no measurement saw is the model's, not the scene's).
    const bool measured =
        s.distance_method != "predicted" && s.distance_method != "rejected" && s.distance_method != "bearing";
    if (t - f.last_update() > cfg_.max_gap_s + 1e-9) continue;
    if (!measured && x[0] <= cfg_.front_overhang) continue;

    s.distance_m = x[0] - out.distance_origin_x;
    s.lateral_m = x[1];
    if (f.updates() >= cfg_.min_updates) {
      const cv::Vec2d vrel(x[2] - ego_vx, x[3]);
      s.velocity_rel = vrel;
      s.covariance = f.covariance();
      if (absolute) {
        s.speed_mps = std::hypot(x[2], x[3]);
        s.heading_rad = std::atan2(x[3], x[2]);
      }
      const double depth = x[0] - cam_x;
      if (depth > 0.5) s.scale_rate = -vrel[0] / depth;
    }
    s.in_path = corridor_.contains(out, s);
    out.objects.push_back(std::move(s));
  }
  for (auto it = tracks_.begin(); it != tracks_.end();)
    it = alive.count(it->first) ? std::next(it) : tracks_.erase(it);
  drop_shadowed(out);
  return out;
}

}  // namespace hf
