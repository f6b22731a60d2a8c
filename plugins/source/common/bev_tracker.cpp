// Internal: bird's-eye view of the road, bonnet detection, coarse-to-fine tracking of ground points between
// consecutive views, and the rigid 2-D fits.
#include "bev_tracker.hpp"
#include "gray.hpp"
#include "median.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include "hazardforge/angles.hpp"

namespace hf::footage::detail {

namespace {

constexpr int kWorkWidth = 960;  // source frames are reduced to this width before warping (anti-aliasing)

}  // namespace

bool BevTracker::patch_agrees(const cv::Mat& a, const cv::Mat& b, cv::Point2f pa, cv::Point2f pb) const {
  const int r = opt_.patch_radius_px;
  const cv::Size sz(2 * r + 1, 2 * r + 1);
  if (pa.x < r + 1 || pa.y < r + 1 || pa.x > a.cols - r - 2 || pa.y > a.rows - r - 2) return false;
  if (pb.x < r + 1 || pb.y < r + 1 || pb.x > b.cols - r - 2 || pb.y > b.rows - r - 2) return false;
  // The two patches (bilinear, as cv::getRectSubPix samples them) in buffers of this thread, then their
  // means, spreads and zero-mean correlation in one pass each.
  thread_local cv::Mat x, y;
  cv::getRectSubPix(a, sz, pa, x, CV_32F);
  cv::getRectSubPix(b, sz, pb, y, CV_32F);
  const int n = sz.area();
  const float* px = x.ptr<float>();
  const float* py = y.ptr<float>();
  double sx = 0, sy = 0;
  for (int i = 0; i < n; ++i) {
    sx += px[i];
    sy += py[i];
  }
  const double mx = sx / n, my = sy / n;
  double vxx = 0, vyy = 0, vxy = 0;
  for (int i = 0; i < n; ++i) {
    const double dx = px[i] - mx, dy = py[i] - my;
    vxx += dx * dx;
    vyy += dy * dy;
    vxy += dx * dy;
  }
  const double std_x = std::sqrt(vxx / n), std_y = std::sqrt(vyy / n);
  if (std_x < opt_.min_patch_contrast || std_y < opt_.min_patch_contrast) return false;
  return vxy / n / (std_x * std_y) >= opt_.min_patch_zncc;
}

cv::Point2d Rigid2::apply(const cv::Point2d& q) const {
  const double c = std::cos(theta), s = std::sin(theta);
  return {c * q.x - s * q.y + t.x, s * q.x + c * q.y + t.y};
}

Rigid2 fit_rigid(const std::vector<cv::Point2d>& p, const std::vector<cv::Point2d>& q,
                 const std::vector<int>& idx) {
  cv::Point2d mp(0, 0), mq(0, 0);
  for (int i : idx) {
    mp += p[i];
    mq += q[i];
  }
  mp *= 1.0 / static_cast<double>(idx.size());
  mq *= 1.0 / static_cast<double>(idx.size());
  double sdot = 0, scross = 0;
  for (int i : idx) {
    const cv::Point2d a = q[i] - mq, b = p[i] - mp;
    sdot += a.x * b.x + a.y * b.y;
    scross += a.x * b.y - a.y * b.x;
  }
  Rigid2 r;
  r.theta = std::atan2(scross, sdot);
  const double c = std::cos(r.theta), s = std::sin(r.theta);
  r.t = mp - cv::Point2d(c * mq.x - s * mq.y, s * mq.x + c * mq.y);
  return r;
}

double rigid_residual(const std::vector<cv::Point2d>& p, const std::vector<cv::Point2d>& q,
                      const std::vector<int>& idx, Rigid2* fit) {
  const Rigid2 r = fit_rigid(p, q, idx);
  if (fit) *fit = r;
  double ss = 0, ws = 0;
  for (int i : idx) {
    const cv::Point2d e = p[i] - r.apply(q[i]);
    const double w = 1.0 / std::max(1.0, q[i].dot(q[i]));
    ss += w * e.dot(e) * q[i].dot(q[i]) / 100.0;
    ws += w;
  }
  return ss / ws;
}

bool pairs_on_ground(const CameraModel& cam, const std::vector<cv::Point2d>& img_p,
                     const std::vector<cv::Point2d>& img_q, std::vector<cv::Point2d>& p,
                     std::vector<cv::Point2d>& q) {
  p.clear();
  q.clear();
  for (size_t i = 0; i < img_p.size() && i < img_q.size(); ++i) {
    const auto a = cam.pixel_to_ground(img_p[i]), b = cam.pixel_to_ground(img_q[i]);
    if (!a || !b) return false;
    p.emplace_back((*a)[0], (*a)[1]);
    q.emplace_back((*b)[0], (*b)[1]);
  }
  return true;
}

double ground_residual(const CameraModel& cam, const std::vector<cv::Point2d>& img_p,
                       const std::vector<cv::Point2d>& img_q, Rigid2* fit) {
  std::vector<cv::Point2d> p, q;
  if (!pairs_on_ground(cam, img_p, img_q, p, q)) return std::numeric_limits<double>::quiet_NaN();
  std::vector<int> all(p.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return rigid_residual(p, q, all, fit);
}

Rigid2 ransac_rigid(const std::vector<cv::Point2d>& p, const std::vector<cv::Point2d>& q, double thr,
                    int iterations, std::vector<int>& best) {
  const int n = static_cast<int>(p.size());
  best.clear();
  if (n < 2) return {};
  // Consensus is weighted by 1 / distance^2: a point on a car body or a wall projects onto the ground farther
  // away than it is and seems to move h / (h - z) times too fast; near the bottom of the image almost
  // everything is road, so near points decide between competing motions.
  std::vector<double> w(n);
  for (int i = 0; i < n; ++i) w[i] = 1.0 / std::max(1.0, q[i].dot(q[i]));
  cv::RNG rng(0xf00d);
  double best_score = 0;
  auto consensus = [&](const Rigid2& m, std::vector<int>& in) {
    in.clear();
    double score = 0;
    const double c = std::cos(m.theta), s = std::sin(m.theta);  // Rigid2::apply's, once per model
    for (int i = 0; i < n; ++i) {
      const double ex = p[i].x - (c * q[i].x - s * q[i].y + m.t.x),
                   ey = p[i].y - (s * q[i].x + c * q[i].y + m.t.y);
      if (ex * ex + ey * ey < thr * thr) {
        in.push_back(i);
        score += w[i];
      }
    }
    return score;
  };
  std::vector<int> in;
  for (int it = 0; it < iterations; ++it) {
    const int a = rng.uniform(0, n), b = rng.uniform(0, n);
    if (a == b || cv::norm(q[a] - q[b]) < 0.5) continue;
    const double score = consensus(fit_rigid(p, q, {a, b}), in);
    if (score > best_score) {
      best_score = score;
      best = in;
    }
  }
  if (best.size() < 2) return {};
  Rigid2 m = fit_rigid(p, q, best);
  for (int pass = 0; pass < 2; ++pass) {
    consensus(m, in);
    if (in.size() < 2) break;
    best = in;
    m = fit_rigid(p, q, best);
  }
  return m;
}

BevTracker::BevTracker(const CameraModel& camera, const OdometryOptions& opt) : cam_(camera), opt_(opt) {
  scale_ = cam_.width > kWorkWidth ? static_cast<double>(kWorkWidth) / cam_.width : 1.0;
  reduced_height_ = cam_.height;
  if (scale_ < 1.0) reduced_height_ = cv::saturate_cast<int>(cam_.height * scale_);  // as cv::resize sizes it
  build_maps();
  // The crop: from a few rows above the farthest road row the view samples, and at least the bottom band the
  // bonnet analysis reads. Its top is moved up to a row whose reduced position is whole, where one exists
  // within 64 rows, so the reduced crop has exactly the pixels of the reduced frame.
  double top = reduced_height_ - opt_.bonnet_max_fraction * reduced_height_ - 2.0;
  for (int r = 0; r < map_y_.rows; ++r)
    for (int c = 0; c < map_y_.cols; ++c)
      if (valid_.at<uchar>(r, c)) top = std::min(top, static_cast<double>(map_y_.at<float>(r, c)) - 3.0);
  int src_top = std::max(0, static_cast<int>(std::floor(top / scale_)));
  for (int k = 0; k <= std::min(src_top, 64); ++k) {
    const double off = (src_top - k) * scale_;
    if (std::abs(off - std::round(off)) < 1e-9) {
      src_top -= k;
      break;
    }
  }
  if (src_top > 0) {
    crop_top_ = src_top;
    crop_off_ = src_top * scale_;
    build_maps();
  }
}

void BevTracker::build_maps() {
  const double res = opt_.bev_resolution_m;
  const double x0 = cam_.t_ego_cam[0];  // distances are counted from the camera
  const int rows = static_cast<int>(std::ceil((opt_.far_m - opt_.near_m) / res));
  const int cols = static_cast<int>(std::ceil(2 * opt_.half_width_m / res));
  map_x_.create(rows, cols, CV_32F);
  map_y_.create(rows, cols, CV_32F);
  valid_ = cv::Mat::zeros(rows, cols, CV_8U);
  const double bottom = cam_.height - std::max(bonnet_rows_, 0) - 2.0;
  const double min_depression = opt_.horizon_margin_deg * kRadPerDeg;
  const double hcam = cam_.height_above_ground();
  for (int r = 0; r < rows; ++r) {
    const double fwd = opt_.far_m - (r + 0.5) * res;
    for (int c = 0; c < cols; ++c) {
      const double lat = opt_.half_width_m - (c + 0.5) * res;
      const auto px = cam_.project_ego(cv::Vec3d(x0 + fwd, cam_.t_ego_cam[1] + lat, 0.0));
      float mx = -1, my = -1;
      if (px && px->x >= 1 && px->x < cam_.width - 2 && px->y >= 1 && px->y < bottom &&
          std::atan2(hcam, std::hypot(fwd, lat)) > min_depression) {
        mx = static_cast<float>(px->x * scale_);
        my = static_cast<float>(px->y * scale_ - crop_off_);
        valid_.at<uchar>(r, c) = 255;
      }
      map_x_.at<float>(r, c) = mx;
      map_y_.at<float>(r, c) = my;
    }
  }
  // Feathered weight for the coarse alignment: the edge of the visible road must not look like texture.
  cv::Mat half, dist;
  cv::resize(valid_, half, cv::Size(), 0.5, 0.5, cv::INTER_NEAREST);
  cv::distanceTransform(half, dist, cv::DIST_L2, 3);
  weight_ = cv::min(dist / 12.0, 1.0);
  maps_bonnet_rows_ = bonnet_rows_;
}

void BevTracker::update_bonnet(const cv::Mat& gray) {
  // Road rows change between frames in proportion to their texture (it streams past); a bonnet reflects the
  // scene but stays put, so its change is small relative to its own gradients. Rows at the bottom whose
  // change/gradient ratio is well below the road's are bonnet. Only frames where the road visibly moves vote.
  // `gray` is the reduced crop; only its bottom band (bonnet_max_fraction of the whole frame's rows) is read,
  // with one row above it for the vertical gradient.
  if (prev_gray_.empty() || prev_gray_.size() != gray.size()) return;
  const int max_rows = std::min(static_cast<int>(opt_.bonnet_max_fraction * reduced_height_), gray.rows - 1);
  if (max_rows < 1) return;
  const cv::Range rows(gray.rows - max_rows - 1, gray.rows);
  cv::Mat diff, gy, row_diff, row_grad;
  cv::absdiff(gray.rowRange(rows), prev_gray_.rowRange(rows), diff);
  cv::Sobel(gray.rowRange(rows), gy, CV_16S, 0, 1, 3);
  gy = cv::abs(gy);
  cv::reduce(diff, row_diff, 1, cv::REDUCE_AVG, CV_64F);
  cv::reduce(gy, row_grad, 1, cv::REDUCE_AVG, CV_64F);
  row_grad *= 0.25;
  const int h = diff.rows;  // rows of the band; h - k is the k-th row from the bottom of the frame
  auto ratio = [&](int r) { return row_diff.at<double>(r) / (row_grad.at<double>(r) + 1.0); };
  // Reference: the road rows of the bottom band move fastest; take its upper quartile of change/gradient.
  std::vector<double> band, band_diff;
  for (int r = h - max_rows; r < h; ++r) {
    band.push_back(ratio(r));
    band_diff.push_back(row_diff.at<double>(r));
  }
  std::sort(band.begin(), band.end());
  const double road = band[band.size() * 3 / 4];
  if (detail::upper_median(band_diff) < 2.0) return;
  // The bonnet reaches up to the highest row below which at least 80 % of the rows are still (single rows at
  // the very bottom may flicker: compression, undistortion borders).
  int n = 0, still = 0;
  for (int k = 1; k <= max_rows; ++k) {
    const bool is_still = ratio(h - k) < opt_.bonnet_change_ratio * road;
    still += is_still ? 1 : 0;
    if (is_still && still >= 0.8 * k) n = k;
  }
  bonnet_votes_.push_back(n);
  const double vote = detail::upper_median(bonnet_votes_);
  // A few still rows at the border are not worth a map rebuild; a bonnet is tens of rows.
  bonnet_rows_ = vote >= 0.02 * reduced_height_ ? static_cast<int>(vote / scale_) + 3 : 0;
}

cv::Point2d BevTracker::bev_to_ego(const cv::Point2f& b) const {
  const double res = opt_.bev_resolution_m;
  return {cam_.t_ego_cam[0] + opt_.far_m - (b.y + 0.5) * res,
          cam_.t_ego_cam[1] + opt_.half_width_m - (b.x + 0.5) * res};
}

cv::Point2d BevTracker::bev_to_image(const cv::Point2f& b) const {
  const cv::Point2d g = bev_to_ego(b);
  const auto px = cam_.project_ego(cv::Vec3d(g.x, g.y, 0.0));
  return px ? *px : cv::Point2d(-1, -1);
}

cv::Matx23d BevTracker::motion_to_pixels(double dist, double yaw, double k) const {
  // Car-like (non-holonomic) motion: the ego origin moves along the chord of an arc, p = R(yaw) q + t with
  // t = dist (cos yaw/2, sin yaw/2). In view pixels (c, r) at k times the view's pixel size:
  // ego = B (c, r) + b, B = [[0, -k res], [-k res, 0]]. Returns the map current-view pixel -> previous-view
  // pixel.
  const double res = opt_.bev_resolution_m * k;
  const double bx = cam_.t_ego_cam[0] + opt_.far_m - 0.5 * res,
               by = cam_.t_ego_cam[1] + opt_.half_width_m - 0.5 * res;
  const double c = std::cos(yaw), s = std::sin(yaw);
  const double tx = dist * std::cos(0.5 * yaw), ty = dist * std::sin(0.5 * yaw);
  // B^-1 R B = [[c, s], [s, c]] (B is res times a swap with a sign flip); offset B^-1 (R b + t - b).
  const double ox = c * bx - s * by + tx - bx, oy = s * bx + c * by + ty - by;
  return {c, s, -oy / res, s, c, -ox / res};
}

cv::Matx23d BevTracker::coarse_alignment(const cv::Mat& prev, const cv::Mat& cur, double dt,
                                         std::optional<double> prior_speed,
                                         std::optional<double> known_yaw) const {
  // Search over distance and yaw change only (a car does not slide sideways), scoring the zero-mean
  // normalised correlation of the current view's textured pixels with the previous view at the predicted
  // places. A free 2-D search (phase correlation) locks onto the streaks that tall objects leave in a
  // bird's-eye view.
  auto search = [&](double k, double d0, double d1, double dstep, double y0, double y1, double ystep,
                    double& bd, double& by) {
    const cv::Size sz(static_cast<int>(std::lround(cur.cols / k)),
                      static_cast<int>(std::lround(cur.rows / k)));
    cv::Mat a, b, va, vb, gx, gy, mag;
    cv::resize(prev, a, sz, 0, 0, cv::INTER_AREA);
    cv::resize(cur, b, sz, 0, 0, cv::INTER_AREA);
    cv::resize(valid_, va, sz, 0, 0, cv::INTER_NEAREST);
    cv::erode(va, va, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
    cv::Sobel(b, gx, CV_32F, 1, 0);
    cv::Sobel(b, gy, CV_32F, 0, 1);
    cv::magnitude(gx, gy, mag);
    std::vector<std::pair<float, cv::Point>> cand;
    for (int r = 0; r < sz.height; ++r)
      for (int c = 0; c < sz.width; ++c)
        if (va.at<uchar>(r, c)) cand.emplace_back(mag.at<float>(r, c), cv::Point(c, r));
    if (cand.size() < 50) return -1.0;
    const size_t keep = std::min<size_t>(1000, cand.size() / 2);
    std::nth_element(cand.begin(), cand.begin() + static_cast<std::ptrdiff_t>(keep), cand.end(),
                     [](const auto& x, const auto& y) { return x.first > y.first; });
    cand.resize(keep);
    std::vector<float> bv(keep);
    for (size_t i = 0; i < keep; ++i) bv[i] = b.at<uchar>(cand[i].second);
    cv::Mat af;
    a.convertTo(af, CV_32F);
    double best = -2;
    for (double yaw = y0; yaw <= y1 + 1e-12; yaw += ystep) {
      for (double d = d0; d <= d1 + 1e-12; d += dstep) {
        const cv::Matx23d M = motion_to_pixels(d, yaw, k);
        double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
        int n = 0;
        for (size_t i = 0; i < keep; ++i) {
          const cv::Point& q = cand[i].second;
          const double x = M(0, 0) * q.x + M(0, 1) * q.y + M(0, 2),
                       y = M(1, 0) * q.x + M(1, 1) * q.y + M(1, 2);
          const int x0 = static_cast<int>(std::floor(x)), y0i = static_cast<int>(std::floor(y));
          if (x0 < 0 || y0i < 0 || x0 + 1 >= sz.width || y0i + 1 >= sz.height) continue;
          if (!va.at<uchar>(y0i, x0) || !va.at<uchar>(y0i + 1, x0 + 1)) continue;
          const double fx = x - x0, fy = y - y0i;
          const float* r0 = af.ptr<float>(y0i);
          const float* r1 = af.ptr<float>(y0i + 1);
          const double va_ = (1 - fx) * (1 - fy) * r0[x0] + fx * (1 - fy) * r0[x0 + 1] +
                             (1 - fx) * fy * r1[x0] + fx * fy * r1[x0 + 1];
          const double vb_ = bv[i];
          sa += va_;
          sb += vb_;
          saa += va_ * va_;
          sbb += vb_ * vb_;
          sab += va_ * vb_;
          ++n;
        }
        if (n < 0.3 * static_cast<double>(keep) || n < 30) continue;
        const double cov = sab - sa * sb / n, var_a = saa - sa * sa / n, var_b = sbb - sb * sb / n;
        if (var_a <= 1e-6 || var_b <= 1e-6) continue;
        const double zncc = cov / std::sqrt(var_a * var_b);
        if (zncc > best) {
          best = zncc;
          bd = d;
          by = yaw;
        }
      }
    }
    return best;
  };
  const double yaw_max = std::max(2.0 * kRadPerDeg, opt_.max_yaw_rate * dt);
  const double d_max = std::min(opt_.max_speed_mps * dt + 0.3, 0.7 * (opt_.far_m - opt_.near_m));
  double d_lo = -0.5, d_hi = d_max;
  if (prior_speed) {
    // Speed changes slowly: within prior_accel * dt plus a relative margin of the last measured speed.
    const double centre = *prior_speed * dt;
    const double margin = opt_.prior_accel_mps2 * dt * dt + opt_.prior_relative * std::abs(centre) + 0.2;
    d_lo = std::max(d_lo, centre - margin);
    d_hi = std::min(d_hi, centre + margin);
  }
  double y_lo = -yaw_max, y_hi = yaw_max, y_step = 1.0 * kRadPerDeg;
  if (known_yaw) {
    y_lo = *known_yaw - 1.5 * kRadPerDeg;
    y_hi = *known_yaw + 1.5 * kRadPerDeg;
    y_step = 0.5 * kRadPerDeg;
  }
  double d = 0, yaw = 0;
  const double coarse = search(4.0, d_lo, d_hi, 0.2, y_lo, y_hi, y_step, d, yaw);
  if (coarse > -1)
    search(2.0, d - 0.2, d + 0.2, 0.05, yaw - 1.0 * kRadPerDeg, yaw + 1.0 * kRadPerDeg, 0.25 * kRadPerDeg, d,
           yaw);
  last_coarse_yaw_ = coarse > -1 ? std::optional<double>(yaw) : std::nullopt;
  cv::Mat inv;
  cv::invertAffineTransform(cv::Mat(motion_to_pixels(d, yaw, 1.0)), inv);
  return cv::Matx23d(inv);
}

std::vector<GroundMatch> BevTracker::add(const cv::Mat& bgr, double dt, std::optional<double> prior_speed,
                                         std::optional<double> known_yaw, bool prewarp) {
  std::vector<GroundMatch> out;
  last_coarse_yaw_.reset();
  if (bgr.empty()) {
    reset();
    return out;
  }
  cv::Mat gray;
  if (bgr.cols == cam_.width && bgr.rows == cam_.height) {
    gray = detail::gray8(bgr.rowRange(crop_top_, bgr.rows));
  } else {
    cv::resize(detail::gray8(bgr), gray, cv::Size(cam_.width, cam_.height));
    gray = gray.rowRange(crop_top_, gray.rows);
  }
  if (scale_ < 1.0) cv::resize(gray, gray, cv::Size(), scale_, scale_, cv::INTER_AREA);
  update_bonnet(gray);
  if (bonnet_rows_ != maps_bonnet_rows_) build_maps();
  cv::Mat bev;
  cv::remap(gray, bev, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::GaussianBlur(bev, bev, cv::Size(3, 3), 0.8);
  cv::Mat prev = prev_bev_;
  prev_gray_ = gray;
  prev_bev_ = bev;
  if (prev.empty()) return out;
  cv::Scalar mean, stddev;
  cv::meanStdDev(bev, mean, stddev, valid_);
  if (stddev[0] < 2.0) return out;  // blank road view: nothing to track

  cv::Mat mask;
  cv::erode(valid_, mask, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(9, 9)));
  std::vector<cv::Point2f> f0, f1, back;
  cv::goodFeaturesToTrack(prev, f0, opt_.max_corners, opt_.corner_quality, opt_.min_corner_distance_px, mask);
  if (f0.size() < static_cast<size_t>(opt_.min_inliers)) return out;
  cv::Matx23d A = coarse_alignment(prev, bev, dt, prior_speed, known_yaw);
  // With prewarp, the previous view is warped by the coarse motion first: what is left for KLT is a small
  // shift, with the patches turned alike (between 2 Hz keyframes the road view turns by 10 degrees and more,
  // which neither KLT's translation-only window nor the patch check survive).
  cv::Mat from = prev;
  std::vector<cv::Point2f> g0;
  g0.reserve(f0.size());
  for (const cv::Point2f& p : f0)
    g0.emplace_back(static_cast<float>(A(0, 0) * p.x + A(0, 1) * p.y + A(0, 2)),
                    static_cast<float>(A(1, 0) * p.x + A(1, 1) * p.y + A(1, 2)));
  if (prewarp)
    cv::warpAffine(prev, from, cv::Mat(A), bev.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  const std::vector<cv::Point2f>& start = prewarp ? g0 : f0;  // the points in `from`
  f1 = g0;
  back = start;
  std::vector<uchar> st, st_back;
  std::vector<float> err;
  const cv::TermCriteria tc(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 40, 0.01);
  const cv::Size win(opt_.klt_window, opt_.klt_window);
  // Between close frames whose coarse alignment found the motion, the guess is within a pixel or two of it
  // and KLT refines it with klt_levels_refine levels (each level costs as much as the base); otherwise (no
  // coarse peak, or far-apart frames whose road views also deform) with klt_levels.
  const int levels = !prewarp && last_coarse_yaw_ ? opt_.klt_levels_refine : opt_.klt_levels;
  cv::calcOpticalFlowPyrLK(from, bev, start, f1, st, err, win, levels, tc, cv::OPTFLOW_USE_INITIAL_FLOW);
  cv::calcOpticalFlowPyrLK(bev, from, f1, back, st_back, err, win, levels, tc, cv::OPTFLOW_USE_INITIAL_FLOW);
  for (size_t i = 0; i < f0.size(); ++i) {
    if (!st[i] || !st_back[i]) continue;
    const cv::Point2f e = back[i] - start[i];
    if (std::hypot(e.x, e.y) > opt_.fb_max_px) continue;
    const int cx = static_cast<int>(std::lround(f1[i].x)), cy = static_cast<int>(std::lround(f1[i].y));
    if (cx < 0 || cy < 0 || cx >= mask.cols || cy >= mask.rows || !mask.at<uchar>(cy, cx)) continue;
    // KLT started from the coarse guess stays put on a blank patch (and so does its backward check): a track
    // counts only where the patch has contrast and really looks the same in both views.
    if (!patch_agrees(from, bev, start[i], f1[i])) continue;
    GroundMatch m;
    m.p = bev_to_ego(f0[i]);
    m.q = bev_to_ego(f1[i]);
    m.img_p = bev_to_image(f0[i]);
    m.img_q = bev_to_image(f1[i]);
    out.push_back(m);
  }
  return out;
}

}  // namespace hf::footage::detail
