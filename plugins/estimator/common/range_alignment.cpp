// Ridge fit of the ground cue's inverse depth on the pinhole cue's: g = a + b p.
#include "hazardforge/estimation/range_alignment.hpp"

#include <algorithm>
#include <cmath>

namespace hf::estimation {

RangeAlignment::RangeAlignment(double offset_sd, double scale_sd, double memory)
    : offset_sd_(std::max(offset_sd, 1e-9)), scale_sd_(std::max(scale_sd, 1e-9)), memory_(memory) {}

void RangeAlignment::add(double g, double p, double var_g, double var_p) {
  if (!(std::isfinite(g) && std::isfinite(p) && p > 0)) return;
  // Residual g - a - b p carries g's noise and b times p's.
  const double var = var_g + b_ * b_ * var_p;
  if (!(var > 0) || !std::isfinite(var)) return;
  const double w = 1.0 / var;
  sw_ = memory_ * sw_ + w;
  swp_ = memory_ * swp_ + w * p;
  swpp_ = memory_ * swpp_ + w * p * p;
  swg_ = memory_ * swg_ + w * g;
  swpg_ = memory_ * swpg_ + w * p * g;
  ++frames_;
  solve();
}

void RangeAlignment::solve() {
  // Minimise sum w (g - a - b p)^2 + a^2 / sa^2 + (b - 1)^2 / sb^2.
  const double pa = 1.0 / (offset_sd_ * offset_sd_), pb = 1.0 / (scale_sd_ * scale_sd_);
  const double m00 = pa + sw_, m01 = swp_, m11 = pb + swpp_;
  const double r0 = swg_, r1 = pb + swpg_;
  const double det = m00 * m11 - m01 * m01;
  if (!(det > 0)) return;
  const double a = (m11 * r0 - m01 * r1) / det, b = (m00 * r1 - m01 * r0) / det;
  if (!(b > 0.2) || !std::isfinite(a)) return;  // a fit this far off is not a calibration error
  a_ = a;
  b_ = b;
}

void RangeAlignment::rescale_pinhole(double k) {
  if (!(k > 0)) return;
  swp_ /= k;
  swpp_ /= k * k;
  swpg_ /= k;
  b_ *= k;
  solve();
}

}  // namespace hf::estimation
