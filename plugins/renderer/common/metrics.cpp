// Appearance metrics of one object: edge contrast and halo across its silhouette, sharpness and noise against
// the background ring, Lab statistics, size at its road distance; and the grabCut silhouette of a real object.
#include "hazardforge/realism/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "hazardforge/error.hpp"

namespace hf::realism {

namespace {

// Pixels whose distance lies in (lo, hi].
cv::Mat between(const cv::Mat& dist, double lo, double hi) {
  return (dist > lo) & (dist <= hi);
}

// Local mean of `v` over the pixels of `band` (window w x w); count of those pixels in `n`.
void band_mean(const cv::Mat& v, const cv::Mat& band, int w, cv::Mat& mean, cv::Mat& n) {
  cv::Mat b, vb;
  band.convertTo(b, CV_32F, 1.0 / 255);
  cv::multiply(v, b, vb);
  cv::boxFilter(vb, mean, CV_32F, cv::Size(w, w), cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
  cv::boxFilter(b, n, CV_32F, cv::Size(w, w), cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
  cv::divide(mean, cv::max(n, 1e-6), mean);
}

double masked_variance(const cv::Mat& v, const cv::Mat& mask, int min_px) {
  if (cv::countNonZero(mask) < min_px) return kNaN;
  cv::Scalar m, sd;
  cv::meanStdDev(v, m, sd, mask);
  return sd[0] * sd[0];
}

}  // namespace

std::optional<double> ground_depth(const CameraModel& camera, double x, double y) {
  const auto g = camera.pixel_to_ground({x, y});
  if (!g) return std::nullopt;
  const double z = camera.ego_to_cam(*g)[2];
  if (!(z > 0)) return std::nullopt;
  return z;
}

namespace {

// Reflect-101 index (the border cv::Laplacian uses): -1 -> 1, n -> n - 2.
int reflect101(int i, int n) {
  if (n == 1) return 0;
  if (i < 0) return -i;
  if (i >= n) return 2 * n - 2 - i;
  return i;
}

// Variance of the 4-neighbour Laplacian (cv::Laplacian with ksize 1) at the masked pixels only: the ring
// around an object or the interior of a sprite is a small part of the rectangle around it, so the Laplacian
// is not computed for the whole rectangle. Sums in double, as cv::meanStdDev keeps them.
template <typename T>
double masked_laplacian_variance(const cv::Mat& g, const cv::Mat& mask) {
  double s = 0, ss = 0;
  size_t n = 0;
  for (int y = 0; y < g.rows; ++y) {
    const uint8_t* m = mask.empty() ? nullptr : mask.ptr<uint8_t>(y);
    const T* up = g.ptr<T>(reflect101(y - 1, g.rows));
    const T* row = g.ptr<T>(y);
    const T* down = g.ptr<T>(reflect101(y + 1, g.rows));
    for (int x = 0; x < g.cols; ++x) {
      if (m && !m[x]) {
        // Skip unmasked runs eight pixels at a time.
        uint64_t eight = 0;
        while (x + 8 < g.cols && (std::memcpy(&eight, m + x + 1, 8), eight == 0)) x += 8;
        continue;
      }
      const int xl = x > 0 ? x - 1 : reflect101(-1, g.cols),
                xr = x + 1 < g.cols ? x + 1 : reflect101(g.cols, g.cols);
      // In float, as the CV_32F Laplacian holds it.
      const float l = static_cast<float>(up[x]) + static_cast<float>(down[x]) + static_cast<float>(row[xl]) +
                      static_cast<float>(row[xr]) - 4.0f * static_cast<float>(row[x]);
      s += l;
      ss += static_cast<double>(l) * l;
      ++n;
    }
  }
  if (n == 0) return 0.0;
  const double mean = s / static_cast<double>(n);
  return std::max(0.0, ss / static_cast<double>(n) - mean * mean);
}

// The same for 8-bit pictures, in integers: the Laplacian of bytes is an integer in [-1020, 1020] and a row's
// sums of it and of its square fit in 32 bits up to 2000 pixels, so each row's interior is one branch-free
// loop the compiler vectorises (the scalar loop above took 2.6 ns per masked pixel on a sprite's interior).
// The sums are exact, so the result is the float path's.
double masked_laplacian_variance_u8(const cv::Mat& g, const cv::Mat& mask) {
  int64_t s = 0, ss = 0, n = 0;
  const int cols = g.cols;
  auto one = [&](const uint8_t* up, const uint8_t* row, const uint8_t* down, const uint8_t* m, int x) {
    if (m && !m[x]) return;
    const int xl = reflect101(x - 1, cols), xr = reflect101(x + 1, cols);
    const int l = up[x] + down[x] + row[xl] + row[xr] - 4 * row[x];
    s += l;
    ss += static_cast<int64_t>(l) * l;
    ++n;
  };
  for (int y = 0; y < g.rows; ++y) {
    const uint8_t* m = mask.empty() ? nullptr : mask.ptr<uint8_t>(y);
    const uint8_t* up = g.ptr<uint8_t>(reflect101(y - 1, g.rows));
    const uint8_t* row = g.ptr<uint8_t>(y);
    const uint8_t* down = g.ptr<uint8_t>(reflect101(y + 1, g.rows));
    one(up, row, down, m, 0);
    if (cols > 1) one(up, row, down, m, cols - 1);
    for (int x0 = 1; x0 < cols - 1; x0 += 2000) {
      const int x1 = std::min(cols - 1, x0 + 2000);
      int32_t rs = 0, rss = 0, rn = 0;
      for (int x = x0; x < x1; ++x) {
        const int32_t on = m ? (m[x] != 0) : 1;
        const int32_t l = (up[x] + down[x] + row[x - 1] + row[x + 1] - 4 * row[x]) * on;
        rs += l;
        rss += l * l;
        rn += on;
      }
      s += rs;
      ss += rss;
      n += rn;
    }
  }
  if (n == 0) return 0.0;
  const double mean = static_cast<double>(s) / static_cast<double>(n);
  return std::max(0.0, static_cast<double>(ss) / static_cast<double>(n) - mean * mean);
}

}  // namespace

double laplacian_variance(const cv::Mat& grey, const cv::Mat& mask) {
  if (grey.empty() || grey.channels() != 1) throw Error("laplacian_variance: expected a grey picture");
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != grey.size()))
    throw Error("laplacian_variance: the mask must be 8-bit and the picture's size");
  if (!mask.empty() && cv::countNonZero(mask) < 16) return kNaN;
  switch (grey.depth()) {
    case CV_8U:
      return masked_laplacian_variance_u8(grey, mask);
    case CV_32F:
      return masked_laplacian_variance<float>(grey, mask);
    default: {
      cv::Mat f;
      grey.convertTo(f, CV_32F);
      return masked_laplacian_variance<float>(f, mask);
    }
  }
}

double blur_to_match(const cv::Mat& grey, const cv::Mat& mask, double target_variance, double hint,
                     const std::vector<double>& sigmas) {
  const double v0 = laplacian_variance(grey, mask);
  if (!std::isfinite(v0) || !(target_variance > 0) || v0 <= target_variance || sigmas.empty()) return 0.0;
  cv::Mat g, b;
  grey.convertTo(g, CV_32F);
  // v(k): the variance after sigmas[k] (k = -1: none); computed once each, on demand.
  std::vector<double> known(sigmas.size(), -1.0);
  auto v = [&](int k) {
    if (k < 0) return v0;
    double& x = known[static_cast<size_t>(k)];
    if (x < 0) {
      cv::GaussianBlur(g, b, cv::Size(), sigmas[static_cast<size_t>(k)]);
      x = laplacian_variance(b, mask);  // finite: the mask is the one v0 was finite on
    }
    return x;
  };
  // Blur only lowers the variance, so the first sigma that reaches the target is found by walking from the
  // hint (the previous frame's answer) instead of from the smallest: the same index as an ascending scan.
  const int n = static_cast<int>(sigmas.size());
  int k = 0;
  while (k + 1 < n && sigmas[static_cast<size_t>(k)] < hint) ++k;
  if (v(k) <= target_variance)
    while (k > 0 && v(k - 1) <= target_variance) --k;
  else
    while (k < n && v(k) > target_variance) ++k;
  if (k == n) return sigmas.back();  // none reaches it
  // It, or the one before it when that is nearer (on a log scale).
  const double prev_s = k > 0 ? sigmas[static_cast<size_t>(k - 1)] : 0.0;
  return std::log(v(k - 1) / target_variance) < std::log(target_variance / std::max(v(k), 1e-12))
             ? prev_s
             : sigmas[static_cast<size_t>(k)];
}

namespace {

// Immerkaer's kernel response and the flatness (gradient of a blurred copy) of a grey picture.
struct NoiseMaps {
  cv::Mat resp, mag;
};
NoiseMaps noise_maps(const cv::Mat& grey) {
  cv::Mat g;
  grey.convertTo(g, CV_32F);
  const cv::Matx33f k(1, -2, 1, -2, 4, -2, 1, -2, 1);
  NoiseMaps m;
  cv::Mat smooth, gx, gy;
  cv::filter2D(g, m.resp, CV_32F, k, cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
  cv::GaussianBlur(g, smooth, cv::Size(), 1.5);
  cv::Sobel(smooth, gx, CV_32F, 1, 0);
  cv::Sobel(smooth, gy, CV_32F, 0, 1);
  cv::magnitude(gx, gy, m.mag);
  return m;
}

// Appends the (flatness, |response|) pairs of the masked pixels; the outermost pixel's kernel reaches past
// the picture, so it is left out.
void collect_noise_pixels(const NoiseMaps& maps, const cv::Mat& mask,
                          std::vector<std::pair<float, float>>& px) {
  const cv::Mat& resp = maps.resp;
  for (int y = 1; y < resp.rows - 1; ++y) {
    const float* r = resp.ptr<float>(y);
    const float* m = maps.mag.ptr<float>(y);
    const uint8_t* k8 = mask.empty() ? nullptr : mask.ptr<uint8_t>(y);
    for (int x = 1; x < resp.cols - 1; ++x)
      if (!k8 || k8[x] >= 128) px.emplace_back(m[x], std::abs(r[x]));
  }
}

double noise_from_pixels(std::vector<std::pair<float, float>>& px) {
  if (px.size() < 32) return kNaN;
  const size_t half = px.size() / 2;
  std::nth_element(px.begin(), px.begin() + static_cast<long>(half), px.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  double sum = 0;
  for (size_t i = 0; i < half; ++i) sum += px[i].second;
  return std::sqrt(CV_PI / 2) / 6.0 * sum / static_cast<double>(half);
}

double noise_from_maps(const NoiseMaps& maps, const cv::Mat& mask) {
  std::vector<std::pair<float, float>> px;  // (flatness, |response|)
  px.reserve(static_cast<size_t>(mask.empty() ? maps.resp.total() : cv::countNonZero(mask)));
  collect_noise_pixels(maps, mask, px);
  return noise_from_pixels(px);
}

}  // namespace

double noise_sigma(const cv::Mat& grey, const cv::Mat& mask) {
  if (grey.empty() || grey.channels() != 1) throw Error("noise_sigma: expected a grey picture");
  if (grey.rows < 5 || grey.cols < 5) return kNaN;
  return noise_from_maps(noise_maps(grey), mask);
}

double noise_sigma(const std::vector<cv::Mat>& grey_patches) {
  std::vector<std::pair<float, float>> px;
  for (const cv::Mat& g : grey_patches) {
    if (g.empty() || g.channels() != 1) throw Error("noise_sigma: expected grey patches");
    if (g.rows >= 5 && g.cols >= 5) collect_noise_pixels(noise_maps(g), {}, px);
  }
  return noise_from_pixels(px);
}

AppearanceStats measure(const cv::Mat& bgr, const cv::Mat& mask, cv::Point offset, const cv::Rect2f& box,
                        const std::string& label, const CameraModel* camera, const MeasureOptions& o) {
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("realism::measure: expected a BGR 8-bit picture");
  if (mask.empty() || mask.type() != CV_8UC1) throw Error("realism::measure: expected an 8-bit mask");
  AppearanceStats s;
  s.label = label;
  s.box = box;
  if (box.height > 0) s.aspect = box.width / box.height;
  if (camera && camera->valid() && box.height > 0 && box.y + box.height < bgr.rows - 1) {
    if (auto z = ground_depth(*camera, box.x + box.width / 2.0, box.y + box.height)) {
      s.ground_depth_m = *z;
      s.height_m = box.height * *z / camera->fy;
      s.width_m = box.width * *z / camera->fx;
    }
  }

  // Work on the mask's rectangle grown by the widest band, clipped to the picture.
  const int obj_h = std::max(1, mask.rows);
  const int ring = std::clamp(static_cast<int>(std::lround(o.ring_fraction * obj_h)), 6, 40);
  const int reach = std::max({ring, o.halo_gap_px + o.halo_width_px, o.band_px}) + 2;
  const cv::Rect want(offset.x - reach, offset.y - reach, mask.cols + 2 * reach, mask.rows + 2 * reach);
  const cv::Rect area = want & cv::Rect(0, 0, bgr.cols, bgr.rows);
  if (area.area() <= 0) return s;
  cv::Mat m(area.size(), CV_8U, cv::Scalar(0));
  {
    const cv::Rect src = cv::Rect(offset, mask.size()) & area;
    if (src.area() <= 0) return s;
    cv::Mat bin;
    cv::threshold(mask(src - offset), bin, 127, 255, cv::THRESH_BINARY);
    bin.copyTo(m(src - area.tl()));
  }
  if (cv::countNonZero(m) < o.min_object_px) return s;

  // L*a*b* in its natural units (L* 0..100).
  cv::Mat f32, lab;
  bgr(area).convertTo(f32, CV_32F, 1.0 / 255);
  cv::cvtColor(f32, lab, cv::COLOR_BGR2Lab);
  std::vector<cv::Mat> ch;
  cv::split(lab, ch);
  const cv::Mat& L = ch[0];

  // Distances to the silhouette from inside and from outside (one pass each instead of a morphology per band).
  cv::Mat d_in, d_out;
  cv::distanceTransform(m, d_in, cv::DIST_L2, cv::DIST_MASK_3);
  cv::distanceTransform(~m, d_out, cv::DIST_L2, cv::DIST_MASK_3);
  const cv::Mat interior = d_in > 1.5;
  if (cv::countNonZero(interior) >= o.min_object_px) {
    cv::Scalar mean, sd;
    cv::meanStdDev(lab, mean, sd, interior);
    s.lab_mean = {mean[0], mean[1], mean[2]};
    s.lab_std = {sd[0], sd[1], sd[2]};
  }

  // Edge contrast and halo at the silhouette's pixels, from local band means.
  const int b = std::max(1, o.band_px);
  const cv::Mat inner = between(d_in, 0, b);
  const cv::Mat outer = between(d_out, 0, b);
  const cv::Mat far = between(d_out, o.halo_gap_px, o.halo_gap_px + o.halo_width_px);
  const cv::Mat edge = between(d_in, 0, 1.0);
  const int w = 2 * (o.halo_gap_px + o.halo_width_px) + 1;
  cv::Mat mi, ni, mo, no, mf, nf;
  band_mean(L, inner, w, mi, ni);
  band_mean(L, outer, w, mo, no);
  band_mean(L, far, w, mf, nf);
  double sum_c = 0, sum_h = 0;
  int n_c = 0, n_h = 0;
  for (int y = 0; y < m.rows; ++y) {
    const uint8_t* e = edge.ptr<uint8_t>(y);
    for (int x = 0; x < m.cols; ++x) {
      if (!e[x]) continue;
      // Skip the silhouette where the picture's border cuts the object (no outside to compare with).
      const int gx = x + area.x, gy = y + area.y;
      if (gx <= b || gy <= b || gx >= bgr.cols - 1 - b || gy >= bgr.rows - 1 - b) continue;
      if (ni.at<float>(y, x) < 1 || no.at<float>(y, x) < 1) continue;
      sum_c += std::abs(mi.at<float>(y, x) - mo.at<float>(y, x));
      ++n_c;
      if (nf.at<float>(y, x) >= 1) {
        sum_h += std::abs(mo.at<float>(y, x) - mf.at<float>(y, x));
        ++n_h;
      }
    }
  }
  if (n_c >= 8) s.edge_contrast = sum_c / n_c;
  if (n_h >= 8) s.halo = sum_h / n_h;

  // Sharpness and noise: the interior (away from the silhouette) against the background ring.
  const cv::Mat core = d_in > b + 1;
  const cv::Mat bg = between(d_out, b + 1, ring);
  cv::Mat lap;
  cv::Laplacian(L, lap, CV_32F, 1);
  const double v_in = masked_variance(lap, core, o.min_object_px);
  const double v_bg = masked_variance(lap, bg, o.min_object_px);
  if (std::isfinite(v_in) && std::isfinite(v_bg) && v_bg > 1e-9) s.sharpness = v_in / v_bg;
  cv::Mat grey;
  cv::cvtColor(bgr(area), grey, cv::COLOR_BGR2GRAY);
  if (cv::countNonZero(core) >= o.min_object_px && grey.rows >= 5 && grey.cols >= 5) {
    const NoiseMaps maps = noise_maps(grey);
    s.noise_sigma = noise_from_maps(maps, core);
    const double bg_noise = cv::countNonZero(bg) >= o.min_object_px ? noise_from_maps(maps, bg) : kNaN;
    if (std::isfinite(s.noise_sigma) && std::isfinite(bg_noise) && bg_noise > 1e-6)
      s.noise_ratio = s.noise_sigma / bg_noise;
  }
  return s;
}

cv::Mat object_mask(const cv::Mat& bgr, const cv::Rect2f& box, cv::Rect* crop, double margin, int max_height_px,
                    int iterations, double min_fill) {
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("realism::object_mask: expected a BGR 8-bit picture");
  const cv::Rect img(0, 0, bgr.cols, bgr.rows);
  const cv::Rect b = cv::Rect(cvFloor(box.x), cvFloor(box.y), cvCeil(box.width), cvCeil(box.height)) & img;
  if (b.width < 8 || b.height < 8) return {};
  const int mx = std::max(4, static_cast<int>(margin * b.width)), my = std::max(4, static_cast<int>(margin * b.height));
  const cv::Rect c = cv::Rect(b.x - mx, b.y - my, b.width + 2 * mx, b.height + 2 * my) & img;
  if (crop) *crop = c;
  const double f = std::min(1.0, static_cast<double>(max_height_px) / b.height);
  cv::Mat small;
  if (f < 1.0)
    cv::resize(bgr(c), small, cv::Size(), f, f, cv::INTER_AREA);
  else
    small = bgr(c).clone();
  cv::Rect r(static_cast<int>((b.x - c.x) * f), static_cast<int>((b.y - c.y) * f),
             std::max(2, static_cast<int>(b.width * f)), std::max(2, static_cast<int>(b.height * f)));
  r &= cv::Rect(0, 0, small.cols, small.rows);
  // A box touching the crop's edge (the picture's border) leaves grabCut no background there; it still works
  // from the other sides, but needs some.
  if (r.area() <= 0 || r.area() >= small.cols * small.rows) return {};
  // Outside the box background, inside probably foreground, and its central ellipse (a third of its width, half
  // its height) surely: a road user fills the middle of its box, and without that seed grabCut gives a grey car
  // on a grey street to the street.
  cv::Mat gc(small.size(), CV_8U, cv::Scalar(cv::GC_BGD)), bgd, fgd;
  gc(r).setTo(cv::GC_PR_FGD);
  cv::ellipse(gc, cv::Point(r.x + r.width / 2, r.y + r.height / 2),
              cv::Size(std::max(1, r.width / 6), std::max(1, r.height / 4)), 0, 0, 360, cv::Scalar(cv::GC_FGD),
              cv::FILLED);
  try {
    cv::grabCut(small, gc, cv::Rect(), bgd, fgd, iterations, cv::GC_INIT_WITH_MASK);
  } catch (const cv::Exception&) {
    return {};
  }
  cv::Mat fg = (gc == cv::GC_FGD) | (gc == cv::GC_PR_FGD);
  // A silhouette that fills little of its box is grabCut losing the object, not the object.
  if (cv::countNonZero(fg(r)) < min_fill * r.area()) return {};
  if (f < 1.0) {
    cv::Mat up;
    cv::resize(fg, up, c.size(), 0, 0, cv::INTER_LINEAR);
    cv::threshold(up, fg, 127, 255, cv::THRESH_BINARY);
  }
  return fg;
}

}  // namespace hf::realism
