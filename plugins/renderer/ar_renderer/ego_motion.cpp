// Ego motion for anchoring a hazard in the world: dataset poses, road-plane optical flow or a constant speed.
#include "ego_motion.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "hazardforge/error.hpp"

namespace hf::render {

namespace {

std::string frame_name(const Frame& f) {
  return "frame " + std::to_string(f.index) + " (t=" + std::to_string(f.timestamp) + " s)";
}

cv::Matx33d rot_of(const cv::Matx44d& T) {
  return {T(0, 0), T(0, 1), T(0, 2), T(1, 0), T(1, 1), T(1, 2), T(2, 0), T(2, 1), T(2, 2)};
}

cv::Matx44d compose(const cv::Matx33d& R, const cv::Vec3d& t) {
  return {R(0, 0), R(0, 1), R(0, 2), t[0], R(1, 0), R(1, 1), R(1, 2), t[1],
          R(2, 0), R(2, 1), R(2, 2), t[2], 0,       0,       0,       1};
}

// Ground point of a full-resolution pixel, undistorting first when the camera has distortion.
std::optional<cv::Vec3d> ground_of(const CameraModel& cam, cv::Point2d px) {
  if (!cam.distortion.empty()) {
    std::vector<cv::Point2d> in{px}, out;
    cv::undistortPoints(in, out, cv::Mat(cam.K()), cam.distortion, cv::noArray(), cv::Mat(cam.K()));
    px = out[0];
  }
  return cam.pixel_to_ground(px);
}

}  // namespace

int horizon_row(const CameraModel& cam) {
  // Far ground points straight ahead and to the sides; with zero roll they share one row.
  double row = -1e9;
  for (double y : {-20.0, 0.0, 20.0}) {
    auto p = cam.project_ego(cam.t_ego_cam + cv::Vec3d(1000.0, y, -cam.t_ego_cam[2]));
    if (p) row = std::max(row, p->y);
  }
  if (row < -1e8) return cam.height;  // camera looks up: no ground in view
  return std::clamp(static_cast<int>(std::ceil(row)), 0, cam.height);
}

cv::Matx44d planar_pose(double x, double y, double yaw) {
  const double c = std::cos(yaw), s = std::sin(yaw);
  return compose(cv::Matx33d(c, -s, 0, s, c, 0, 0, 0, 1), cv::Vec3d(x, y, 0));
}

cv::Matx44d invert_rigid(const cv::Matx44d& T) {
  const cv::Matx33d Rt = rot_of(T).t();
  const cv::Vec3d t(T(0, 3), T(1, 3), T(2, 3));
  return compose(Rt, -(Rt * t));
}

double yaw_of(const cv::Matx44d& T) {
  return std::atan2(T(1, 0), T(0, 0));
}

EgoMotionMode parse_ego_motion_mode(const std::string& s) {
  if (s == "auto") return EgoMotionMode::kAuto;
  if (s == "poses") return EgoMotionMode::kPoses;
  if (s == "flow") return EgoMotionMode::kFlow;
  if (s == "constant_speed") return EgoMotionMode::kConstantSpeed;
  if (s == "track") return EgoMotionMode::kTrack;
  throw Error("ego_motion '" + s + "' is not one of auto, poses, flow, constant_speed");
}

// ---- FlowEgoMotion
// ---------------------------------------------------------------------------------------------

namespace {
constexpr int kLkLevels = 3;
// Full-resolution rows of the road between the two ranges (nullopt when there is none in view).
std::optional<std::pair<int, int>> road_rows(const CameraModel& cam, const FlowOptions& o) {
  const int top = static_cast<int>(horizon_row(cam) + o.horizon_margin_px);
  int far_row = top, near_row = cam.height;
  if (auto p = cam.project_ego(cam.t_ego_cam + cv::Vec3d(o.max_range_m, 0, -cam.t_ego_cam[2])))
    far_row = std::max(top, static_cast<int>(p->y));
  if (auto p = cam.project_ego(cam.t_ego_cam + cv::Vec3d(o.min_range_m, 0, -cam.t_ego_cam[2])))
    near_row = std::min(cam.height, static_cast<int>(std::ceil(p->y)));
  if (near_row - far_row < 16) return std::nullopt;
  return std::make_pair(far_row, near_row);
}
}  // namespace

FlowFrame FlowEgoMotion::prepare(const cv::Mat& img, const CameraModel& cam) const {
  FlowFrame ff;
  const auto rows = road_rows(cam, opt_);
  if (!rows || img.empty()) return ff;
  // Margin so features keep their LK window while they move towards the bottom of the band.
  const int margin = static_cast<int>(std::ceil(4 * opt_.win_px / opt_.scale));
  ff.row0 = std::max(0, rows->first - margin);
  const int row1 = std::min(img.rows, rows->second + margin);
  cv::Mat band = img.rowRange(ff.row0, row1), gray;
  if (band.channels() == 3) {
    cv::cvtColor(band, gray, cv::COLOR_BGR2GRAY);
  } else {
    gray = band;
  }
  cv::Mat small;
  if (std::abs(opt_.scale - 1.0) < 1e-9) {
    small = gray.clone();
  } else {
    cv::resize(gray, small, cv::Size(), opt_.scale, opt_.scale, cv::INTER_AREA);
  }
  ff.sx = static_cast<double>(small.cols) / gray.cols;
  ff.sy = static_cast<double>(small.rows) / gray.rows;
  ff.far_row = static_cast<int>((rows->first - ff.row0) * ff.sy);
  ff.near_row = std::min(small.rows, static_cast<int>(std::ceil((rows->second - ff.row0) * ff.sy)));
  cv::buildOpticalFlowPyramid(small, ff.pyramid, cv::Size(opt_.win_px, opt_.win_px), kLkLevels);
  return ff;
}

PlanarMotion FlowEgoMotion::estimate(const cv::Mat& prev, const cv::Mat& cur, const CameraModel& cam,
                                     const std::vector<cv::Rect2f>& exclude) const {
  return estimate(prepare(prev, cam), prepare(cur, cam), cam, exclude, nullptr);
}

PlanarMotion FlowEgoMotion::estimate(const FlowFrame& prev, const FlowFrame& cur, const CameraModel& cam,
                                     const std::vector<cv::Rect2f>& exclude, FlowCarry* carry) const {
  if (!carry || !carry->homography) return track(prev, cur, cam, exclude, carry, std::nullopt);
  // With the last motion as the starting guess the two finest pyramid levels are enough; when the motion
  // changed too much for that (a sharp turn ending, a bump), the features are tracked again from zero motion
  // through the whole pyramid.
  const std::optional<cv::Matx33d> guess = carry->homography;
  const std::vector<cv::Point2f> points = carry->points;
  PlanarMotion pm = track(prev, cur, cam, exclude, carry, guess);
  if (pm.ok) return pm;
  carry->points = points;
  carry->homography.reset();
  return track(prev, cur, cam, exclude, carry, std::nullopt);
}

PlanarMotion FlowEgoMotion::track(const FlowFrame& prev, const FlowFrame& cur, const CameraModel& cam,
                                  const std::vector<cv::Rect2f>& exclude, FlowCarry* carry,
                                  const std::optional<cv::Matx33d>& guess) const {
  PlanarMotion pm;
  if (prev.empty() || cur.empty()) {
    pm.why = "no road between flow_min_range_m and flow_max_range_m below the horizon";
    if (carry) carry->clear();
    return pm;
  }
  const cv::Mat& img0 = prev.pyramid[0];
  // Where features may be: road rows in range, outside detected objects (they move on their own).
  cv::Mat mask(img0.size(), CV_8U, cv::Scalar(0));
  mask.rowRange(prev.far_row, prev.near_row).setTo(255);
  for (const cv::Rect2f& b : exclude) {
    cv::Rect r(static_cast<int>(std::floor(b.x * prev.sx)) - 3,
               static_cast<int>(std::floor((b.y - prev.row0) * prev.sy)) - 3,
               static_cast<int>(std::ceil(b.width * prev.sx)) + 6,
               static_cast<int>(std::ceil(b.height * prev.sy)) + 6);
    r &= cv::Rect(0, 0, mask.cols, mask.rows);
    if (r.area() > 0) mask(r).setTo(0);
  }
  std::vector<cv::Point2f> p0;
  if (carry)
    for (const cv::Point2f& q : carry->points) {
      const cv::Point qi(cvRound(q.x), cvRound(q.y));
      if (qi.inside(cv::Rect(0, 0, mask.cols, mask.rows)) && mask.at<uint8_t>(qi)) p0.push_back(q);
    }
  if (static_cast<int>(p0.size()) < opt_.max_corners / 2) {
    // Replenish away from the features kept.
    cv::Mat free = mask.clone();
    for (const auto& q : p0) cv::circle(free, q, opt_.min_distance_px, cv::Scalar(0), cv::FILLED);
    std::vector<cv::Point2f> fresh;
    cv::goodFeaturesToTrack(img0, fresh, opt_.max_corners - static_cast<int>(p0.size()), opt_.quality,
                            opt_.min_distance_px, free, 7);
    p0.insert(p0.end(), fresh.begin(), fresh.end());
  }
  if (carry) carry->clear();
  if (static_cast<int>(p0.size()) < opt_.min_inliers) {
    pm.why = "only " + std::to_string(p0.size()) + " road features";
    return pm;
  }
  std::vector<cv::Point2f> p1, pb;
  std::vector<uint8_t> st, st_b;
  std::vector<float> err;
  const cv::Size win(opt_.win_px, opt_.win_px);
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  auto full = [](const FlowFrame& f, const cv::Point2f& q) {  // band pixel centre -> full-resolution pixel
    return cv::Point2d((q.x + 0.5) / f.sx - 0.5, (q.y + 0.5) / f.sy - 0.5 + f.row0);
  };
  // Start LK where the last motion would take each feature (the road's homography changes little from frame
  // to frame): only the change of motion is left to track, which the two finest pyramid levels cover.
  int lk_flags = 0;
  if (guess) {
    p1.reserve(p0.size());
    for (const cv::Point2f& q : p0) {
      const cv::Point2d g = full(prev, q);
      const cv::Vec3d h = *guess * cv::Vec3d(g.x, g.y, 1.0);
      if (h[2] <= 1e-9) {
        p1.push_back(q);
        continue;
      }
      p1.emplace_back(static_cast<float>((h[0] / h[2] + 0.5) * cur.sx - 0.5),
                      static_cast<float>((h[1] / h[2] - cur.row0 + 0.5) * cur.sy - 0.5));
    }
    lk_flags = cv::OPTFLOW_USE_INITIAL_FLOW;
  }
  cv::calcOpticalFlowPyrLK(prev.pyramid, cur.pyramid, p0, p1, st, err, win, guess ? 1 : kLkLevels, term,
                           lk_flags);
  // Forward-backward check: a track that does not come back to where it started is unreliable.
  const bool fb = opt_.fb_max_px > 0;
  if (fb) cv::calcOpticalFlowPyrLK(cur.pyramid, prev.pyramid, p1, pb, st_b, err, win, kLkLevels, term);
  std::vector<cv::Point2d> a, b;
  std::vector<cv::Point2f> b_band;
  for (size_t i = 0; i < p0.size(); ++i) {
    if (!st[i]) continue;
    if (fb && (!st_b[i] || cv::norm(pb[i] - p0[i]) > opt_.fb_max_px * prev.sx)) continue;
    a.push_back(full(prev, p0[i]));
    b.push_back(full(cur, p1[i]));
    b_band.push_back(p1[i]);
  }
  pm.tracked = static_cast<int>(a.size());
  if (pm.tracked < opt_.min_inliers) {
    pm.why = "only " + std::to_string(pm.tracked) + " features tracked";
    return pm;
  }
  std::vector<uint8_t> inl;
  cv::Mat H = cv::findHomography(a, b, cv::RANSAC, opt_.ransac_px, inl, 2000, 0.995);
  if (H.empty()) {
    pm.why = "no road-plane homography";
    return pm;
  }
  // The plane's metric geometry is known (camera height and mounting): inliers become ground points, and the
  // homography's planar part is the rigid motion between them.
  std::vector<cv::Vec2d> P, Q;
  std::vector<double> W;
  std::vector<size_t> src;  // index into a/b of each ground pair
  for (size_t i = 0; i < a.size(); ++i) {
    if (!inl[i]) continue;
    auto ga = ground_of(cam, a[i]), gb = ground_of(cam, b[i]);
    if (!ga || !gb) continue;
    const double ra = (*ga)[0] - cam.t_ego_cam[0], rb = (*gb)[0] - cam.t_ego_cam[0];
    if (ra < opt_.min_range_m || ra > opt_.max_range_m || rb < opt_.min_range_m || rb > opt_.max_range_m)
      continue;
    P.emplace_back((*ga)[0], (*ga)[1]);
    Q.emplace_back((*gb)[0], (*gb)[1]);
    W.push_back(std::pow(std::max(ra, 1.0), -opt_.weight_power));
    src.push_back(i);
  }
  // Weighted least-squares rigid motion (2D Kabsch): a pixel of error costs X^2 / (f h) metres at range X, so
  // near points are trusted more.
  auto fit = [&W](const std::vector<cv::Vec2d>& P, const std::vector<cv::Vec2d>& Q,
                  const std::vector<bool>& use, double& th, cv::Vec2d& t) {
    cv::Vec2d mp(0, 0), mq(0, 0);
    double sw = 0;
    for (size_t i = 0; i < P.size(); ++i)
      if (use[i]) {
        mp += W[i] * P[i];
        mq += W[i] * Q[i];
        sw += W[i];
      }
    mp /= sw;
    mq /= sw;
    double sxx = 0, sxy = 0;
    for (size_t i = 0; i < P.size(); ++i)
      if (use[i]) {
        const cv::Vec2d p = P[i] - mp, q = Q[i] - mq;
        sxx += W[i] * (p[0] * q[0] + p[1] * q[1]);
        sxy += W[i] * (p[0] * q[1] - p[1] * q[0]);
      }
    th = std::atan2(sxy, sxx);
    const double c = std::cos(th), sn = std::sin(th);
    t = mq - cv::Vec2d(c * mp[0] - sn * mp[1], sn * mp[0] + c * mp[1]);
  };
  std::vector<bool> use(P.size(), true);
  if (static_cast<int>(P.size()) < opt_.min_inliers) {
    pm.why = "only " + std::to_string(P.size()) + " road-plane inliers in range";
    return pm;
  }
  // Few tracks agreeing on one plane motion means the tracks are mostly wrong (large motion, smooth asphalt).
  if (P.size() < opt_.min_inlier_ratio * pm.tracked) {
    pm.why = "only " + std::to_string(P.size()) + " of " + std::to_string(pm.tracked) +
             " tracks agree on a road-plane motion";
    return pm;
  }
  double th = 0;
  cv::Vec2d t;
  fit(P, Q, use, th, t);
  // One refinement pass without the worst residuals (points slightly off the plane: kerbs, markings' edges).
  std::vector<double> res(P.size());
  const double c = std::cos(th), sn = std::sin(th);
  for (size_t i = 0; i < P.size(); ++i) {
    const cv::Vec2d q = cv::Vec2d(c * P[i][0] - sn * P[i][1], sn * P[i][0] + c * P[i][1]) + t;
    res[i] = cv::norm(q - Q[i]) * std::sqrt(W[i]);
  }
  std::vector<double> sorted = res;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  const double cut = 3.0 * sorted[sorted.size() / 2] + 1e-9;
  int kept = 0;
  for (size_t i = 0; i < P.size(); ++i) kept += (use[i] = res[i] <= cut) ? 1 : 0;
  if (kept >= opt_.min_inliers) fit(P, Q, use, th, t);
  pm.inliers = kept >= opt_.min_inliers ? kept : static_cast<int>(P.size());
  if (carry) {
    for (size_t i = 0; i < P.size(); ++i)
      if (use[i] || kept < opt_.min_inliers) carry->points.push_back(b_band[src[i]]);
    carry->homography = cv::Matx33d(H);
  }
  pm.dx = t[0];
  pm.dy = t[1];
  pm.dyaw = th;
  pm.ok = true;
  return pm;
}

// ---- EgoTrajectory
// ---------------------------------------------------------------------------------------------

std::vector<std::string> EgoTrajectory::take_warnings() {
  std::vector<std::string> w;
  w.swap(warnings_);
  return w;
}

void EgoTrajectory::update(const Frame& f, const std::vector<cv::Rect2f>& exclude) {
  if (!resolved_) {
    EgoMotionMode m = opt_.mode;
    if (m == EgoMotionMode::kAuto)
      m = f.ego.T_world_ego ? EgoMotionMode::kPoses
          : f.ego_track && f.ego_track->samples.size() >= 2 ? EgoMotionMode::kTrack
                                                             : EgoMotionMode::kFlow;
    resolved_ = m;
  }
  const double t = f.timestamp;
  const double dt = have_prev_ ? t - prev_t_ : 0.0;
  const cv::Matx44d prev_pose = current_;
  if (*resolved_ == EgoMotionMode::kPoses) {
    if (!f.ego.T_world_ego)
      throw Error(frame_name(f) +
                  ": ego_motion 'poses' needs the ego pose (Frame.ego.T_world_ego), which this "
                  "frame lacks; use ego_motion: flow or constant_speed for sources without poses");
    // The road the ego drives on is its ground plane, in the planner as here: its pose on the map (x, y,
    // heading), without the body's pitch and roll. Datasets' attitude comes from an IMU while their height
    // stays fixed (nuScenes: z = 0 throughout, pitch -4.6..2.8 deg in scene-0916), and chaining that pitch
    // over the tens of metres between a hazard's anchor frame and the current one lifted it off the road
    // (0.35 m at frame 30 of the nuScenes cut-in: drawn a third taller than its box, and called a bus).
    const cv::Matx44d& T = *f.ego.T_world_ego;
    current_ = planar_pose(T(0, 3), T(1, 3), yaw_of(T));
    last_source_ = "poses";
  } else if (*resolved_ == EgoMotionMode::kTrack) {
    if (!f.ego_track || f.ego_track->samples.size() < 2)
      throw Error(frame_name(f) +
                  ": ego_motion 'track' needs the recording's ego track (Frame.ego_track: dataset poses or the "
                  "ego motion the video source estimated), which this frame lacks");
    const EgoTrackSample e = f.ego_track->at(t);
    current_ = planar_pose(e.x, e.y, e.yaw);
    last_source_ = "track (" + f.ego_track->source + ")";
  } else if (!have_prev_) {
    current_ = cv::Matx44d::eye();  // odometry starts at the first frame
    last_source_ = *resolved_ == EgoMotionMode::kFlow ? "flow" : "constant_speed";
  } else {
    cv::Vec3d rate;  // (vx, vy, yaw rate) in the previous ego frame
    bool have = false;
    if (*resolved_ == EgoMotionMode::kFlow) {
      if (!f.camera.valid())
        throw Error(frame_name(f) + ": ego_motion 'flow' needs the frame's camera model");
      FlowFrame cur = flow_.prepare(f.image, f.camera);
      last_flow_ = dt > 0 ? flow_.estimate(prev_flow_, cur, f.camera, exclude, &carry_) : PlanarMotion{};
      prev_flow_ = std::move(cur);
      if (last_flow_.ok) {
        // Ego displacement in the previous frame: the inverse of the world points' apparent motion.
        const double th = last_flow_.dyaw, c = std::cos(th), s = std::sin(th);
        const cv::Vec2d d(-(c * last_flow_.dx + s * last_flow_.dy),
                          -(-s * last_flow_.dx + c * last_flow_.dy));
        const double speed = cv::norm(d) / dt;
        if (speed <= opt_.flow.max_speed_mps) {
          // As a body-frame velocity (the chord is rotated back by half the turn, as integration below adds
          // it).
          const double ch = std::cos(th / 2), sh = std::sin(th / 2);
          rate = cv::Vec3d((ch * d[0] - sh * d[1]) / dt, (sh * d[0] + ch * d[1]) / dt, -th / dt);
          if (have_rate_) rate = opt_.smoothing * smoothed_rate_ + (1.0 - opt_.smoothing) * rate;
          have = true;
          last_source_ = "flow";
        } else {
          last_flow_.ok = false;
          last_flow_.why = "implausible speed " + std::to_string(speed) + " m/s";
        }
      }
    }
    if (!have) {
      std::optional<double> v = f.ego.speed_mps;
      double w = f.ego.yaw_rate.value_or(0.0);
      if (v && prev_speed_) {  // the interval's mean (trapezoid), when both ends carry a speed
        v = 0.5 * (*v + *prev_speed_);
        w = 0.5 * (w + prev_yaw_rate_.value_or(w));
      }
      if (!v && opt_.speed_mps >= 0) v = opt_.speed_mps;
      if (v) {
        rate = cv::Vec3d(*v, 0.0, w);
        last_source_ = "constant_speed";
      } else if (have_rate_) {
        rate = smoothed_rate_;  // hold the last estimate through a short degenerate stretch
        last_source_ = "hold";
      } else {
        rate = cv::Vec3d(0, 0, 0);
        last_source_ = "hold";
        if (!warned_no_speed_) {
          warnings_.push_back(
              frame_name(f) + ": no ego speed known (" +
              (last_flow_.why.empty() ? std::string("constant_speed") : last_flow_.why) +
              "; the frame has no speed and ego_speed_mps is unset): assuming the ego is still");
          warned_no_speed_ = true;
        }
      }
    }
    smoothed_rate_ = rate;
    have_rate_ = true;
    // Integrate along the arc: translate along the mid-interval heading.
    const double psi = rate[2] * dt, c = std::cos(psi / 2), s = std::sin(psi / 2);
    const cv::Vec3d step(dt * (c * rate[0] - s * rate[1]), dt * (s * rate[0] + c * rate[1]), 0.0);
    const double cp = std::cos(psi), sp = std::sin(psi);
    current_ = prev_pose * compose(cv::Matx33d(cp, -sp, 0, sp, cp, 0, 0, 0, 1), step);
  }
  if (*resolved_ == EgoMotionMode::kFlow && !have_prev_) prev_flow_ = flow_.prepare(f.image, f.camera);

  // Velocity in the current ego axes: dataset velocity when given, else the pose difference.
  const cv::Matx33d Rt = rot_of(current_).t();
  if (f.ego.velocity_world) {
    velocity_ego_ = Rt * *f.ego.velocity_world;
  } else if (have_prev_ && dt > 1e-6) {
    const cv::Vec3d dp(current_(0, 3) - prev_pose(0, 3), current_(1, 3) - prev_pose(1, 3),
                       current_(2, 3) - prev_pose(2, 3));
    velocity_ego_ = Rt * (dp / dt);
  } else if (f.ego.speed_mps) {
    velocity_ego_ = cv::Vec3d(*f.ego.speed_mps, 0, 0);
  } else if (opt_.speed_mps >= 0) {
    velocity_ego_ = cv::Vec3d(opt_.speed_mps, 0, 0);
  }
  if (f.ego.yaw_rate)
    yaw_rate_ = f.ego.yaw_rate;
  else if (have_prev_ && dt > 1e-6)
    yaw_rate_ = std::remainder(yaw_of(current_) - yaw_of(prev_pose), 2 * CV_PI) / dt;
  history_[t] = current_;
  prev_speed_ = f.ego.speed_mps;
  prev_yaw_rate_ = f.ego.yaw_rate;
  prev_t_ = t;
  have_prev_ = true;
}

std::optional<cv::Matx44d> EgoTrajectory::pose_at(double t) const {
  if (history_.empty()) return std::nullopt;
  constexpr double kEps = 1e-6;
  auto hi = history_.lower_bound(t - kEps);
  if (hi == history_.end()) return std::nullopt;
  if (std::abs(hi->first - t) <= kEps) return hi->second;
  if (hi == history_.begin()) return std::nullopt;
  auto lo = std::prev(hi);
  const double u = (t - lo->first) / (hi->first - lo->first);
  const cv::Matx33d Ra = rot_of(lo->second), Rb = rot_of(hi->second);
  cv::Vec3d w;
  cv::Rodrigues(cv::Mat(Ra.t() * Rb), w);
  cv::Matx33d Ru;
  cv::Rodrigues(w * u, Ru);
  const cv::Vec3d ta(lo->second(0, 3), lo->second(1, 3), lo->second(2, 3));
  const cv::Vec3d tb(hi->second(0, 3), hi->second(1, 3), hi->second(2, 3));
  return compose(Ra * Ru, ta + u * (tb - ta));
}

}  // namespace hf::render
