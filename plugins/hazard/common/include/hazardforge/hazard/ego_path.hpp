// The ego's planned motion in the anchor frame: its recorded track when the scene carries one, else a
// straight line at constant speed; and the road coordinates (arc length along that path, offset to its left)
// templates design in.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "hazardforge/types.hpp"

namespace hf::hazard {

// One ego pose of a recording's track (hf::EgoTrack, SDK): t, x, y, yaw (+ speed, yaw rate).
using hf::EgoTrackSample;

// Where the ego goes after the anchor time, and the road coordinates along it.
//
// A recorded path is a natural cubic spline of the track positions against time, smoothed with a Gaussian
// along time (pose noise would make its curvature wiggle; smoothed, the curvature and its rate are continuous
// and a hazard that follows the path, even a lane to the side, stays within jerk limits), expressed in the
// anchor frame: the ego frame at the anchor time, taken from the recorded pose there. Beyond
// the recorded span the ego keeps going straight at its last speed (before it: backwards along its first
// heading). Road coordinates (s, d): s = arc length along the path from the ego's position at the anchor
// time, d = offset to the left of the path; on a straight path they equal the anchor frame's (x, y).
class EgoPath {
 public:
  // A straight line along the anchor frame's x axis at constant `speed`.
  static EgoPath straight(double speed);
  // The recorded track (world frame), seen from the ego at `anchor_time`, which must lie within the track's
  // time span (throws hf::Error naming `where` otherwise, and for fewer than two samples). `smoothing_s` is
  // the sigma (s) of the Gaussian that removes pose noise from the path (0 = the interpolating spline as is).
  static EgoPath recorded(const std::vector<EgoTrackSample>& track, double anchor_time,
                          const std::string& where, double smoothing_s = 0.25);

  // The same path with its anchor `tau` s after this one's (negative: before), in the ego frame there. Before
  // the recorded span that is on the straight line back along the first heading.
  EgoPath seen_from(double tau) const;

  bool is_recorded() const { return recorded_; }
  // The ego's state `tau` s after the anchor time (anchor frame): position, heading, speed, acceleration.
  TrajectoryPoint at(double tau) const;
  // Distance travelled along the path since the anchor time (negative for tau < 0).
  double s_at(double tau) const;
  // Earliest tau >= 0 at which the ego has travelled `s`; nullopt when it never gets there (it stops first).
  std::optional<double> time_at(double s) const;

  struct Pose {
    double x = 0, y = 0, heading = 0;
    double curvature = 0;  // 1/m, positive = turning left
  };
  // The path at arc length s (any s; straight beyond the recorded span).
  Pose point(double s) const;
  // Road coordinates -> anchor frame.
  cv::Vec2d to_anchor(double s, double d) const;
  // Anchor frame -> road coordinates (the nearest point of the path within the recorded span, or of its
  // straight continuations).
  cv::Vec2d to_road(double x, double y) const;
  // Maps a motion designed in road coordinates: position, velocity (ds/dt, dd/dt) and an optional heading
  // relative to the path. Returns the anchor-frame position, velocity and heading.
  struct Mapped {
    double x = 0, y = 0, vx = 0, vy = 0;
    std::optional<double> heading;
  };
  Mapped map(double s, double d, double ds, double dd, std::optional<double> rel_heading) const;

 private:
  struct Node {
    double t, s, x, y, heading, speed, accel, curvature;
  };
  bool recorded_ = false;
  double speed_ = 0;         // straight path
  double anchor_t_ = 0;      // stream time of tau = 0
  std::vector<Node> nodes_;  // dense samples of the recorded path, increasing t, non-decreasing s
  Node at_time(double tau) const;
  Node extrapolate(const Node& end, double dt) const;
};

}  // namespace hf::hazard
