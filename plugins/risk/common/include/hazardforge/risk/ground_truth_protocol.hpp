// The ground-truth TTC protocol over annotated boxes (docs/evaluation.md): the reference TTC and Safe/Unsafe
// label of a frame from a dataset's annotations and ego motion, shared by the ground_truth and label_ttc
// metrics.
#pragma once

#include <string>
#include <vector>

#include "hazardforge/corridor.hpp"
#include "hazardforge/params.hpp"
#include "hazardforge/types.hpp"

namespace hf {

// The ground-truth protocol's constants (docs/evaluation.md), one param each.
struct GroundTruthProtocol {
  std::vector<std::string> category_prefixes{"vehicle.", "human."};
  // The protocol's corridor is straight ahead (the paper's labels); corridor_path: ego_path bends it along
  // the ego's recorded yaw rate.
  Corridor corridor{1.0, 0.5, false};
  double front_overhang = 3.4;  // ego x of the front bumper (rear axle to bumper), m
  double min_closing_mps = 0.1;
  double threshold = 1.5;
  bool static_when_unknown = false;  // objects without a velocity: false = ignored, true = treated as parked

  // Fills objects, scene value, critical object and label; `ego` gives the speed and yaw rate the corridor
  // follows. Throws hf::Error naming `what` when the ego velocity is missing.
  RiskAssessment assess(const Annotations& ann, const EgoState& ego, const std::string& what) const;

  // The protocol's params, shared by every metric built on it; the dataset-specific ones (the bumper offset,
  // the category names and what an object without a velocity means there) come with their own default and
  // doc.
  struct DatasetParams {
    double front_overhang;
    std::string front_overhang_doc;
    std::vector<std::string> categories;
    std::string categories_doc;
    std::string missing_velocity_doc;
  };
  static std::vector<ParamSpec> params(const DatasetParams& d);
  static GroundTruthProtocol from(const Params& p);
};

}  // namespace hf
