// The realism_test sink: can a classifier tell the inserted object from the recording's real ones?
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/stage.hpp"

namespace hf::render {

// Stage "realism_test" (kind sink).
//  inputs:  original (Frame), augmented (Frame): the same frame before and after augmentation; hazard
//           (HazardInstance): where the inserted object is drawn; tracks (Tracks of the original frames):
//           the recording's real objects, each with its identity.
//  outputs: none; in finish() writes <file> (realism.json: the C2ST's AUC with its 95 % interval, the crop
//           counts, the picture's source, and the control: the same test of real against real objects split
//           by track, which shows how much the test tells identities apart), <crops_file> (realism/crops.jsonl: one line per crop with its
//           features, for pooling runs with hf_c2st) and <sheet> (realism/contact_sheet.png: real and
//           inserted crops side by side).
//  Crops: the inserted object in every frame where at least min_visible_share of it shows and its box is
//  min_height_px tall; the recording's tracked objects matched in the frame, of the same class (score >= min_score, not cut by the
//  border, not overlapped by another box) in every frame, kept when their height lies within the inserted
//  crops' range widened by size_range times on either side.
class RealismTestSink : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

  struct Crop {
    bool inserted = false;
    int64_t frame = 0;
    int64_t track_id = -1;
    std::string label;
    cv::Rect2f box;
    std::vector<float> features;
    cv::Mat picture;  // the box with a margin, for the contact sheet
  };
  const std::vector<Crop>& crops() const { return crops_; }

 private:
  std::filesystem::path file_, crops_file_, sheet_;
  double min_visible_ = 0.7, min_height_ = 24, min_score_ = 0.5, size_range_ = 3.0;
  int max_real_ = 300;
  unsigned seed_ = 1;
  std::vector<Crop> crops_;
  std::string object_class_, picture_source_, picture_file_;
};

}  // namespace hf::render
