// An OpenDRIVE reference line fitted to a driven path, with the s/t mapping both ways.
#pragma once

#include <vector>

namespace hf::road {

struct PathPoint {
  double x = 0, y = 0;
};

struct RoadPose {
  double x = 0, y = 0, hdg = 0;
};

// One planView geometry. A paramPoly3 uses pRange "normalized": p in [0, 1],
// u(p) = bu p + cu p^2 + du p^3, v(p) = bv p + cv p^2 + dv p^3 in the frame of (x, y, hdg); a line has no
// coefficients.
struct Geometry {
  double s = 0, x = 0, y = 0, hdg = 0, length = 0;
  bool line = false;
  double bu = 0, cu = 0, du = 0, bv = 0, cv = 0, dv = 0;
};

class ReferenceLine {
 public:
  // Fits G1-continuous pieces (position and heading continuous) to `path` (at least two distinct points, in
  // driving order): the longest pieces whose curve stays within `tolerance` metres of every path point, at
  // most `max_piece` metres long. Straight stretches become lines. Throws std::invalid_argument for a path
  // with fewer than two distinct points.
  static ReferenceLine fit(const std::vector<PathPoint>& path, double tolerance = 0.02,
                           double max_piece = 60.0);

  const std::vector<Geometry>& geometries() const { return pieces_; }
  double length() const;
  // Pose on the line at arc length s (clamped to [0, length]).
  RoadPose at(double s) const;
  // Point at road coordinates (s, t): t to the left of the line.
  PathPoint to_xy(double s, double t) const;
  // Road coordinates (s, t) of the nearest point of the line.
  PathPoint to_st(double x, double y) const;

 private:
  std::vector<Geometry> pieces_;
  // Dense samples of the whole line (every ~0.2 m), for projection and evaluation.
  struct Sample {
    double s, x, y, hdg;
  };
  std::vector<Sample> dense_;
  void densify();
};

// (u, v) of a paramPoly3 piece at normalised parameter p, and its derivative, in the piece's own frame.
PathPoint poly_point(const Geometry& g, double p);
PathPoint poly_tangent(const Geometry& g, double p);

}  // namespace hf::road
