// The footage_harvester sink: appearances cut from a recording's own tracked road users into an asset folder.
#pragma once

#include <filesystem>
#include <memory>

#include "hazardforge/assets/footage_harvest.hpp"
#include "hazardforge/stage.hpp"

namespace hf::render {

// Stage "footage_harvester" (kind sink).
//  inputs:  frames (Frame), states (ObjectStates: ranges and motion), tracks (Tracks, optional: hit counts).
//  outputs: none; in finish() writes <out_dir>/*.png (BGRA) and <out_dir>/assets.yaml, the cuts the footage
//           harvest kept over the whole recording (hazardforge/assets/footage_harvest.hpp): whole, sharp,
//           stable cars and persons, silhouettes by grabCut seeded from their boxes, views from their
//           motion, sizes from the camera. The campaign's scouting pass runs it; the renderer's
//           footage_assets_dir reads the folder.
//  params:  out_dir, min_height_px.
class FootageHarvester : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

 private:
  std::filesystem::path out_dir_;
  std::unique_ptr<FootageHarvest> harvest_;
};

}  // namespace hf::render
