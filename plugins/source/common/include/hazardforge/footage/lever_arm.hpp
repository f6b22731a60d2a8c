// The distance driven between two views from the camera's lever arm in a turn (no road needed).
#pragma once

#include <optional>
#include <vector>

#include "hazardforge/footage/ego_motion.hpp"

namespace hf::footage {

// A car does not slide sideways: its rear axle moves along an arc, and a camera mounted lever_m ahead of it
// swings out of the arc's chord as the car turns (the non-holonomic constraint of Scaramuzza, Fraundorfer,
// Pollefeys and Siegwart, ICCV 2009). Between two views turning by `turn` (rad, left positive) the camera
// moves by c (cos turn/2, sin turn/2) + lever_m (cos turn - 1, sin turn) in the first view's ego axes, c being
// the chord the rear axle drove. Its direction (`heading`, rad, left positive) is what an essential matrix
// gives; solving for c gives the metric distance. nullopt when the pair does not determine it (a straight
// pair: the direction is then the turn's half whatever the distance) or when the solution is not a forward
// drive.
std::optional<double> lever_arm_chord(double turn, double heading, double lever_m);

struct LeverArmOptions {
  // Pairs turning less than this give the direction of straight travel in the camera model's ego axes: the
  // camera's mounting yaw, which every heading is corrected by (1 deg of it is 10-20 % of the distance in a
  // 10 deg bend).
  double straight_turn_deg = 0.6;
  int min_straight_pairs = 3;
  // Without that many straight pairs the correction is this prior (rad; e.g. the column where the lane
  // lines meet the horizon, HorizonEstimate::travel_x) with this sigma.
  double prior_bias = 0.0;
  double prior_bias_sigma_deg = 1.0;
  double min_turn_deg = 2.0;          // pairs turning less give no distance (it is not determined)
  double max_relative_sigma = 0.25;   // a distance looser than this is not used
  // The road view and the lever arm are averaged by inverse variance when they agree within gate_sigma of
  // the two combined sigmas (the road's floored at road_sigma_floor_mps). When they do not, the lever arm
  // replaces the road view where its own distance is tight (relative sigma at most trust_relative_sigma):
  // the road view's failure mode in a bend is a confident wrong reading (its texture along the lane lines
  // turns with the view), the lever arm's is a loose one. Else the road view stays.
  double gate_sigma = 3.0;
  double road_sigma_floor_mps = 0.2;
  double trust_relative_sigma = 0.1;
};

// The lever-arm distance for a clip's pairs. observe() every sample first (the straight pairs give the
// direction of straight travel), then fuse() each: offline, observe the whole clip and fuse afterwards;
// causally, observe and fuse sample by sample (the bias then rests on the straight pairs seen so far, else the
// prior).
// The prior of that correction from the column where the direction of travel meets the horizon
// (HorizonEstimate::travel_x, from the lane lines' vanishing points): a column right of the principal point is a
// direction of travel to the right of the camera axis (negative). The options unchanged when the column is NaN.
LeverArmOptions with_travel_column(LeverArmOptions opt, const CameraModel& camera, double travel_x);

class LeverArmScale {
 public:
  explicit LeverArmScale(double lever_m, LeverArmOptions opt = {});
  void observe(const EgoMotionSample& s);
  // The mounting yaw taken off every heading (rad) and its sigma; from_straight_pairs() says whether it
  // came from the clip (else the prior).
  double bias() const;
  double bias_sigma() const;
  int straight_pairs() const { return static_cast<int>(straight_.size()); }
  bool from_straight_pairs() const { return straight_pairs() >= opt_.min_straight_pairs; }
  // The sample with the lever arm's speed (lever_speed_mps) when the pair turned enough, and its speed fused
  // or replaced as described in LeverArmOptions (speed_cue and road_speed_mps say what happened).
  EgoMotionSample fuse(EgoMotionSample s) const;
  double lever_m() const { return lever_m_; }
  const LeverArmOptions& options() const { return opt_; }

 private:
  double lever_m_;
  LeverArmOptions opt_;
  std::vector<double> straight_;  // headings of the straight pairs
};

// Offline: observe every sample, then fuse every sample (in place). Returns the scale (for its bias and
// counts).
LeverArmScale apply_lever_arm(std::vector<EgoMotionSample>& raw, double lever_m, LeverArmOptions opt = {});

}  // namespace hf::footage
