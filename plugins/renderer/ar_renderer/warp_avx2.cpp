// Internal: the AVX2 kernel of warp_bgra (this file alone is compiled with -mavx2 -mfma; see warp.hpp).
#include <immintrin.h>

#include <cstdint>

#include "warp.hpp"

namespace hf::render::detail {

namespace {

// 1 where 0 <= v <= lim, per 32-bit lane.
inline __m256i in_range(__m256i v, __m256i lim) {
  const __m256i below = _mm256_cmpgt_epi32(_mm256_setzero_si256(), v), above = _mm256_cmpgt_epi32(v, lim);
  return _mm256_xor_si256(_mm256_or_si256(below, above), _mm256_set1_epi32(-1));
}

// One pixel by the same rule (the row's tail): 1/32 px position, weights (32 - a)(32 - b) ... summing to 1024.
inline uint32_t one_pixel(const cv::Mat& src, double X, double Y, double W) {
  if (W == 0) return 0;
  const double fx = X * 32 / W, fy = Y * 32 / W;
  if (!(fx > -1e9 && fx < 1e9 && fy > -1e9 && fy < 1e9)) return 0;
  const int sx = cvRound(fx), sy = cvRound(fy);
  const int x0 = sx >> 5, y0 = sy >> 5, a = sx & 31, b = sy & 31;
  uint32_t out = 0;
  for (int c = 0; c < 4; ++c) {
    auto at = [&](int x, int y) {
      return (x >= 0 && x < src.cols && y >= 0 && y < src.rows) ? src.ptr<uint8_t>(y)[4 * x + c] : 0;
    };
    const int v = at(x0, y0) * (32 - a) * (32 - b) + at(x0 + 1, y0) * a * (32 - b) + at(x0, y0 + 1) * (32 - a) * b +
                  at(x0 + 1, y0 + 1) * a * b;
    out |= static_cast<uint32_t>((v + 512) >> 10) << (8 * c);
  }
  return out;
}

}  // namespace

void warp_bgra_avx2(const cv::Mat& src, cv::Mat& dst, const cv::Matx33d& M) {
  const __m256i zero = _mm256_setzero_si256(), one = _mm256_set1_epi32(1), c32 = _mm256_set1_epi32(32);
  const __m256i m31 = _mm256_set1_epi32(31), rnd = _mm256_set1_epi32(512);
  const __m256i wlim = _mm256_set1_epi32(src.cols - 1), hlim = _mm256_set1_epi32(src.rows - 1);
  const __m256i stride = _mm256_set1_epi32(static_cast<int>(src.step[0] / 4));
  const __m256 lane = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256 m00 = _mm256_set1_ps(static_cast<float>(M(0, 0))), m10 = _mm256_set1_ps(static_cast<float>(M(1, 0)));
  const __m256 m20 = _mm256_set1_ps(static_cast<float>(M(2, 0)));
  const int* base = reinterpret_cast<const int*>(src.data);
  for (int y = 0; y < dst.rows; ++y) {
    uint32_t* d = dst.ptr<uint32_t>(y);
    const double X0 = M(0, 1) * y + M(0, 2), Y0 = M(1, 1) * y + M(1, 2), W0 = M(2, 1) * y + M(2, 2);
    const __m256 x0v = _mm256_set1_ps(static_cast<float>(X0)), y0v = _mm256_set1_ps(static_cast<float>(Y0));
    const __m256 w0v = _mm256_set1_ps(static_cast<float>(W0));
    int x = 0;
    for (; x + 8 <= dst.cols; x += 8) {
      const __m256 xs = _mm256_add_ps(_mm256_set1_ps(static_cast<float>(x)), lane);
      const __m256 W = _mm256_fmadd_ps(m20, xs, w0v);
      const __m256 k = _mm256_div_ps(_mm256_set1_ps(32.0f), W);
      // Positions in 1/32 px (rounded); a position beyond int range or NaN becomes INT_MIN: out of range.
      const __m256i sx = _mm256_cvtps_epi32(_mm256_mul_ps(_mm256_fmadd_ps(m00, xs, x0v), k));
      const __m256i sy = _mm256_cvtps_epi32(_mm256_mul_ps(_mm256_fmadd_ps(m10, xs, y0v), k));
      const __m256i xa = _mm256_srai_epi32(sx, 5), ya = _mm256_srai_epi32(sy, 5);
      const __m256i xb = _mm256_add_epi32(xa, one), yb = _mm256_add_epi32(ya, one);
      const __m256i ixa = in_range(xa, wlim), ixb = in_range(xb, wlim), iya = in_range(ya, hlim), iyb = in_range(yb, hlim);
      if (_mm256_testz_si256(_mm256_or_si256(ixa, ixb), _mm256_or_si256(iya, iyb))) {
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(d + x), zero);  // all eight outside the picture
        continue;
      }
      const __m256i ra = _mm256_mullo_epi32(ya, stride), rb = _mm256_add_epi32(ra, stride);
      const __m256i p00 = _mm256_mask_i32gather_epi32(zero, base, _mm256_add_epi32(ra, xa), _mm256_and_si256(ixa, iya), 4);
      const __m256i p01 = _mm256_mask_i32gather_epi32(zero, base, _mm256_add_epi32(ra, xb), _mm256_and_si256(ixb, iya), 4);
      const __m256i p10 = _mm256_mask_i32gather_epi32(zero, base, _mm256_add_epi32(rb, xa), _mm256_and_si256(ixa, iyb), 4);
      const __m256i p11 = _mm256_mask_i32gather_epi32(zero, base, _mm256_add_epi32(rb, xb), _mm256_and_si256(ixb, iyb), 4);
      const __m256i ax = _mm256_and_si256(sx, m31), ay = _mm256_and_si256(sy, m31);
      // Across: byte pairs (32 - ax, ax) against each channel's two neighbours (maddubs, at most 255 * 32).
      const __m256i wx16 = _mm256_or_si256(_mm256_sub_epi32(c32, ax), _mm256_slli_epi32(ax, 8));
      const __m256i wx = _mm256_or_si256(wx16, _mm256_slli_epi32(wx16, 16));
      const __m256i wxl = _mm256_unpacklo_epi32(wx, wx), wxh = _mm256_unpackhi_epi32(wx, wx);
      const __m256i h0l = _mm256_maddubs_epi16(_mm256_unpacklo_epi8(p00, p01), wxl);
      const __m256i h0h = _mm256_maddubs_epi16(_mm256_unpackhi_epi8(p00, p01), wxh);
      const __m256i h1l = _mm256_maddubs_epi16(_mm256_unpacklo_epi8(p10, p11), wxl);
      const __m256i h1h = _mm256_maddubs_epi16(_mm256_unpackhi_epi8(p10, p11), wxh);
      // Down: 16-bit pairs (32 - ay, ay) against the two rows (madd), rounded, / 1024.
      const __m256i wy = _mm256_or_si256(_mm256_sub_epi32(c32, ay), _mm256_slli_epi32(ay, 16));
      auto down = [&](__m256i rows, __m256i w) {
        return _mm256_srli_epi32(_mm256_add_epi32(_mm256_madd_epi16(rows, w), rnd), 10);
      };
      const __m256i v0 = down(_mm256_unpacklo_epi16(h0l, h1l), _mm256_shuffle_epi32(wy, 0x00));
      const __m256i v1 = down(_mm256_unpackhi_epi16(h0l, h1l), _mm256_shuffle_epi32(wy, 0x55));
      const __m256i v2 = down(_mm256_unpacklo_epi16(h0h, h1h), _mm256_shuffle_epi32(wy, 0xAA));
      const __m256i v3 = down(_mm256_unpackhi_epi16(h0h, h1h), _mm256_shuffle_epi32(wy, 0xFF));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(d + x),
                          _mm256_packus_epi16(_mm256_packs_epi32(v0, v1), _mm256_packs_epi32(v2, v3)));
    }
    for (; x < dst.cols; ++x) d[x] = one_pixel(src, M(0, 0) * x + X0, M(1, 0) * x + Y0, M(2, 0) * x + W0);
  }
}

}  // namespace hf::render::detail
