// Pastes one object picture into a frame on the ROI only: warp, harmonise, feather, blur, occlude, shadow,
// blend.
#include "compositor.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include "hazardforge/assets/box_geometry.hpp"
#include "hazardforge/realism/metrics.hpp"
#include "warp.hpp"

namespace hf::render {

namespace {

// Sum over faces of |picture share - frame share| up to which the whole outline is fitted (0 = same view).
constexpr double kMaxShareMismatch = 0.35;

cv::Point2d apply(const cv::Matx33d& H, const cv::Point2d& p, double* w_out = nullptr) {
  const cv::Vec3d q = H * cv::Vec3d(p.x, p.y, 1.0);
  if (w_out) *w_out = q[2];
  return {q[0] / q[2], q[1] / q[2]};
}

int odd(double v) {
  int k = std::max(1, static_cast<int>(std::lround(v)));
  return k | 1;
}

// img = (img + img shifted by (dx, dy)) / 2, rounded up, in place; pixels shifted in from outside are 0
// (transparent, premultiplied). Rows are visited so that the row a shifted copy comes from is not yet
// changed; `row` holds that copy. (a + b + 1) >> 1 on bytes is one vector average instruction
// (cv::addWeighted goes through floating point).
void shift_average(cv::Mat& img, std::vector<uint8_t>& row, int dx, int dy) {
  const int cn = img.channels(), n = img.cols * cn;
  row.assign(static_cast<size_t>(n), 0);
  const int w = img.cols - std::abs(dx);
  for (int k = 0; k < img.rows; ++k) {
    const int y = dy > 0 ? img.rows - 1 - k : k, ys = y - dy;
    uint8_t* __restrict a = img.ptr<uint8_t>(y);
    uint8_t* __restrict b = row.data();
    if (ys < 0 || ys >= img.rows || w <= 0) {
      for (int i = 0; i < n; ++i) a[i] = static_cast<uint8_t>((a[i] + 1) >> 1);
      continue;
    }
    std::fill(row.begin(), row.end(), 0);
    std::memcpy(b + std::max(0, dx) * cn, img.ptr<uint8_t>(ys) + std::max(0, -dx) * cn,
                static_cast<size_t>(w * cn));
    for (int i = 0; i < n; ++i) a[i] = static_cast<uint8_t>((a[i] + b[i] + 1) >> 1);
  }
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

// A noise estimate as a level to match: 0 where the estimator cannot tell (NaN), and capped, since road
// texture inflates it.
double usable_noise(double sigma) {
  return std::isfinite(sigma) ? std::min(sigma, 6.0) : 0.0;
}

// Sensor noise level of a picture patch, as the realism metric measures it (hazardforge/realism noise_sigma:
// Immerkaer's estimate over the flattest half of the patch).
double noise_level(const cv::Mat& patch, const cv::Mat& mask = {}) {
  if (patch.rows < 8 || patch.cols < 8) return 0.0;
  cv::Mat g;
  cv::cvtColor(patch, g, patch.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return usable_noise(realism::noise_sigma(g, mask));
}

// The sensor noise beside an object whose box spans (x0, y0)-(x1, y1), as the realism metric reads it in its
// ring: Immerkaer's estimate over the four strips (up to 16 px wide) that frame the box, pooled; 0 when fewer
// than 256 of their pixels are in the picture. Strips, not the framed rectangle: the cost stays with the
// ring.
double ring_noise(const cv::Mat& image, double x0, double y0, double x1, double y1) {
  const int w = std::clamp(static_cast<int>(0.15 * (y1 - y0)), 6, 16);
  const int ix0 = static_cast<int>(std::floor(x0)), iy0 = static_cast<int>(std::floor(y0));
  const int ix1 = static_cast<int>(std::ceil(x1)), iy1 = static_cast<int>(std::ceil(y1));
  const cv::Rect img(0, 0, image.cols, image.rows);
  std::vector<cv::Mat> strips;
  int n = 0;
  for (const cv::Rect& r :
       {cv::Rect(ix0 - w, iy0 - w, ix1 - ix0 + 2 * w, w), cv::Rect(ix0 - w, iy1, ix1 - ix0 + 2 * w, w),
        cv::Rect(ix0 - w, iy0, w, iy1 - iy0), cv::Rect(ix1, iy0, w, iy1 - iy0)}) {
    const cv::Rect c = r & img;
    if (c.width < 8 || c.height < 8) continue;
    cv::Mat g;
    cv::cvtColor(image(c), g, cv::COLOR_BGR2GRAY);
    strips.push_back(g);
    n += c.area();
  }
  if (n < 256) return 0.0;
  return usable_noise(realism::noise_sigma(strips));
}

// A fixed tile of unit Gaussian noise in 1/1024 units; frames read it at shifting offsets so the grain
// changes every frame.
const cv::Mat& noise_tile_q10() {
  static const cv::Mat tile = [] {
    cv::Mat t(256, 256, CV_32F), q;
    cv::RNG rng(0x5eed);
    rng.fill(t, cv::RNG::NORMAL, 0.0, 1.0);
    t.convertTo(q, CV_16S, 1024.0);
    return q;
  }();
  return tile;
}

// Grain of a fully opaque pixel in 1/64 grey levels: sigma (1/256 grey levels) x unit noise (1/1024), kept
// within what the 16-bit arithmetic of the blend holds.
inline int16_t grain_q6(int sigma_q8, int unit_q10) {
  return static_cast<int16_t>(std::clamp((sigma_q8 * unit_q10 + 2048) >> 12, -8191, 8191));
}

// Grain of a pixel of alpha 0..255 in grey levels, rounded: (4 g)(64 alpha) >> 16 is g x alpha / 256 in 1/64
// levels, exactly what a 16-bit multiply-high of the vector blend gives.
inline int grain_at(uint32_t alpha, int g_q6) {
  return (((g_q6 * 4) * static_cast<int>(alpha * 64) >> 16) + 32) >> 6;
}

// The grain sigma whose rounded noise on a flat picture the realism metric reads as `target` (8-bit grey
// levels). Rounding to whole grey levels swallows most of a small sigma (0.3 reads as ~0.1), so the level is
// found on a table of what the metric reads for each sigma, built once from the grain itself.
double grain_for(double target) {
  struct Row {
    double sigma, reads;
  };
  static const std::vector<Row> table = [] {
    std::vector<Row> t;
    const cv::Mat& tile = noise_tile_q10();
    const double sigmas[] = {0,   0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0,
                             1.2, 1.4, 1.7, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0};
    double best = 0.0;
    for (double sg : sigmas) {
      cv::Mat g(tile.size(), CV_8U);
      const int q8 = static_cast<int>(std::lround(sg * 256));
      for (int y = 0; y < g.rows; ++y)
        for (int x = 0; x < g.cols; ++x)
          g.at<uint8_t>(y, x) =
              cv::saturate_cast<uint8_t>(128 + grain_at(255, grain_q6(q8, tile.at<int16_t>(y, x))));
      const double reads = realism::noise_sigma(g);
      best = std::max(best, std::isfinite(reads) ? reads : 0.0);  // kept monotone
      t.push_back({sg, best});
    }
    return t;
  }();
  if (!(target > 0)) return 0.0;
  for (size_t i = 1; i < table.size(); ++i)
    if (table[i].reads >= target) {
      const Row &a = table[i - 1], &b = table[i];
      const double f = b.reads > a.reads ? (target - a.reads) / (b.reads - a.reads) : 1.0;
      return a.sigma + f * (b.sigma - a.sigma);
    }
  return table.back().sigma;
}

// The background ring a sprite's sharpness is matched against: the pixels of the ROI 4–20 px from the shown
// picture (alpha > 0; `alpha` lies at `at` in the ROI), in 4 x 4 blocks: the blocks that hold none of the
// picture and none of its eight neighbours, but have one within four blocks. On the block grid two dilations
// cost a 16th of per-pixel ones (0.8 ms for a car 8 m ahead). `work` is reused across frames.
cv::Mat background_ring(const cv::Mat& alpha, cv::Rect at, cv::Size roi, cv::Mat& work) {
  constexpr int kBlock = 4;
  const cv::Size blocks((roi.width + kBlock - 1) / kBlock, (roi.height + kBlock - 1) / kBlock);
  cv::Mat any(blocks, CV_8U, cv::Scalar(0));
  std::vector<uint8_t> rows(static_cast<size_t>(alpha.cols));
  for (int y = 0; y < alpha.rows;) {
    // The picture's rows that fall into one row of blocks, OR-ed, then their columns block by block.
    const int by = (y + at.y) / kBlock, end = std::min(alpha.rows, (by + 1) * kBlock - at.y);
    std::fill(rows.begin(), rows.end(), 0);
    for (; y < end; ++y) {
      const uint8_t* a = alpha.ptr<uint8_t>(y);
      for (int x = 0; x < alpha.cols; ++x) rows[static_cast<size_t>(x)] |= a[x];
    }
    uint8_t* b = any.ptr<uint8_t>(by);
    for (int x = 0; x < alpha.cols; ++x) b[(x + at.x) / kBlock] |= rows[static_cast<size_t>(x)];
  }
  cv::Mat near, far;
  cv::dilate(any, near, cv::getStructuringElement(cv::MORPH_RECT, {3, 3}));
  cv::dilate(any, far, cv::getStructuringElement(cv::MORPH_RECT, {9, 9}));
  const cv::Mat ring_blocks = far & ~near;
  work.create(blocks.height * kBlock, blocks.width * kBlock, CV_8U);
  for (int by = 0; by < blocks.height; ++by) {
    const uint8_t* r = ring_blocks.ptr<uint8_t>(by);
    uint8_t* first = work.ptr<uint8_t>(by * kBlock);
    for (int x = 0; x < work.cols; ++x) first[x] = r[x / kBlock];
    for (int k = 1; k < kBlock; ++k)
      std::memcpy(work.ptr<uint8_t>(by * kBlock + k), first, static_cast<size_t>(work.cols));
  }
  return work(cv::Rect(cv::Point(0, 0), roi));
}

// Whether the camera records no colour: over every frame sampled so far, 99.5 % of the frame lies within
// kMonochromeReach of one Lab a/b point. A grey pixel (R = G = B) is a = b = 128 exactly; a grayscale video
// through a 4:2:0 codec and 8-bit rounding reads 0 or 1. A colour camera on a street reads 4 or more even
// under an overcast sky (nuScenes scene-0916: 4 to 9 in a, 6 to 22 in b).
constexpr double kMonochromeReach = 2.0;
bool monochrome_camera(const CompositorState& ex) {
  return ex.gamut_reach[0] >= 0 && ex.gamut_reach[0] <= kMonochromeReach &&
         ex.gamut_reach[1] <= kMonochromeReach;
}

// Per-channel affine map in Lab moving the asset's statistics part of the way to the surroundings'.
cv::Mat harmonisation_lut(const LoadedAsset& a, const CompositorState& ex, const CompositeOptions& o) {
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
    if (c > 0 && monochrome_camera(ex)) {
      // A camera that records no colour: the picture takes the camera's grey (or tint) too.
      gain[c] = 0.0;
      off[c] = ex.gamut_centre[c - 1];
    }
  }
  auto* p = lut.ptr<cv::Vec3b>(0);
  for (int v = 0; v < 256; ++v)
    for (int c = 0; c < 3; ++c) p[v][c] = cv::saturate_cast<uint8_t>(gain[c] * v + off[c]);
  return lut;
}

}  // namespace

void camera_gamut(const cv::Mat& image, cv::Vec2d& centre, cv::Vec2d& reach) {
  // Nearest-neighbour sampling keeps each pixel's own colour (averaging would shrink the reach).
  const double f = std::min(1.0, 160.0 / std::max(1, std::max(image.cols, image.rows)));
  cv::Mat small, lab;
  cv::resize(image, small, cv::Size(), f, f, cv::INTER_NEAREST);
  cv::cvtColor(small, lab, cv::COLOR_BGR2Lab);
  for (int c = 0; c < 2; ++c) {
    std::array<int, 256> hist{}, dev{};
    for (int y = 0; y < lab.rows; ++y) {
      const auto* p = lab.ptr<cv::Vec3b>(y);
      for (int x = 0; x < lab.cols; ++x) ++hist[p[x][c + 1]];
    }
    const int n = static_cast<int>(lab.total());
    int median = 0;
    for (int acc = 0; median < 255 && (acc += hist[static_cast<size_t>(median)]) * 2 < n;) ++median;
    for (int v = 0; v < 256; ++v) dev[static_cast<size_t>(std::abs(v - median))] += hist[static_cast<size_t>(v)];
    int r = 0;
    for (int acc = 0; r < 255 && (acc += dev[static_cast<size_t>(r)]) < 0.995 * n;) ++r;
    centre[c] = median;
    reach[c] = r;
  }
}

namespace {

// x * y / 255 for x * y <= 65025, rounded (the usual (t + (t >> 8)) >> 8 with t = x y + 128).
uint32_t mul_div255(uint32_t x, uint32_t y) {
  const uint32_t t = x * y + 128;
  return (t + (t >> 8)) >> 8;
}

}  // namespace

// The blend, 16 pixels at a time with OpenCV's universal intrinsics (the per-pixel loop took 2.4 ms for a car
// 8 m ahead), the rest one by one with the same integer arithmetic.
void blend_row(uint8_t* d, const uint8_t* s, const uint8_t* sh, const int16_t* g, int n) {
  int x = 0;
#if CV_SIMD128
  using namespace cv;
  const v_uint8x16 zero = v_setzero_u8(), full = v_setall_u8(255);
  const v_uint16x8 half = v_setall_u16(128);
  const v_int16x8 round6 = v_setall_s16(32);
  auto div255 = [&](const v_uint16x8& p) {
    const v_uint16x8 t = p + half;
    return (t + (t >> 8)) >> 8;
  };
  for (; x + 16 <= n; x += 16) {
    v_uint8x16 sb, sg, sr, sa;
    v_load_deinterleave(s + 4 * x, sb, sg, sr, sa);
    const v_uint8x16 sv = sh ? v_load(sh + x) : zero;
    if (!v_check_any((sa | sv) != zero)) continue;
    v_uint16x8 ia[2], is[2], keep[2], al[2];
    v_expand(full - sa, ia[0], ia[1]);
    v_expand(full - sv, is[0], is[1]);
    v_expand(sa, al[0], al[1]);
    v_int16x8 grain[2];
    for (int h = 0; h < 2; ++h) {
      keep[h] = div255(v_mul_wrap(ia[h], is[h]));
      const v_int16x8 g4 = v_shl<2>(v_load(g + x + 8 * h));
      grain[h] = (v_mul_hi(g4, v_reinterpret_as_s16(v_shl<6>(al[h]))) + round6) >> 6;
    }
    v_uint8x16 db, dg, dr;
    v_load_deinterleave(d + 3 * x, db, dg, dr);
    v_uint8x16* dst[3] = {&db, &dg, &dr};
    const v_uint8x16* src[3] = {&sb, &sg, &sr};
    for (int c = 0; c < 3; ++c) {
      v_uint16x8 bg[2], fg[2];
      v_expand(*dst[c], bg[0], bg[1]);
      v_expand(*src[c], fg[0], fg[1]);
      v_int16x8 out[2];
      for (int h = 0; h < 2; ++h)
        out[h] = v_reinterpret_as_s16(div255(v_mul_wrap(bg[h], keep[h])) + fg[h]) + grain[h];
      *dst[c] = v_pack_u(out[0], out[1]);
    }
    v_store_interleave(d + 3 * x, db, dg, dr);
  }
#endif
  for (; x < n; ++x) {
    const uint32_t al = s[4 * x + 3], sv = sh ? sh[x] : 0u;
    if ((al | sv) == 0) continue;
    const uint32_t keep = mul_div255(255 - al, 255 - sv);
    const int grain = grain_at(al, g[x]);
    for (int k = 0; k < 3; ++k)
      d[3 * x + k] =
          cv::saturate_cast<uint8_t>(static_cast<int>(mul_div255(d[3 * x + k], keep) + s[4 * x + k]) + grain);
  }
}

std::vector<int> mapping_corners(const AssetSpec& asset, const std::array<cv::Point2d, 8>& image_px) {
  // When the picture shows the box's faces in about the proportions the frame does, its whole outline goes
  // onto those faces (least squares), so the object fills its projected box. Otherwise only the faces both
  // show are matched: the picture is not squeezed onto faces it shows much more (or less) of than the frame.
  const std::vector<Face> shown = facing_faces(asset.box_corners_px);
  if (shown.empty()) return visible_corners(asset.azimuth_deg);
  const auto a = face_shares(asset.box_corners_px), b = face_shares(image_px);
  double mismatch = 0;
  for (int k = 0; k < 4; ++k) mismatch += std::abs(a[k] - b[k]);
  if (mismatch <= kMaxShareMismatch) return corners_of(shown);
  const std::vector<Face> seen = facing_faces(image_px);
  std::vector<Face> both;
  for (Face f : shown)
    if (std::find(seen.begin(), seen.end(), f) != seen.end()) both.push_back(f);
  return corners_of(both.empty() ? shown : both);
}

cv::Matx33d asset_homography(const LoadedAsset& a, const std::array<cv::Point2d, 8>& img) {
  const std::vector<int> ids = mapping_corners(a.spec, img);
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

int motion_blur(cv::Mat& bgra, cv::Point2d blur, std::vector<uint8_t>& row) {
  const double len = cv::norm(blur);
  const int passes = len >= 1.5 ? static_cast<int>(std::lround(std::log2(len))) : 0;
  const cv::Point2d dir = blur / std::max(len, 1e-9);
  for (int i = 0; i < passes; ++i) {
    const double step = std::ldexp(1.0, i);
    shift_average(bgra, row, static_cast<int>(std::lround(dir.x * step)),
                  static_cast<int>(std::lround(dir.y * step)));
  }
  return passes;
}

CompositeResult composite(cv::Mat& image, const Placement& p, const CompositeOptions& o,
                          CompositorState& st) {
  CompositorState& ex = st;
  CompositeResult r;
  const LoadedAsset& a = *p.asset;
  const cv::Matx33d H0 = asset_homography(a, p.corners_px);
  if (cv::norm(H0) < 1e-12) return r;

  // Pyramid level: the coarsest one still as tall as the object will be drawn (no aliasing, least work).
  const std::vector<int> ids = mapping_corners(a.spec, p.corners_px);
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
  std::array<cv::Point2d, 4> quad;
  size_t qi = 0;
  for (const cv::Point2d q : {cv::Point2d(0, 0), cv::Point2d(lvl_alpha.cols, 0),
                              cv::Point2d(lvl_alpha.cols, lvl_alpha.rows), cv::Point2d(0, lvl_alpha.rows)}) {
    double w = 0;
    const cv::Point2d m = apply(H, q, &w);
    if (w <= 1e-9) return r;
    quad[qi++] = m;
    x0 = std::min(x0, m.x);
    y0 = std::min(y0, m.y);
    x1 = std::max(x1, m.x);
    y1 = std::max(y1, m.y);
  }
  // The whole silhouette's coverage, borders or not: the picture's alpha sum times the area its rectangle
  // lands on over its own area (exact for an affine map; the object's perspective across itself is slight).
  double quad_area = 0;
  for (size_t i = 0; i < 4; ++i)
    quad_area += quad[i].x * quad[(i + 1) % 4].y - quad[(i + 1) % 4].x * quad[i].y;
  r.coverage_full = cv::sum(lvl_alpha)[0] / 255.0 * std::abs(quad_area) / 2.0 /
                    std::max(1.0, static_cast<double>(lvl_alpha.total()));
  double bx0 = 1e18, by0 = 1e18, bx1 = -1e18, by1 = -1e18;
  for (const auto& q : p.corners_px) {
    bx0 = std::min(bx0, q.x);
    by0 = std::min(by0, q.y);
    bx1 = std::max(bx1, q.x);
    by1 = std::max(by1, q.y);
  }
  const double obj_h = by1 - by0;
  // The projected box's outline: the surroundings' statistics leave it out, and drawing is kept to it.
  std::vector<cv::Point2f> hull;
  {
    std::vector<cv::Point2f> pts(p.corners_px.begin(), p.corners_px.end());
    cv::convexHull(pts, hull);
  }

  // The outline drawing is kept to (clip_to_box): the projected box's hull pushed out by the margin from its
  // centre. Skipped when the picture lands inside it anyway. The whole silhouette's coverage then counts only
  // the picture's alpha inside the outline mapped back onto the picture.
  std::vector<cv::Point2d> clip_poly;
  if (o.clip_to_box) {
    cv::Point2d mid(0, 0);
    for (const auto& q : hull) mid += cv::Point2d(q);
    mid *= 1.0 / static_cast<double>(hull.size());
    const double grow = kClipMargin * obj_h + 2.0;
    std::vector<cv::Point2f> grown;
    for (const auto& q : hull) {
      const cv::Point2d d = cv::Point2d(q) - mid;
      grown.emplace_back(cv::Point2d(q) + d * (grow / std::max(cv::norm(d), 1e-9)));
    }
    bool inside = true;
    for (const auto& q : quad) inside = inside && cv::pointPolygonTest(grown, cv::Point2f(q), false) >= 0;
    if (!inside) {
      const cv::Matx33d Hi = H.inv();
      std::vector<cv::Point> back;
      for (const auto& q : grown) {
        double w = 0;
        const cv::Point2d b = apply(Hi, cv::Point2d(q), &w);
        if (w <= 1e-9) {
          back.clear();
          break;
        }
        back.emplace_back(static_cast<int>(std::lround(b.x * 16)), static_cast<int>(std::lround(b.y * 16)));
      }
      for (const auto& q : grown) clip_poly.emplace_back(q);
      if (!back.empty()) {
        st.clip_back.create(lvl_alpha.size(), CV_8U);  // reallocated only when the pyramid level changes
        st.clip_back.setTo(0);
        cv::fillConvexPoly(st.clip_back, back, cv::Scalar(255), cv::LINE_AA, 4);
        r.coverage_full = st.clip_back.dot(lvl_alpha) / (255.0 * 255.0) * std::abs(quad_area) / 2.0 /
                          std::max(1.0, static_cast<double>(lvl_alpha.total()));
      }
    }
  }
  const cv::Point2d blur = p.velocity_px_s * o.exposure_s;
  const double blur_len = std::min(cv::norm(blur), 0.5 * std::max(obj_h, 8.0));
  const int shadow_k = odd(std::max(3.0, 0.08 * obj_h));
  const int pad =
      static_cast<int>(std::ceil(blur_len / 2 + 3 * o.feather_px)) + 2 + (o.match_sharpness > 0 ? 8 : 0);
  const int spad = o.shadow ? shadow_k + 2 : 0;
  const cv::Rect img_rect(0, 0, image.cols, image.rows);
  // A cast shadow reaches beyond the object: the region drawn covers it.
  double rx0 = bx0 - spad, ry0 = by0, rx1 = bx1 + spad, ry1 = by1 + spad;
  if (o.shadow && p.cast_px)
    for (const auto& q : *p.cast_px) {
      rx0 = std::min(rx0, q.x - spad);
      rx1 = std::max(rx1, q.x + spad);
      ry0 = std::min(ry0, q.y - spad);
      ry1 = std::max(ry1, q.y + spad);
    }
  const cv::Rect want(static_cast<int>(std::floor(std::min(x0, rx0))) - pad,
                      static_cast<int>(std::floor(std::min(y0, ry0))) - pad,
                      static_cast<int>(std::ceil(std::max(x1, rx1) - std::min(x0, rx0))) + 2 * pad + 1,
                      static_cast<int>(std::ceil(std::max(y1, ry1) - std::min(y0, ry0))) + 2 * pad + 1);
  const cv::Rect roi = want & img_rect;
  if (roi.area() <= 0) return r;
  r.roi = roi;

  // Surroundings' colour statistics, smoothed over time so exposure does not flicker.
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
  if (o.grain && (ex.noise_frames == 0 || ex.frame % 4 == 0)) {
    // Noise beside the object, read as the realism metric reads it (in a ring around the object); frames
    // where too little of the ring is in the picture do not count. A camera's noise level changes slowly:
    // after the first reading, every fourth frame.
    const double noise = ring_noise(image, bx0, by0, bx1, by1);
    if (noise > 0) {
      ex.noise_sigma = ex.noise_frames == 0
                           ? noise
                           : ex.noise_sigma * o.exposure_smoothing + noise * (1 - o.exposure_smoothing);
      ++ex.noise_frames;
    }
  }
  const bool colour_known = ex.gamut_reach[0] > kMonochromeReach || ex.gamut_reach[1] > kMonochromeReach;
  if (ex.frame % 4 == 0 && !colour_known) {
    // What colours the camera records: the widest reach so far (a camera's gamut does not shrink, so once it
    // is known to record colour it is not sampled again).
    cv::Vec2d centre, reach;
    camera_gamut(image, centre, reach);
    ex.gamut_centre = ex.gamut_reach[0] < 0 ? centre : ex.gamut_centre * 0.8 + centre * 0.2;
    for (int c = 0; c < 2; ++c) ex.gamut_reach[c] = std::max(ex.gamut_reach[c], reach[c]);
  }
  ++ex.frame;
  // The harmonised, premultiplied, feathered picture at this level. It is rebuilt only when the asset or
  // level changes, when the (smoothed, so settling) harmonisation moves by more than two grey levels, or when
  // the feather width in picture pixels drifts by a quarter as the object's size changes.
  const cv::Mat lut =
      ex.valid ? harmonisation_lut(a, ex, o) : cv::Mat();
  const double level_face_h = (sy1 - sy0) * f;
  const double feather = o.feather_px > 0.05 ? o.feather_px * level_face_h / std::max(iy1 - iy0, 1.0) : 0.0;
  bool rebuild = st.sprite_asset != &a || st.sprite_level != r.level ||
                 lut.empty() != st.sprite_lut.empty() ||
                 std::abs(feather - st.sprite_feather) > 0.25 * std::max(st.sprite_feather, 0.2);
  if (!rebuild && !lut.empty()) {
    cv::Mat d;
    cv::absdiff(lut, st.sprite_lut, d);
    double mx = 0;
    cv::minMaxLoc(d.reshape(1), nullptr, &mx);
    rebuild = mx > 2.0;
  }
  if (rebuild) {
    cv::Mat colour = a.bgr[static_cast<size_t>(r.level)];
    if (!lut.empty()) {
      cv::Mat lab;
      cv::LUT(a.lab[static_cast<size_t>(r.level)], lut, lab);
      cv::cvtColor(lab, colour, cv::COLOR_Lab2BGR);
    }
    // Premultiply: (b, g, r, a) * (a, a, a, 255) / 255, then feather. (Feathering the alpha alone keeps the
    // colour sharper, and YOLOv8n then finds the default person in 12 instead of 18 of the 36 frames of
    // pedestrian_crossing_udacity; match_sharpness below blurs further where the recording is softer.)
    cv::Mat bgra, weights;
    cv::Mat opaque(lvl_alpha.size(), CV_8U, cv::Scalar(255));
    cv::merge(std::vector<cv::Mat>{colour, lvl_alpha}, bgra);
    cv::merge(std::vector<cv::Mat>{lvl_alpha, lvl_alpha, lvl_alpha, opaque}, weights);
    cv::multiply(bgra, weights, st.sprite, 1.0 / 255);
    if (feather > 0.05) cv::GaussianBlur(st.sprite, st.sprite, cv::Size(), feather);
    st.sprite_asset = &a;
    st.sprite_level = r.level;
    st.sprite_lut = lut.clone();
    st.sprite_feather = feather;
    st.own_noise = -1.0;  // a new picture: its noise is read again
  }

  // Warp the premultiplied picture onto its part of the ROI (8-bit throughout: blurring and blending
  // premultiplied colour never bleeds the transparent surroundings in). Buffers are reused across frames.
  auto area = [](cv::Mat& buf, cv::Size sz, int type) {
    if (buf.type() != type || buf.rows < sz.height || buf.cols < sz.width)
      buf.create(std::max(buf.rows, sz.height), std::max(buf.cols, sz.width), type);
    return buf(cv::Rect(cv::Point(0, 0), sz));
  };
  cv::Mat pre = area(st.warped, roi.size(), CV_8UC4);
  pre.setTo(cv::Scalar::all(0));
  const cv::Rect spr =
      cv::Rect(static_cast<int>(std::floor(x0)) - roi.x - 1, static_cast<int>(std::floor(y0)) - roi.y - 1,
               static_cast<int>(std::ceil(x1 - x0)) + 3, static_cast<int>(std::ceil(y1 - y0)) + 3) &
      cv::Rect(0, 0, roi.width, roi.height);
  if (spr.area() <= 0) return r;
  cv::Mat pre_spr = pre(spr);
  // Only what the kept outline can show is warped (the rest of the picture's rectangle stays clear): the
  // outline's bounding box, a pixel wider for its anti-aliased edge (about 8 % of the warp for a car 8 m
  // ahead).
  cv::Rect drawn = spr;
  if (!clip_poly.empty()) {
    double cx0 = 1e18, cy0 = 1e18, cx1 = -1e18, cy1 = -1e18;
    for (const auto& q : clip_poly) {
      cx0 = std::min(cx0, q.x);
      cy0 = std::min(cy0, q.y);
      cx1 = std::max(cx1, q.x);
      cy1 = std::max(cy1, q.y);
    }
    const cv::Rect kept(static_cast<int>(std::floor(cx0)) - roi.x - 1,
                        static_cast<int>(std::floor(cy0)) - roi.y - 1,
                        static_cast<int>(std::ceil(cx1) - std::floor(cx0)) + 3,
                        static_cast<int>(std::ceil(cy1) - std::floor(cy0)) + 3);
    drawn &= kept;
  }
  if (drawn.area() > 0) {
    const cv::Matx33d T(1, 0, -(roi.x + drawn.x), 0, 1, -(roi.y + drawn.y), 0, 0, 1);
    cv::Mat out = pre(drawn);
    warp_bgra(st.sprite, out, T * H);
  }
  if (!clip_poly.empty()) {
    cv::Mat keep = area(st.clip, spr.size(), CV_8U);
    keep.setTo(0);
    std::vector<cv::Point> poly;
    for (const auto& q : clip_poly)
      poly.emplace_back(static_cast<int>(std::lround((q.x - roi.x - spr.x) * 16)),
                        static_cast<int>(std::lround((q.y - roi.y - spr.y) * 16)));
    cv::fillConvexPoly(keep, poly, cv::Scalar(255), cv::LINE_AA, 4);
    const cv::Rect in_spr = drawn - spr.tl();  // outside it the picture is clear already
    for (int y = in_spr.y; y < in_spr.y + in_spr.height; ++y) {
      uint8_t* d = pre_spr.ptr<uint8_t>(y);
      const uint8_t* k = keep.ptr<uint8_t>(y);
      for (int x = in_spr.x; x < in_spr.x + in_spr.width; ++x) {
        if (k[x] == 255) continue;
        if (k[x] == 0) {  // outside the outline (most of what is not kept): cleared
          std::memset(d + 4 * x, 0, 4);
          continue;
        }
        for (int c = 0; c < 4; ++c) d[4 * x + c] = static_cast<uint8_t>(mul_div255(d[4 * x + c], k[x]));
      }
    }
  }
  // Match the recording's blur (defocus, motion, compression): the picture's interior is made no sharper than
  // the frame around it — the variance of its Laplacian brought to `match_sharpness` times the background
  // ring's, by the least Gaussian blur (hazardforge/realism), smoothed over frames. Premultiplied, so the
  // silhouette softens with it as a blurred camera would soften it.
  // A recording's blur changes slowly (focus, exposure, speed): after the first reading it is read every
  // fourth frame, two frames after the noise is read (the two readings never fall on one frame), and again
  // whenever the picture was rebuilt (another pyramid level or feather changes its own sharpness); the frames
  // between apply the last smoothed value. The reading is the larger part of the cost of matching (2.2 ms per
  // frame for a car 8 m ahead in the renderer bench).
  const bool read_blur = rebuild || st.blur_frames == 0 || (ex.frame - 1) % 4 == 2;
  if (o.match_sharpness > 0 && read_blur) {
    cv::Mat a_spr, solid, grey_spr, grey_bg;
    cv::extractChannel(pre_spr, a_spr, 3);
    cv::erode(a_spr == 255, solid, cv::getStructuringElement(cv::MORPH_RECT, {5, 5}));
    const cv::Mat ring = background_ring(a_spr, spr, roi.size(), st.ring);
    cv::cvtColor(image(roi), grey_bg, cv::COLOR_BGR2GRAY);
    cv::cvtColor(pre_spr, grey_spr, cv::COLOR_BGRA2GRAY);
    const double bg_var = realism::laplacian_variance(grey_bg, ring);
    double sigma = 0.0;
    if (std::isfinite(bg_var) && cv::countNonZero(solid) >= 64)
      sigma = realism::blur_to_match(grey_spr, solid, o.match_sharpness * bg_var, st.last_match_sigma);
    st.last_match_sigma = sigma;
    st.blur_sigma = st.blur_frames == 0
                        ? sigma
                        : o.exposure_smoothing * st.blur_sigma + (1 - o.exposure_smoothing) * sigma;
    ++st.blur_frames;
  }
  if (o.match_sharpness > 0) {
    r.match_sigma = st.blur_sigma;
    if (st.blur_sigma >= 0.3) {
      const cv::Rect grown = cv::Rect(spr.x - 6, spr.y - 6, spr.width + 12, spr.height + 12) &
                             cv::Rect(0, 0, roi.width, roi.height);
      cv::Mat part = pre(grown);
      cv::GaussianBlur(part, part, cv::Size(), st.blur_sigma, st.blur_sigma, cv::BORDER_CONSTANT);
    }
  }
  if (blur_len >= 1.5) {
    const int reach = static_cast<int>(std::ceil(blur_len)) + 1;
    const cv::Rect moved =
        cv::Rect(spr.x - reach, spr.y - reach, spr.width + 2 * reach, spr.height + 2 * reach) &
        cv::Rect(0, 0, roi.width, roi.height);
    cv::Mat part = pre(moved);
    motion_blur(part, blur / std::max(cv::norm(blur), 1e-9) * blur_len, st.row);
  }
  // Nearer objects stay in front: the hazard (and its shadow) is removed under their boxes.
  std::vector<cv::Rect> occ;
  double removed = 0;
  for (const cv::Rect2f& b : p.occluders) {
    const cv::Rect ib(static_cast<int>(std::floor(b.x)) - roi.x, static_cast<int>(std::floor(b.y)) - roi.y,
                      static_cast<int>(std::ceil(b.x + b.width) - std::floor(b.x)),
                      static_cast<int>(std::ceil(b.y + b.height) - std::floor(b.y)));
    const cv::Rect cl = ib & cv::Rect(0, 0, roi.width, roi.height);
    if (cl.area() > 0) {
      removed += cv::sum(pre(cl))[3] / 255.0;
      pre(cl).setTo(cv::Scalar::all(0));
      occ.push_back(cl);
    }
  }
  cv::extractChannel(pre, r.alpha, 3);
  r.coverage_after = cv::sum(r.alpha)[0] / 255.0;
  r.coverage_before = r.coverage_after + removed;

  // Soft contact shadow shaped by the footprint, not its rectangle: a rounded footprint (superellipse
  // |u|^4 + |v|^4 = 1 in the footprint's own coordinates, mapped by its homography, so perspective holds) a
  // little larger than the object, with a darker core under its middle where the body is nearest the road;
  // blurred.
  cv::Mat shadow;
  if (o.shadow && o.shadow_strength > 0) {
    // Footprint corners 0..3 are front-left, front-right, rear-right, rear-left: (u, v) = (+-1 forward, +-1
    // left).
    const std::vector<cv::Point2f> unit = {{1, 1}, {1, -1}, {-1, -1}, {-1, 1}};
    std::vector<cv::Point2f> foot;
    for (int i = 0; i < 4; ++i) foot.emplace_back(p.corners_px[i] - cv::Point2d(roi.x, roi.y));
    const cv::Matx33d Hf = cv::Matx33d(cv::getPerspectiveTransform(unit, foot));
    auto outline_of = [&](const cv::Matx33d& H, double su, double sv) {
      std::vector<cv::Point> poly;
      for (int k = 0; k < 32; ++k) {
        const double th = 2 * CV_PI * k / 32, c = std::cos(th), sn = std::sin(th);
        const double u = su * std::copysign(std::sqrt(std::abs(c)), c),
                     v = sv * std::copysign(std::sqrt(std::abs(sn)), sn);
        const cv::Vec3d q = H * cv::Vec3d(u, v, 1);
        if (q[2] <= 1e-9) return std::vector<cv::Point>();
        poly.emplace_back(static_cast<int>(std::lround(q[0] / q[2] * 16)),
                          static_cast<int>(std::lround(q[1] / q[2] * 16)));
      }
      return poly;
    };
    auto outline = [&](double su, double sv) { return outline_of(Hf, su, sv); };
    std::vector<cv::Point> outer = outline(1.12, 1.12), core = outline(0.8, 0.7);
    // The sun's shadow: the footprint swept along the shadow (the convex hull of the footprint and its cast
    // copy).
    std::vector<cv::Point> cast;
    if (p.cast_px && p.cast_darkness > 0 && !outer.empty()) {
      std::vector<cv::Point2f> moved;
      for (int i = 0; i < 4; ++i)
        moved.emplace_back((*p.cast_px)[static_cast<size_t>(i)] - cv::Point2d(roi.x, roi.y));
      const std::vector<cv::Point> far =
          outline_of(cv::Matx33d(cv::getPerspectiveTransform(unit, moved)), 1.0, 1.0);
      if (!far.empty()) {
        std::vector<cv::Point> both = outline(1.0, 1.0);
        both.insert(both.end(), far.begin(), far.end());
        cv::convexHull(both, cast);
      }
    }
    shadow = area(st.shadow, roi.size(), CV_8U);
    shadow.setTo(0);
    // Only the footprint's neighbourhood is filled and blurred.
    cv::Rect fb = outer.empty() ? cv::Rect() : cv::boundingRect(outer);
    if (!cast.empty()) fb |= cv::boundingRect(cast);
    fb = cv::Rect(fb.x / 16 - shadow_k - 1, fb.y / 16 - shadow_k - 1, fb.width / 16 + 2 * shadow_k + 3,
                  fb.height / 16 + 2 * shadow_k + 3) &
         cv::Rect(0, 0, roi.width, roi.height);
    if (fb.area() > 0 && !core.empty()) {
      cv::Mat part = shadow(fb);
      for (auto& q : outer) q -= cv::Point(fb.x * 16, fb.y * 16);
      for (auto& q : core) q -= cv::Point(fb.x * 16, fb.y * 16);
      for (auto& q : cast) q -= cv::Point(fb.x * 16, fb.y * 16);
      cv::fillPoly(part, std::vector<std::vector<cv::Point>>{outer},
                   cv::Scalar(std::lround(210 * o.shadow_strength)), cv::LINE_AA, 4);
      cv::fillPoly(part, std::vector<std::vector<cv::Point>>{core},
                   cv::Scalar(std::lround(255 * o.shadow_strength)), cv::LINE_AA, 4);
      if (!cast.empty()) {
        // Where the sun's shadow is darker than the contact shadow, it wins.
        cv::Mat sun(part.size(), CV_8U, cv::Scalar(0));
        cv::fillPoly(sun, std::vector<std::vector<cv::Point>>{cast},
                     cv::Scalar(std::lround(255 * std::clamp(p.cast_darkness, 0.0, 0.95))), cv::LINE_AA, 4);
        cv::max(part, sun, part);
      }
      cv::blur(part, part, cv::Size(shadow_k, shadow_k), cv::Point(-1, -1), cv::BORDER_CONSTANT);
      cv::blur(part, part, cv::Size(shadow_k, shadow_k), cv::Point(-1, -1), cv::BORDER_CONSTANT);
    }
    for (const cv::Rect& cl : occ) shadow(cl).setTo(0);
  }

  // Blend: out = background * (1 - shadow) * (1 - alpha) + premultiplied colour (+ grain on the object, as
  // the camera would have added it).
  cv::Mat dst = image(roi);
  // Integer arithmetic (blend_row): background (255 - a)(255 - s) / 255^2 as two rounded divisions by 255;
  // grain = alpha x sigma x unit noise, from a fixed-point tile.
  const cv::Mat& tile = noise_tile_q10();
  const int ox = static_cast<int>((ex.frame * 97) % tile.cols),
            oy = static_cast<int>((ex.frame * 61) % tile.rows);
  // Grain tops the picture's own noise up to the surroundings' (a harvested cut-out carries its camera's,
  // which blurring lowered): measured as drawn, on a central patch of the opaque picture, on the frames the
  // surroundings' noise is read on (it changes as slowly: with the blur and the pyramid level).
  double grain = 0.0;
  if (o.grain && ex.noise_sigma > 0) {
    const int side = std::min({128, spr.width / 2, spr.height / 2});
    if (st.own_noise < 0 || (ex.frame - 1) % 4 == 0) {
      st.own_noise = 0.0;
      if (side >= 8) {
        const cv::Rect c(spr.x + (spr.width - side) / 2, spr.y + (spr.height - side) / 2, side, side);
        cv::Mat a;
        cv::extractChannel(pre(c), a, 3);
        st.own_noise = noise_level(pre(c), a == 255);
      }
    }
    grain =
        grain_for(std::sqrt(std::max(0.0, ex.noise_sigma * ex.noise_sigma - st.own_noise * st.own_noise)));
  }
  r.grain_sigma = grain;
  const int grain_q8 = static_cast<int>(std::lround(grain * 256.0));
  // The grain at full alpha over the tile for this sigma, kept while the sigma stays (it changes on the
  // frames the noise is read on, one in four), then one row of the ROI at a time.
  if (grain_q8 && st.grain_tile_q8 != grain_q8) {
    st.grain_tile.create(tile.size(), CV_16S);
    for (int y = 0; y < tile.rows; ++y) {
      const int16_t* u = tile.ptr<int16_t>(y);
      int16_t* g = st.grain_tile.ptr<int16_t>(y);
      for (int x = 0; x < tile.cols; ++x) g[x] = grain_q6(grain_q8, u[x]);
    }
    st.grain_tile_q8 = grain_q8;
  }
  std::vector<int16_t>& grain_row = st.grain_row;
  grain_row.assign(static_cast<size_t>(roi.width), 0);
  for (int y = 0; y < roi.height; ++y) {
    if (grain_q8) {
      const int16_t* nz = st.grain_tile.ptr<int16_t>((y + oy) % tile.rows);
      for (int x = 0; x < roi.width;) {
        const int nx = (x + ox) % tile.cols, len = std::min(roi.width - x, tile.cols - nx);
        std::memcpy(grain_row.data() + x, nz + nx, sizeof(int16_t) * static_cast<size_t>(len));
        x += len;
      }
    }
    blend_row(dst.ptr<uint8_t>(y), pre.ptr<uint8_t>(y), shadow.empty() ? nullptr : shadow.ptr<uint8_t>(y),
              grain_row.data(), roi.width);
  }
  r.drawn = true;
  return r;
}

}  // namespace hf::render
