// The scenario_package sink: a hazard run's augmented and original frames with their labels
// (hazardforge/scenario_package.hpp).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "hazardforge/scenario_package.hpp"
#include "hazardforge/stage.hpp"

namespace hf::sinks {

// Stage "scenario_package" (kind sink).
//  inputs:  original (Frame), augmented (Frame): the same frame before and after augmentation; hazard
//           (HazardInstance): where the inserted object is.
//  outputs: none; writes <folder>/augmented/NNNNNN.<ext> and <folder>/original/NNNNNN.<ext> as frames arrive,
//           and <folder>/frames.jsonl and <folder>/scenario.json in finish().
//  Labels: the inserted object (track 0) while the renderer places it, with its drawn box, truncation,
//  occlusion, 3D box (camera and ego axes) and ground-truth TTC; the recording's objects the dataset
//  annotates (Frame::annotations) that lie in view, their 3D boxes projected (or the dataset's own 2D box).
class ScenarioPackageSink : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

 private:
  std::vector<scenario::LabelledObject> recorded_objects(const Frame& f);

  std::filesystem::path dir_;
  std::string ext_ = "jpg";
  int jpeg_quality_ = 95;
  scenario::PackageHeader header_;
  std::vector<scenario::PackageFrame> frames_;
  std::map<std::string, int64_t> track_ids_;  // dataset instance -> label track id
};

}  // namespace hf::sinks
