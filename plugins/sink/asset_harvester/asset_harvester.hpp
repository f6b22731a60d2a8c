// The asset_harvester sink: cuts real object appearances out of annotated frames into an asset folder.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/assets/asset_library.hpp"
#include "hazardforge/stage.hpp"

namespace hf::render {

// Stage "asset_harvester" (kind sink).
//  inputs:  frames (Frame with annotations: 3D boxes in the ego frame, e.g. from the nuscenes source).
//  outputs: none; writes <out_dir>/*.png (BGRA) and <out_dir>/assets.yaml (the format of share/assets) in
//  finish(). Each annotated object of a wanted class is projected with the frame's camera (8 corners -> 2D
//  box); objects that are clipped by the border, too small, too far, with too few lidar/radar points, flagged
//  occluded, or overlapped by a nearer annotated object are skipped; the rest are cut out with cv::grabCut
//  initialised from the projected box (a cut whose bounding box has IoU < min_box_iou with the projected
//  faces' box is rejected), the edge's alpha refined by information-flow matting (cv::alphamat) and its
//  colour decontaminated (hazardforge/realism/matting.hpp); their view is classified from the object's yaw
//  relative to the camera, and the best cut per instance and view is kept. Timestamps: none emitted. params:
//  out_dir, classes, min_points, min_height_px, min_width_px, border_margin_px, max_distance_m,
//           max_occlusion, max_overlap, grabcut_iterations, min_fill, min_box_iou, matting, matting_band,
//           decontaminate, per_instance_view, append.
class AssetHarvester : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

  // Candidates found so far (tests inspect them before finish()).
  struct Cut {
    AssetSpec spec;
    cv::Mat bgra;
    double quality = 0;  // larger = better (visible height x mask fill)
  };
  const std::map<std::string, std::vector<Cut>>& cuts() const { return cuts_; }
  const std::map<std::string, int>& rejections() const { return rejected_; }

 private:
  std::filesystem::path out_dir_;
  std::vector<std::string> classes_;
  int min_points_ = 0, min_h_ = 0, min_w_ = 0, border_ = 0, iterations_ = 0, per_view_ = 1;
  double max_distance_ = 0, max_occlusion_ = 0, max_overlap_ = 0, min_fill_ = 0, min_box_iou_ = 0.7;
  bool matting_ = true, decontaminate_ = true;
  double matting_band_ = 2.0;
  int matted_ = 0;
  bool append_ = true;
  std::map<std::string, std::vector<Cut>> cuts_;  // key: instance + view
  std::map<std::string, int> rejected_;           // reason -> count
  int frames_ = 0, frames_with_annotations_ = 0, objects_ = 0;
};

}  // namespace hf::render
