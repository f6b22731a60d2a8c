// Horizon evidence per frame (road-line vanishing point, focus of expansion, road-plane homography) and its
// robust combination over a clip.
#include "hazardforge/footage/horizon.hpp"

#include "gray.hpp"
#include "median.hpp"

#include "bev_tracker.hpp"
#include "hazardforge/angles.hpp"
#include "hazardforge/footage/attitude.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace hf::footage {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

double mad_sigma(const std::vector<double>& v, double med) {
  std::vector<double> d;
  d.reserve(v.size());
  for (double x : v) d.push_back(std::abs(x - med));
  return 1.4826 * detail::median(d);
}

cv::Mat to_gray(const cv::Mat& bgr, double scale) {
  cv::Mat gray = detail::gray8(bgr);
  if (scale < 1.0) cv::resize(gray, gray, cv::Size(), scale, scale, cv::INTER_AREA);
  return gray;
}

struct Segment {
  cv::Point2d a, b, mid, dir;  // dir: unit vector pointing up the image (towards the vanishing point)
  cv::Vec3d line;              // normalised homogeneous line
  double length = 0;
  int lean = 0;  // +1: x grows going up (left-side lines), -1: x shrinks
};

// Least-squares point closest to weighted lines (normalised a x + b y + c = 0).
std::optional<cv::Point2d> intersect_lines(const std::vector<cv::Vec3d>& lines,
                                           const std::vector<double>& w) {
  double a11 = 0, a12 = 0, a22 = 0, b1 = 0, b2 = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    const cv::Vec3d& l = lines[i];
    a11 += w[i] * l[0] * l[0];
    a12 += w[i] * l[0] * l[1];
    a22 += w[i] * l[1] * l[1];
    b1 -= w[i] * l[0] * l[2];
    b2 -= w[i] * l[1] * l[2];
  }
  const double det = a11 * a22 - a12 * a12;
  if (std::abs(det) < 1e-9 * std::max(1.0, a11 * a22)) return std::nullopt;
  return cv::Point2d((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det);
}

