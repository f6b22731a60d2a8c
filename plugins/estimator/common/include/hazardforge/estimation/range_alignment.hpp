// Per-track relation between the ground-contact range and the pinhole (class-height) range of one object.
#pragma once

namespace hf::estimation {

// Both range cues of a monocular camera are inverse depths: the ground contact gives
// g = (v_bottom - v_horizon) / (fy hc), the box height p = h / (fy H). Their errors are not alike: the class
// prior's height error scales p by a constant factor for the whole track, which no TTC sees (range and
// closing speed scale together); a camera pitch error shifts the horizon row and so adds a constant *offset*
// to g, which makes the ground range's relative error grow with distance and reads as a closing speed when
// the object approaches. A road surface off the ego's plane scales g. So on one track g = a + b p, with the
// offset a (pitch) and the scale b (height prior, road height) constant; the fit of (a, b) over the track's
// frames, with priors from the stated uncertainties, maps the ground cue onto the pinhole cue's scale, and
// fusing the two then adds no drift when their weights change with distance or when one of them comes and
// goes.
class RangeAlignment {
 public:
  // offset_sd: spread of a (1/m), tan(pitch uncertainty) / camera height. scale_sd: relative spread of b.
  // memory: factor on the past frames' weight at each new frame (1 = all frames count alike).
  RangeAlignment(double offset_sd, double scale_sd, double memory = 0.98);
  RangeAlignment() : RangeAlignment(0.005, 0.1) {}

  // One frame with both cues: inverse depths g (ground) and p (pinhole), and their noise variances.
  void add(double inv_ground, double inv_pinhole, double var_ground, double var_pinhole);
  int frames() const { return frames_; }
  double offset() const { return a_; }
  double scale() const { return b_; }
  // The ground cue's inverse depth on the pinhole scale, (g - a) / b; <= 0 when the fit puts it beyond the
  // horizon (the cue is then unusable).
  double to_pinhole(double inv_ground) const { return (inv_ground - a_) / b_; }
  // The pinhole cue's depth was multiplied by k (a track relabelled to a class of another height): p -> p /
  // k.
  void rescale_pinhole(double k);

 private:
  void solve();
  double offset_sd_, scale_sd_, memory_;
  // Weighted sums of the normal equations: sum w, w p, w p^2, w g, w p g.
  double sw_ = 0, swp_ = 0, swpp_ = 0, swg_ = 0, swpg_ = 0;
  double a_ = 0.0, b_ = 1.0;
  int frames_ = 0;
};

}  // namespace hf::estimation
