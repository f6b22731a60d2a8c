// The scene's light, read from the shadows the recording's own vehicles cast on the road: whether the sun
// casts a shadow (and where it points, how far it reaches, how dark it is) or the light is diffuse (overcast,
// shade), and how dark the road is right beside a vehicle. The renderer shapes and darkens the hazard's
// shadow by it.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/types.hpp"

namespace hf::render {

// One real vehicle seen in a frame: its (untruncated) box and its class's size.
struct VehicleView {
  cv::Rect2f box;
  double length_m = 4.5, width_m = 1.85, height_m = 1.5;
};

struct SceneLight {
  bool directional = false;      // a consistent cast shadow was seen beside the vehicles (sun)
  double azimuth = 0;            // where the shadows point on the road, rad, in the frame `heading` refers to
  double length_per_height = 0;  // the shadow's reach beyond the footprint per metre of object height
  double darkness = 0;  // 1 - shadowed / lit road: of the cast shadow, or (diffuse) beside the vehicle
  int samples = 0;      // vehicle views measured
  int directional_samples = 0;  // ... of which showed one darker side
  double consistency = 0;       // resultant length of those sides' directions, 0..1
  bool measured() const { return samples > 0; }
};

struct SceneLightOptions {
  double min_box_px = 30;      // smaller vehicles show too little road around them
  int directions = 16;         // around the footprint
  double min_contrast = 0.12;  // a side counts as the shadow's when darker than the median side by this ...
  double min_darkness = 0.15;  // ... and darker than the lit road by this
  int min_samples = 3;         // vehicle views with a shadow side before the light is called directional ...
  double min_share = 0.5;      // ... and at least this share of all views
  double min_consistency = 0.7;  // ... pointing the same way
  // The body overhangs the wheels by this fraction of its length at each end (a 4.5 m car's 0.85 m, a bus's
  // 2.5 m of 12): the box's bottom is where the near wheels touch the road, and the road under the overhang
  // is in the body's own shade in any light, so the footprint's near edge lies this much nearer than the
  // box's bottom.
  double overhang_fraction = 0.19;
};

// Accumulates vehicle views frame by frame (shadows are fixed in the world: pass the ego's heading in a fixed
// frame, e.g. from poses or the integrated yaw rate; directions are then reported in that frame).
class SceneLightEstimator {
 public:
  explicit SceneLightEstimator(SceneLightOptions o = {}) : opt_(o) {}
  void add(const cv::Mat& bgr, const CameraModel& camera, const std::vector<VehicleView>& vehicles,
           double heading = 0.0);
  SceneLight estimate() const;
  void reset() { samples_.clear(); }

  // One vehicle view's measurement (exposed for tests).
  struct Sample {
    bool directional = false;
    double azimuth = 0;  // of the darkest side, in the heading frame
    double contrast = 0, darkness = 0, beside = 0, length_per_height = 0;
  };
  const std::vector<Sample>& samples() const { return samples_; }

 private:
  SceneLightOptions opt_;
  std::vector<Sample> samples_;
};

}  // namespace hf::render