// Vanishing point of the lines that converge in the lower image (lane markings, road edges, kerbs and the
// building edges parallel to the road), in work-image pixels.
std::optional<cv::Point2d> road_vanishing_point(const cv::Mat& gray, const HorizonOptions& o) {
  const int w = gray.cols, h = gray.rows;
  const int top = static_cast<int>(o.lines_top_fraction * h);
  cv::Mat roi = gray.rowRange(top, h), blurred, edges;
  cv::GaussianBlur(roi, blurred, cv::Size(5, 5), 1.2);
  cv::Canny(blurred, edges, 60, 150);
  std::vector<cv::Vec4i> raw;
  const double min_len = o.min_segment_fraction * w;
  cv::HoughLinesP(edges, raw, 1, kRadPerDeg, 25, min_len, 4);
  std::vector<Segment> segs;
  for (const cv::Vec4i& r : raw) {
    Segment s;
    s.a = cv::Point2d(r[0], r[1] + top);
    s.b = cv::Point2d(r[2], r[3] + top);
    if (s.a.y < s.b.y) std::swap(s.a, s.b);  // a is the lower end
    const cv::Point2d d = s.b - s.a;
    s.length = std::hypot(d.x, d.y);
    if (s.length < min_len) continue;
    const double angle = std::atan2(std::abs(d.y), std::abs(d.x)) / kRadPerDeg;
    if (angle < o.min_segment_angle_deg || angle > o.max_segment_angle_deg) continue;
    s.dir = d / s.length;
    s.mid = 0.5 * (s.a + s.b);
    s.lean = d.x > 0 ? 1 : -1;
    cv::Vec3d l = cv::Vec3d(s.a.x, s.a.y, 1).cross(cv::Vec3d(s.b.x, s.b.y, 1));
    s.line = l / std::hypot(l[0], l[1]);
    segs.push_back(s);
  }
  if (static_cast<int>(segs.size()) < o.vp_min_support) return std::nullopt;
  std::sort(segs.begin(), segs.end(), [](const Segment& x, const Segment& y) { return x.length > y.length; });
  if (segs.size() > 80) segs.resize(80);
  const double tol = std::sin(o.vp_angle_tol_deg * kRadPerDeg);
  auto supports = [&](const Segment& s, const cv::Point2d& vp) {
    const cv::Point2d v = vp - s.mid;
    const double n = std::hypot(v.x, v.y);
    if (n < 1e-6 || v.y >= 0) return false;  // the vanishing point lies up the image from the segment
    const double along = (v.x * s.dir.x + v.y * s.dir.y) / n;
    const double across = std::abs(v.x * s.dir.y - v.y * s.dir.x) / n;
    return along > 0 && across < tol;
  };
  double best_score = 0;
  cv::Point2d best;
  for (size_t i = 0; i < segs.size(); ++i) {
    for (size_t j = i + 1; j < segs.size(); ++j) {
      if (segs[i].lean == segs[j].lean) continue;
      cv::Vec3d p = segs[i].line.cross(segs[j].line);
      if (std::abs(p[2]) < 1e-12) continue;
      const cv::Point2d vp(p[0] / p[2], p[1] / p[2]);
      if (vp.x < -0.25 * w || vp.x > 1.25 * w || vp.y < -0.25 * h || vp.y > 0.85 * h) continue;
      double score = 0;
      int left = 0, right = 0;
      for (const Segment& s : segs) {
        if (!supports(s, vp)) continue;
        score += s.length;
        (s.lean > 0 ? left : right) += 1;
      }
      if (left < 2 || right < 2 || left + right < o.vp_min_support) continue;
      if (score > best_score) {
        best_score = score;
        best = vp;
      }
    }
  }
  if (best_score <= 0) return std::nullopt;
  std::vector<cv::Vec3d> lines;
  std::vector<double> weights;
  for (const Segment& s : segs) {
    if (!supports(s, best)) continue;
    lines.push_back(s.line);
    weights.push_back(s.length);
  }
  auto refined = intersect_lines(lines, weights);
  if (!refined) return best;
  return refined;
}

// Focus of expansion of the flow prev -> cur (work pixels), or nullopt when the flow is not a clean
// expansion.
std::optional<cv::Point2d> focus_of_expansion(const std::vector<cv::Point2f>& p0,
                                              const std::vector<cv::Point2f>& p1, cv::Size size,
                                              const HorizonOptions& o) {
  std::vector<int> idx;
  for (size_t i = 0; i < p0.size(); ++i) {
    const cv::Point2f d = p1[i] - p0[i];
    if (std::hypot(d.x, d.y) >= o.flow_min_px) idx.push_back(static_cast<int>(i));
  }
  if (static_cast<int>(idx.size()) < o.foe_min_inliers) return std::nullopt;
  auto line_of = [&](int i) {
    const cv::Vec3d l = cv::Vec3d(p0[i].x, p0[i].y, 1).cross(cv::Vec3d(p1[i].x, p1[i].y, 1));
    return cv::Vec3d(l / std::hypot(l[0], l[1]));
  };
  const double tol = std::sin(o.foe_angle_tol_deg * kRadPerDeg);
  auto inlier = [&](int i, const cv::Point2d& f) {
    const cv::Point2d d(p1[i].x - p0[i].x, p1[i].y - p0[i].y);
    const cv::Point2d r(p0[i].x - f.x, p0[i].y - f.y);  // from the FOE out to the point
    const double nd = std::hypot(d.x, d.y), nr = std::hypot(r.x, r.y);
    if (nr < 1e-6) return false;
    const double along = (d.x * r.x + d.y * r.y) / (nd * nr);
    const double across = std::abs(d.x * r.y - d.y * r.x) / (nd * nr);
    return along > 0 && across < tol;
  };
  cv::RNG rng(0x5eed);
  int best_count = 0;
  cv::Point2d best;
  const int n = static_cast<int>(idx.size());
  for (int it = 0; it < 300; ++it) {
    const int a = idx[rng.uniform(0, n)], b = idx[rng.uniform(0, n)];
    if (a == b) continue;
    const cv::Vec3d p = line_of(a).cross(line_of(b));
    if (std::abs(p[2]) < 1e-12) continue;
    const cv::Point2d f(p[0] / p[2], p[1] / p[2]);
    if (f.x < 0 || f.x > size.width || f.y < 0 || f.y > size.height) continue;
    int count = 0;
    for (int i : idx) count += inlier(i, f) ? 1 : 0;
    if (count > best_count) {
      best_count = count;
      best = f;
    }
  }
  if (best_count < o.foe_min_inliers || best_count < o.foe_min_inlier_fraction * n) return std::nullopt;
  std::vector<cv::Vec3d> lines;
  std::vector<double> weights;
  for (int i : idx) {
    if (!inlier(i, best)) continue;
    lines.push_back(line_of(i));
    const cv::Point2f d = p1[i] - p0[i];
    weights.push_back(
        std::min(10.0, static_cast<double>(std::hypot(d.x, d.y))));  // long flow: better direction
  }
  auto refined = intersect_lines(lines, weights);
  return refined ? refined : std::optional<cv::Point2d>(best);
}

}  // namespace

