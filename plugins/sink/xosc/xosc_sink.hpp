// xosc sink: writes each planned hazard as an ASAM OpenSCENARIO 1.2 scenario file.
#pragma once

#include <string>

#include "hazardforge/hazard/kinematics.hpp"
#include "hazardforge/stage.hpp"

namespace hf {

// Stage xosc (kind sink).
// Inputs: `trajectory` (HazardTrajectory, sticky), `frames` (Frame, optional: the anchor frame's ego pose
// places the scenario in the dataset's world frame). Outputs: none. Writes <output>/<file> (atomic) when a
// trajectory arrives (<stem>_<n>.xosc for the n-th of a run), so an interrupted run keeps it. Params: file,
// author, description, coordinates (auto | anchor | world), ego_name, hazard_name, ego_front_m, limits,
// class_sizes.
class XoscSink : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;

 private:
  std::string file_, coordinates_;
  std::string author_, description_, ego_name_, hazard_name_;
  hazard::LimitsTable limits_;
  cv::Vec3d ego_size_{4.5, 1.85, 1.52};
  double ego_front_ = 3.4;
  const void* last_ = nullptr;
  int written_ = 0;
};

}  // namespace hf
