// Pastes one object picture into a frame on the ROI only: warp, harmonise, feather, blur, occlude, shadow, blend.
#include "compositor.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "box_geometry.hpp"

namespace hf::render {

namespace {

cv::Point2d apply(const cv::Matx33d& H, const cv::Point2d& p, double* w_out = nullptr) {
  const cv::Vec3d q = H * cv::Vec3d(p.x, p.y, 1.0);
  if (w_out) *w_out = q[2];
  return {q[0] / q[2], q[1] / q[2]};
}

int odd(double v) {
  int k = std::max(1, static_cast<int>(std::lround(v)));
  return k | 1;
}

// Adds `src` shifted by (dx, dy) into `dst` (same size; the part shifted out is dropped).
void add_shifted(const cv::Mat& src, cv::Mat& dst, int dx, int dy) {
  const int w = src.cols - std::abs(dx), h = src.rows - std::abs(dy);
  if (w <= 0 || h <= 0) return;
  const cv::Rect from(std::max(0, -dx), std::max(0, -dy), w, h);
  const cv::Rect to(std::max(0, dx), std::max(0, dy), w, h);
  cv::Mat d = dst(to);
  cv::add(d, src(from), d);
}

// Statistics of the surroundings in 8-bit Lab: a rectangle around the object, minus the object's box hull,
// sampled on a coarse grid (a few thousand pixels are plenty for a mean and a deviation).
bool ring_statistics(const cv::Mat& image, const cv::Rect& around, const std::vector<cv::Point2d>& hull,
                     cv::Scalar& mean, cv::Scalar& stddev) {
  if (around.area() <= 0) return false;
  const double f = std::min(1.0, 96.0 / std::max(around.width, around.height));
  cv::Mat small;
  cv::resize(image(around), small, cv::Size(), f, f, cv::INTER_NEAREST);
  if (small.empty()) return false;
  cv::Mat mask(small.size(), CV_8U, cv::Scalar(255));
  std::vector<cv::Point> poly;
  for (const auto& p : hull)
    poly.emplace_back(static_cast<int>(std::lround((p.x - around.x) * f)),
                      static_cast<int>(std::lround((p.y - around.y) * f)));
  if (poly.size() >= 3) {
    cv::fillConvexPoly(mask, poly, cv::Scalar(0));
    cv::erode(mask, mask, cv::Mat(), cv::Point(-1, -1), 1);
  }
  if (cv::countNonZero(mask) < 16) return false;
  cv::Mat lab;
  cv::cvtColor(small, lab, cv::COLOR_BGR2Lab);
  cv::meanStdDev(lab, mean, stddev, mask);
  return true;
}

// Per-channel affine map in Lab moving the asset's statistics part of the way to the surroundings'.
cv::Mat harmonisation_lut(const LoadedAsset& a, const ExposureState& ex, const CompositeOptions& o) {
  cv::Mat lut(1, 256, CV_8UC3);
  double gain[3], off[3];
  for (int c = 0; c < 3; ++c) {
    const double s = c == 0 ? o.harmonize_luma : o.harmonize_chroma;
    const double mo = a.lab_mean[c], so = std::max(a.lab_std[c], 1.0);
    const double sr = std::max(ex.stddev[c], 1.0);
    const double mt = mo + s * (ex.mean[c] - mo);
    const double st = so * std::pow(sr / so, s);
    gain[c] = std::clamp(st / so, 0.5, 2.0);
    off[c] = mt - gain[c] * mo;
  }
  auto* p = lut.ptr<cv::Vec3b>(0);
  for (int v = 0; v < 256; ++v)
    for (int c = 0; c < 3; ++c) p[v][c] = cv::saturate_cast<uint8_t>(gain[c] * v + off[c]);
  return lut;
}

}  // namespace

std::vector<int> mapping_corners(double asset_az, double view_az) {
  std::vector<int> ids;
  const auto faces = visible_faces(view_az);
  for (Face f : visible_faces(asset_az))
    if (std::find(faces.begin(), faces.end(), f) != faces.end())
      for (int c : face_corners(f)) ids.push_back(c);
  if (ids.empty()) return visible_corners(asset_az);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

cv::Matx33d asset_homography(const LoadedAsset& a, const std::array<cv::Point2d, 8>& img, double view_az) {
  const std::vector<int> ids = mapping_corners(a.spec.azimuth_deg, view_az);
  std::vector<cv::Point2f> src, dst;
  for (int i : ids) {
    src.emplace_back(a.spec.box_corners_px[i]);
    dst.emplace_back(img[i]);
  }
  cv::Mat H = ids.size() == 4 ? cv::getPerspectiveTransform(src, dst) : cv::findHomography(src, dst, 0);
  if (H.empty()) return cv::Matx33d::zeros();
  cv::Matx33d out;
  H.convertTo(cv::Mat(3, 3, CV_64F, out.val), CV_64F);
  return out;
}

CompositeResult composite(cv::Mat& image, const Placement& p, const CompositeOptions& o, ExposureState& ex) {
  CompositeResult r;
  const LoadedAsset& a = *p.asset;
  const cv::Matx33d H0 = asset_homography(a, p.corners_px, p.view_azimuth_deg);
  if (cv::norm(H0) < 1e-12) return r;

  // Pyramid level: the coarsest one still as tall as the object will be drawn (no aliasing, least work).
  const std::vector<int> ids = mapping_corners(a.spec.azimuth_deg, p.view_azimuth_deg);
  double sy0 = 1e9, sy1 = -1e9, iy0 = 1e9, iy1 = -1e9;
  for (int i : ids) {
    sy0 = std::min(sy0, a.spec.box_corners_px[i].y);
    sy1 = std::max(sy1, a.spec.box_corners_px[i].y);
    iy0 = std::min(iy0, p.corners_px[i].y);
    iy1 = std::max(iy1, p.corners_px[i].y);
  }
  const double scale = (iy1 - iy0) / std::max(sy1 - sy0, 1e-6);
  r.level = a.level_for_height(a.spec.image_size.height * scale);
  const double f = std::ldexp(1.0, -r.level), c = 0.5 * f - 0.5 + a.pad;
  const cv::Matx33d S_inv(1 / f, 0, -c / f, 0, 1 / f, -c / f, 0, 0, 1);  // level pixel -> file pixel
  const cv::Matx33d H = H0 * S_inv;

  // Where the picture lands; refuse a homography that folds part of it behind the camera.
  const cv::Mat& lvl_alpha = a.alpha[static_cast<size_t>(r.level)];
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  for (const cv::Point2d q : {cv::Point2d(0, 0), cv::Point2d(lvl_alpha.cols, 0),
                              cv::Point2d(lvl_alpha.cols, lvl_alpha.rows), cv::Point2d(0, lvl_alpha.rows)}) {
    double w = 0;
    const cv::Point2d m = apply(H, q, &w);
    if (w <= 1e-9) return r;
    x0 = std::min(x0, m.x);
    y0 = std::min(y0, m.y);
    x1 = std::max(x1, m.x);
    y1 = std::max(y1, m.y);
  }
  double bx0 = 1e18, by0 = 1e18, bx1 = -1e18, by1 = -1e18;
  for (const auto& q : p.corners_px) {
    bx0 = std::min(bx0, q.x);
    by0 = std::min(by0, q.y);
    bx1 = std::max(bx1, q.x);
    by1 = std::max(by1, q.y);
  }
  const double obj_h = by1 - by0;
  const cv::Point2d blur = p.velocity_px_s * o.exposure_s;
  const double blur_len = std::min(cv::norm(blur), 0.5 * std::max(obj_h, 8.0));
  const int shadow_k = odd(std::max(3.0, 0.08 * obj_h));
  const int pad = static_cast<int>(std::ceil(blur_len / 2 + 3 * o.feather_px)) + 2;
  const int spad = o.shadow ? shadow_k + 2 : 0;
  const cv::Rect img_rect(0, 0, image.cols, image.rows);
  const cv::Rect want(static_cast<int>(std::floor(std::min(x0, bx0 - spad))) - pad,
                      static_cast<int>(std::floor(std::min(y0, by0))) - pad,
                      static_cast<int>(std::ceil(std::max(x1, bx1 + spad) - std::min(x0, bx0 - spad))) + 2 * pad + 1,
                      static_cast<int>(std::ceil(std::max(y1, by1 + spad) - std::min(y0, by0))) + 2 * pad + 1);
  const cv::Rect roi = want & img_rect;
  if (roi.area() <= 0) return r;
  r.roi = roi;

  // Surroundings' colour statistics, smoothed over time so exposure does not flicker.
  std::vector<cv::Point2d> hull_pts(p.corners_px.begin(), p.corners_px.end());
  std::vector<cv::Point2f> hull_f;
  for (const auto& q : hull_pts) hull_f.emplace_back(q);
  std::vector<cv::Point2f> hull;
  cv::convexHull(hull_f, hull);
  const int m = static_cast<int>(std::max(4.0, 0.15 * obj_h));
  const cv::Rect around = cv::Rect(static_cast<int>(bx0) - m, static_cast<int>(by0) - m,
                                   static_cast<int>(bx1 - bx0) + 2 * m, static_cast<int>(by1 - by0) + 2 * m) &
                          img_rect;
  cv::Scalar mean, sd;
  std::vector<cv::Point2d> hull_d(hull.begin(), hull.end());
  if (ring_statistics(image, around, hull_d, mean, sd)) {
    if (!ex.valid) {
      ex.mean = mean;
      ex.stddev = sd;
      ex.valid = true;
    } else {
      const double k = o.exposure_smoothing;
      ex.mean = ex.mean * k + mean * (1 - k);
      ex.stddev = ex.stddev * k + sd * (1 - k);
    }
  }
  cv::Mat colour = a.bgr[static_cast<size_t>(r.level)];
  if (ex.valid && (o.harmonize_luma > 0 || o.harmonize_chroma > 0)) {
    cv::Mat lab;
    cv::LUT(a.lab[static_cast<size_t>(r.level)], harmonisation_lut(a, ex, o), lab);
    cv::cvtColor(lab, colour, cv::COLOR_Lab2BGR);
  }

  // Warp colour and alpha together onto the ROI.
  cv::Mat src4, warped;
  cv::merge(std::vector<cv::Mat>{colour, lvl_alpha}, src4);
  const cv::Matx33d T(1, 0, -roi.x, 0, 1, -roi.y, 0, 0, 1);
  cv::warpPerspective(src4, warped, cv::Mat(T * H), roi.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                      cv::Scalar::all(0));
  cv::Mat w32;
  warped.convertTo(w32, CV_32FC4, 1.0 / 255);
  // Premultiplied colour: blurring and blending in this form never bleeds the transparent colour in.
  cv::Mat pre(roi.size(), CV_32FC4);
  for (int y = 0; y < roi.height; ++y) {
    const auto* s = w32.ptr<cv::Vec4f>(y);
    auto* d = pre.ptr<cv::Vec4f>(y);
    for (int x = 0; x < roi.width; ++x) d[x] = cv::Vec4f(s[x][0] * s[x][3], s[x][1] * s[x][3], s[x][2] * s[x][3], s[x][3]);
  }
  if (o.feather_px > 0.05) cv::GaussianBlur(pre, pre, cv::Size(), o.feather_px);
  // Motion blur: the line integral of the object over the exposure, as shifted copies one pixel apart.
  if (blur_len >= 1.0) {
    const int n = static_cast<int>(std::ceil(blur_len)) + 1;
    cv::Mat acc(pre.size(), pre.type(), cv::Scalar::all(0));
    const cv::Point2d step = blur * (blur_len / std::max(cv::norm(blur), 1e-9));
    for (int i = 0; i < n; ++i) {
      const double u = static_cast<double>(i) / (n - 1) - 0.5;
      add_shifted(pre, acc, static_cast<int>(std::lround(step.x * u)), static_cast<int>(std::lround(step.y * u)));
    }
    pre = acc / n;
  }
  std::vector<cv::Mat> ch;
  cv::split(pre, ch);
  r.coverage_before = cv::sum(ch[3])[0];
  // Nearer objects stay in front: the hazard (and its shadow) is removed under their boxes.
  std::vector<cv::Rect> occ;
  for (const cv::Rect2f& b : p.occluders) {
    const cv::Rect ib(static_cast<int>(std::floor(b.x)) - roi.x, static_cast<int>(std::floor(b.y)) - roi.y,
                      static_cast<int>(std::ceil(b.x + b.width) - std::floor(b.x)),
                      static_cast<int>(std::ceil(b.y + b.height) - std::floor(b.y)));
    const cv::Rect cl = ib & cv::Rect(0, 0, roi.width, roi.height);
    if (cl.area() > 0) {
      pre(cl).setTo(cv::Scalar::all(0));
      occ.push_back(cl);
    }
  }
  if (!occ.empty()) cv::split(pre, ch);
  r.coverage_after = cv::sum(ch[3])[0];

  // Soft contact shadow: the footprint, a little larger, blurred, darkening the road under the object.
  cv::Mat shadow;
  if (o.shadow && o.shadow_strength > 0) {
    cv::Point2d cen(0, 0);
    for (int i = 0; i < 4; ++i) cen += p.corners_px[i] * 0.25;
    std::vector<cv::Point> poly;
    for (int i = 0; i < 4; ++i) {
      const cv::Point2d q = cen + (p.corners_px[i] - cen) * 1.12;
      poly.emplace_back(static_cast<int>(std::lround((q.x - roi.x) * 16)),
                        static_cast<int>(std::lround((q.y - roi.y) * 16)));
    }
    shadow = cv::Mat(roi.size(), CV_32F, cv::Scalar(0));
    std::vector<cv::Point> hull_i;
    cv::convexHull(poly, hull_i);
    cv::fillConvexPoly(shadow, hull_i, cv::Scalar(o.shadow_strength), cv::LINE_AA, 4);
    cv::blur(shadow, shadow, cv::Size(shadow_k, shadow_k));
    cv::blur(shadow, shadow, cv::Size(shadow_k, shadow_k));
    for (const cv::Rect& cl : occ) shadow(cl).setTo(0);
  }

  // Blend: out = background * (1 - shadow) * (1 - alpha) + premultiplied colour.
  cv::Mat dst = image(roi);
  for (int y = 0; y < roi.height; ++y) {
    auto* d = dst.ptr<cv::Vec3b>(y);
    const auto* s = pre.ptr<cv::Vec4f>(y);
    const float* sh = shadow.empty() ? nullptr : shadow.ptr<float>(y);
    for (int x = 0; x < roi.width; ++x) {
      const float al = s[x][3];
      const float keep = (1.f - al) * (sh ? 1.f - sh[x] : 1.f);
      if (al <= 0.f && (!sh || sh[x] <= 0.f)) continue;
      for (int k = 0; k < 3; ++k) d[x][k] = cv::saturate_cast<uint8_t>(d[x][k] * keep + 255.f * s[x][k]);
    }
  }
  r.alpha = ch[3];
  r.drawn = true;
  return r;
}

}  // namespace hf::render