struct HorizonEstimator::Ground {
  Ground(const CameraModel& nominal, const OdometryOptions& o) : nominal(nominal), tracker(nominal, o) {}
  CameraModel nominal;
  detail::BevTracker tracker;
};

HorizonEstimator::HorizonEstimator(const CameraModel& intrinsics, HorizonOptions opt)
    : cam_(intrinsics), opt_(opt) {
  // The ground cue tracks the road in a bird's-eye view of a level camera; the view need not be metric.
  const double hcam = intrinsics.height_above_ground() > 0 ? intrinsics.height_above_ground() : 1.5;
  const CameraModel nominal =
      CameraModel::pinhole(intrinsics.width, intrinsics.height, intrinsics.fx, intrinsics.fy, intrinsics.cx,
                           intrinsics.cy, hcam, 0.0, intrinsics.t_ego_cam[0], 0.0);
  ground_ = std::make_shared<Ground>(nominal, OdometryOptions{});
  scale_ = intrinsics.width > opt_.work_width ? static_cast<double>(opt_.work_width) / intrinsics.width : 1.0;
  work_cam_ = intrinsics.scaled_to(static_cast<int>(std::lround(intrinsics.width * scale_)),
                                   static_cast<int>(std::lround(intrinsics.height * scale_)));
}

void HorizonEstimator::add(const cv::Mat& bgr, double timestamp) {
  const int frame = frame_++;
  if (bgr.empty()) {
    prev_gray_.release();
    return;
  }
  cv::Mat gray = to_gray(bgr, scale_);
  if (gray.cols != work_cam_.width || gray.rows != work_cam_.height) {
    cv::resize(gray, gray, cv::Size(work_cam_.width, work_cam_.height), 0, 0, cv::INTER_AREA);
  }
  const double inv = 1.0 / scale_;
  // Texture-less frames (sky, a lens cap, a blank screen) carry no evidence and would only feed noise.
  cv::Scalar mean, stddev;
  cv::meanStdDev(gray, mean, stddev);
  if (stddev[0] < 3.0) {
    prev_gray_.release();
    return;
  }

  ground_motion_cue(bgr, frame, timestamp - prev_t_);
  prev_t_ = timestamp;

  if (auto vp = road_vanishing_point(gray, opt_)) {
    Sample s{Sample::kVanishingPoint, vp->x * inv, vp->y * inv, 0, 0, frame};
    samples_.push_back(s);
  }

  if (!prev_gray_.empty()) {
    std::vector<cv::Point2f> p0, p1, back;
    cv::goodFeaturesToTrack(prev_gray_, p0, opt_.flow_max_corners, 0.01, 7);
    if (p0.size() >= 8) {
      std::vector<uchar> st, st_back;
      std::vector<float> err;
      const cv::TermCriteria tc(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
      cv::calcOpticalFlowPyrLK(prev_gray_, gray, p0, p1, st, err, cv::Size(21, 21), 4, tc);
      cv::calcOpticalFlowPyrLK(gray, prev_gray_, p1, back, st_back, err, cv::Size(21, 21), 4, tc);
      std::vector<cv::Point2f> a, b;
      for (size_t i = 0; i < p0.size(); ++i) {
        if (!st[i] || !st_back[i]) continue;
        const cv::Point2f e = back[i] - p0[i];
        if (std::hypot(e.x, e.y) > 0.7) continue;
        a.push_back(p0[i]);
        b.push_back(p1[i]);
      }
      // The FOE is that of translation only: undo the yaw the ground tracker saw (a turning car's flow is the
      // expansion plus a sideways sweep that drags the apparent FOE off the horizon).
      std::vector<cv::Point2f> b_derot = b;
      if (const auto yaw = ground_->tracker.last_coarse_yaw(); yaw && std::abs(*yaw) > 1e-4) {
        const cv::Matx33d K = work_cam_.K(), R = ground_->nominal.R_ego_cam;
        const double c = std::cos(*yaw), s = std::sin(*yaw);
        const cv::Matx33d Rz(c, -s, 0, s, c, 0, 0, 0, 1);
        const cv::Matx33d H = K * R.t() * Rz * R * K.inv();
        for (cv::Point2f& pt : b_derot) {
          const cv::Vec3d v = H * cv::Vec3d(pt.x, pt.y, 1.0);
          pt = cv::Point2f(static_cast<float>(v[0] / v[2]), static_cast<float>(v[1] / v[2]));
        }
      }
      if (auto foe = focus_of_expansion(a, b_derot, gray.size(), opt_)) {
        samples_.push_back(Sample{Sample::kFoe, foe->x * inv, foe->y * inv, 0, 0, frame});
      }
      // Road points: below the horizon seen so far (or the lower half before any evidence), homography of the
      // road plane between the frames, decomposed with K for the plane normal.
      std::vector<double> rows;
      for (const Sample& s : samples_)
        if (s.cue != Sample::kHomography) rows.push_back(s.y * scale_);
      double floor_row = 0.5 * gray.rows;
      if (!rows.empty())
        floor_row = std::clamp(detail::median(rows) + 0.06 * gray.rows, 0.3 * gray.rows, 0.8 * gray.rows);
      std::vector<cv::Point2f> ra, rb;
      for (size_t i = 0; i < a.size(); ++i) {
        if (a[i].y > floor_row && b[i].y > floor_row) {
          ra.push_back(a[i]);
          rb.push_back(b[i]);
        }
      }
      if (static_cast<int>(ra.size()) >= opt_.homography_min_inliers) {
        std::vector<uchar> mask;
        cv::Mat H = cv::findHomography(ra, rb, cv::RANSAC, opt_.homography_reproj_px, mask, 2000, 0.999);
        const int inliers = mask.empty() ? 0 : cv::countNonZero(mask);
        if (!H.empty() && inliers >= opt_.homography_min_inliers) {
          std::vector<cv::Mat> Rs, ts, ns;
          cv::decomposeHomographyMat(H, cv::Mat(work_cam_.K()), Rs, ts, ns);
          double best_cos = 0;
          cv::Vec3d best_n, best_t;
          for (size_t k = 0; k < ns.size(); ++k) {
            cv::Vec3d n(ns[k].at<double>(0), ns[k].at<double>(1), ns[k].at<double>(2));
            cv::Vec3d t(ts[k].at<double>(0), ts[k].at<double>(1), ts[k].at<double>(2));
            const double c = std::abs(n[1]) / cv::norm(n);
            if (c > best_cos) {
              best_cos = c;
              best_n = n * (n[1] > 0 ? -1.0 : 1.0) / cv::norm(n);  // up in camera axes
              best_t = t;
            }
          }
          const double tn = cv::norm(best_t);
          // The road normal is nearly the camera's -y; the motion is mostly along the optical axis.
          if (best_cos > std::cos(20 * kRadPerDeg) && tn > opt_.homography_min_translation &&
              std::abs(best_t[2]) > 0.8 * tn && best_n[1] < -1e-6) {
            Sample s{Sample::kHomography, 0, 0, 0, 0, frame};
            s.row_at_cx = cam_.cy - cam_.fy * best_n[2] / best_n[1];
            s.roll = std::atan2(-best_n[0], -best_n[1]);
            samples_.push_back(s);
          }
        }
      }
    }
  }
  prev_gray_ = gray;
}

void HorizonEstimator::ground_motion_cue(const cv::Mat& bgr, int frame, double dt) {
  const std::vector<detail::GroundMatch> m = ground_->tracker.add(bgr, dt);
  if (static_cast<int>(m.size()) < opt_.ground_min_matches) return;
  // Inliers of the rigid motion at the nominal (level) pitch, with a loose threshold since the pitch is
  // unknown.
  std::vector<cv::Point2d> p, q;
  for (const auto& g : m) {
    p.push_back(g.p);
    q.push_back(g.q);
  }
  std::vector<int> in;
  const detail::Rigid2 nominal = detail::ransac_rigid(p, q, 0.4, 300, in);
  if (static_cast<int>(in.size()) < opt_.ground_min_matches) return;
  if (std::hypot(nominal.t.x, nominal.t.y) < opt_.ground_min_travel_m) return;
  std::vector<cv::Point2d> ip,
      iq;  // the inliers' image points, put on the road at each candidate pitch and roll
  for (int i : in) {
    ip.push_back(m[static_cast<size_t>(i)].img_p);
    iq.push_back(m[static_cast<size_t>(i)].img_q);
  }
  const CameraModel& base = ground_->nominal;
  auto cam_at = [&](double pitch, double roll) {
    return CameraModel::pinhole(base.width, base.height, base.fx, base.fy, base.cx, base.cy,
                                base.height_above_ground(), pitch, base.t_ego_cam[0], roll);
  };
  auto search = [&](double p0, double p1, double pstep, double r0, double r1, double rstep, double& bp,
                    double& br) {
    double best = kInf;
    for (double pitch = p0; pitch <= p1 + 1e-12; pitch += pstep) {
      for (double roll = r0; roll <= r1 + 1e-12; roll += rstep) {
        const double e = detail::ground_residual(cam_at(pitch, roll), ip, iq);
        if (std::isfinite(e) && e < best) {
          best = e;
          bp = pitch;
          br = roll;
        }
      }
    }
    return best;
  };
  const double pr = opt_.ground_pitch_range_deg * kRadPerDeg, rr = opt_.ground_roll_range_deg * kRadPerDeg;
  double bp = 0, br = 0;
  if (!std::isfinite(search(-pr, pr, 0.25 * kRadPerDeg, -rr, rr, 0.5 * kRadPerDeg, bp, br))) return;
  double best = search(bp - 0.3 * kRadPerDeg, bp + 0.3 * kRadPerDeg, 0.025 * kRadPerDeg,
                       br - 0.6 * kRadPerDeg, br + 0.6 * kRadPerDeg, 0.1 * kRadPerDeg, bp, br);
  // A flat residual (too little depth range, points not on the ground) does not pin the pitch down.
  const double lo = detail::ground_residual(cam_at(bp - kRadPerDeg, br), ip, iq);
  const double hi = detail::ground_residual(cam_at(bp + kRadPerDeg, br), ip, iq);
  const double side = std::min(std::isfinite(lo) ? lo : kInf, std::isfinite(hi) ? hi : kInf);
  if (!(side > opt_.ground_sharpness * best) || bp <= -pr + 0.1 * kRadPerDeg || bp >= pr - 0.1 * kRadPerDeg)
    return;
  Sample s{Sample::kGroundMotion, 0, 0, 0, br, frame};
  s.row_at_cx = cam_.cy - cam_.fy * std::tan(bp) / std::cos(br);
  samples_.push_back(s);
}

void HorizonEstimator::add_epipole(const cv::Point2d& e, int frame) {
  samples_.push_back(Sample{Sample::kEpipole, e.x, e.y, 0, 0, frame});
}

std::optional<HorizonEstimate> HorizonEstimator::result() const {
  if (samples_.empty()) return std::nullopt;
  HorizonEstimate est;
  const double h = cam_.height;

  // Roll: the road-plane normal when the homographies agree, else the line through the vanishing points and
  // FOEs when they spread across the image, else unobservable.
  std::vector<double> rolls;
  std::vector<double> px, py;
  for (const Sample& s : samples_) {
    if (s.cue == Sample::kHomography || s.cue == Sample::kGroundMotion) {
      rolls.push_back(s.roll);
    } else {
      px.push_back(s.x);
      py.push_back(s.y);
    }
  }
  double roll = 0;
  bool roll_known = false;
  const double max_sigma = opt_.max_roll_sigma_deg * kRadPerDeg;
  if (static_cast<int>(rolls.size()) >= opt_.min_roll_samples) {
    const double m = detail::median(rolls);
    const double sig = mad_sigma(rolls, m);
    if (sig < max_sigma) {
      std::vector<double> in;
      for (double r : rolls)
        if (std::abs(r - m) <= std::max(3 * sig, 0.2 * kRadPerDeg)) in.push_back(r);
      const double se =
          1.2533 * sig / std::sqrt(static_cast<double>(in.size()));  // standard error of a median
      if (static_cast<int>(in.size()) >= opt_.min_roll_samples && se < opt_.max_roll_error_deg * kRadPerDeg) {
        roll = detail::median(in);
        est.roll_sigma_rad = std::max(se, 1e-4);
        roll_known = true;
      }
    }
  }
  if (!roll_known && px.size() >= 5) {
    const double mx = std::accumulate(px.begin(), px.end(), 0.0) / px.size();
    double sxx = 0;
    for (double x : px) sxx += (x - mx) * (x - mx);
    const double sx = std::sqrt(sxx / px.size());
    if (sx > 0.05 * cam_.width) {
      // Least squares line y = a + b (x - mx) after dropping points beyond 3 MAD of the rows.
      const double my = detail::median(py), sy = std::max(mad_sigma(py, my), 1.0);
      double sxy = 0, sxx2 = 0, sumy = 0, sumx = 0;
      int n = 0;
      for (size_t i = 0; i < px.size(); ++i) {
        if (std::abs(py[i] - my) > 3 * sy) continue;
        sumx += px[i];
        sumy += py[i];
        ++n;
      }
      if (n >= 5) {
        const double ax = sumx / n, ay = sumy / n;
        double res = 0;
        for (size_t i = 0; i < px.size(); ++i) {
          if (std::abs(py[i] - my) > 3 * sy) continue;
          sxy += (px[i] - ax) * (py[i] - ay);
          sxx2 += (px[i] - ax) * (px[i] - ax);
        }
        const double b = sxy / sxx2;
        for (size_t i = 0; i < px.size(); ++i) {
          if (std::abs(py[i] - my) > 3 * sy) continue;
          const double r = py[i] - ay - b * (px[i] - ax);
          res += r * r;
        }
        const double se_b = std::sqrt(res / std::max(1, n - 2) / sxx2);
        const double r = std::atan(-b * cam_.fx / cam_.fy);
        const double se_r = se_b * cam_.fx / cam_.fy;
        if (se_r < opt_.max_roll_error_deg * kRadPerDeg) {
          roll = r;
          est.roll_sigma_rad = se_r;
          roll_known = true;
        }
      }
    }
  }
  if (!roll_known) {
    est.notes.push_back(
        "roll not observable from this clip (no consistent road-plane normal and the horizon points do not "
        "spread "
        "across the image): roll reported as 0");
  }

  // Horizon rows at cx of every sample, given the roll.
  const double slope = -cam_.fy / cam_.fx * std::tan(roll);
  std::vector<double> rows;
  rows.reserve(samples_.size());
  for (const Sample& s : samples_) {
    const bool plane = s.cue == Sample::kHomography || s.cue == Sample::kGroundMotion;
    rows.push_back(plane ? s.row_at_cx : s.y + slope * (cam_.cx - s.x));
  }
  const double m = detail::median(rows);
  const double gate = std::max(3 * mad_sigma(rows, m), opt_.inlier_gate_fraction * h);
  std::vector<double> in_rows, cue_rows[5], vp_cols;
  std::vector<int> frames;
  for (size_t i = 0; i < rows.size(); ++i) {
    if (std::abs(rows[i] - m) > gate) continue;
    in_rows.push_back(rows[i]);
    cue_rows[samples_[i].cue].push_back(rows[i]);
    if (samples_[i].cue == Sample::kVanishingPoint) vp_cols.push_back(samples_[i].x);
    frames.push_back(samples_[i].frame);
  }
  if (in_rows.empty()) return std::nullopt;
  std::sort(frames.begin(), frames.end());
  est.frames_used = static_cast<int>(std::unique(frames.begin(), frames.end()) - frames.begin());
  const double mean = std::accumulate(in_rows.begin(), in_rows.end(), 0.0) / in_rows.size();
  const double centre = detail::median(in_rows);  // the estimate: median of the inliers (few, skewed samples)
  double var = 0;
  for (double r : in_rows) var += (r - mean) * (r - mean);
  const double sd = in_rows.size() > 1 ? std::sqrt(var / (in_rows.size() - 1)) : 0.0;
  est.horizon_y = centre;
  est.horizon_sigma_px = sd;
  est.roll_rad = roll;
  est.pitch_rad = std::atan((cam_.cy - centre) * std::cos(roll) / cam_.fy);
  est.vanishing_points = static_cast<int>(cue_rows[Sample::kVanishingPoint].size());
  est.foe_points = static_cast<int>(cue_rows[Sample::kFoe].size());
  est.homographies = static_cast<int>(cue_rows[Sample::kHomography].size());
  est.vp_row = detail::median(cue_rows[Sample::kVanishingPoint]);
  if (vp_cols.size() >= 3) est.travel_x = detail::median(vp_cols);
  est.foe_row = detail::median(cue_rows[Sample::kFoe]);
  est.homography_row = detail::median(cue_rows[Sample::kHomography]);
  est.ground_motions = static_cast<int>(cue_rows[Sample::kGroundMotion].size());
  est.ground_motion_row = detail::median(cue_rows[Sample::kGroundMotion]);
  est.epipoles = static_cast<int>(cue_rows[Sample::kEpipole].size());
  est.epipole_row = detail::median(cue_rows[Sample::kEpipole]);
  const char* names[5] = {"vanishing_point", "flow_foe", "road_homography", "ground_motion", "epipole"};
  for (int c = 0; c < 5; ++c) {
    if (cue_rows[c].empty()) continue;
    if (!est.method.empty()) est.method += "+";
    est.method += names[c];
  }
  const double inlier_fraction = static_cast<double>(in_rows.size()) / rows.size();
  const double tau = 0.01 * h;
  est.confidence = inlier_fraction *
                   std::min(1.0, static_cast<double>(est.frames_used) / opt_.full_confidence_frames) *
                   std::exp(-0.5 * (sd / tau) * (sd / tau));
  if (est.frames_used < opt_.full_confidence_frames) {
    est.notes.push_back("only " + std::to_string(est.frames_used) + " frames gave horizon evidence");
  }
  for (int c = 0; c < 5; ++c) {
    if (cue_rows[c].size() < 3) continue;
    const double d = detail::median(cue_rows[c]) - centre;
    if (std::abs(d) > 0.5 * gate) {
      est.notes.push_back(std::string(names[c]) + " rows sit " +
                          std::to_string(static_cast<int>(std::lround(d))) +
                          " px from the combined horizon (road slope, curve or turning bias)");
    }
  }
  if (inlier_fraction < 0.5) est.notes.push_back("fewer than half of the per-frame horizon samples agreed");
  return est;
}

CameraModel HorizonEstimator::apply(const CameraModel& intrinsics, const HorizonEstimate& est) {
  return with_pitch_roll(intrinsics, est.pitch_rad, est.roll_rad);
}

}  // namespace hf::footage
