// Appearances cut from the recording itself: tracked road users that are whole, sharp, large and stable are cut
// out by grabCut seeded from their box alone (no annotations needed), matted, given a view from their motion
// and a metric size from the camera model, and kept as appearance assets (the assets.yaml format).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/assets/asset_library.hpp"
#include "hazardforge/geometry.hpp"
#include "hazardforge/types.hpp"

namespace hf::render {

// One tracked road user as the harvest sees it in one frame.
struct FootageObject {
  int64_t track_id = -1;
  std::string label;
  cv::Rect2f box;
  float score = 0.f;
  int hits = 0;    // frames its track has been matched so far
  int misses = 0;  // frames since it was last matched (its box is predicted when > 0)
  unsigned truncated = 0;
  double distance_m = kInf;  // ego x of its near face, from the ego origin (kInf = no range)
  double lateral_m = 0.0;
  std::optional<double> heading_rad;  // motion direction relative to the ego's heading
  std::optional<double> speed_mps;    // absolute speed
};

// The objects of one frame: each state (with its range and motion) joined with its track's hit count.
std::vector<FootageObject> footage_objects(const ObjectStates* states, const Tracks* tracks);

struct FootageHarvestOptions {
  std::vector<std::string> classes{"car", "person"};  // detector labels harvested
  double min_height_px = 40.0;                        // smallest box (persons and vehicles)
  double min_score = 0.5;
  int min_track_hits = 3;           // a track seen this often before it is cut
  double border_margin_px = 4.0;    // the box stays this far from the picture's border
  double max_overlap = 0.05;        // largest share of the box covered by a nearer object's box
  double max_distance_m = 45.0;
  double min_vehicle_speed_mps = 1.5;  // slower vehicles outside the ego's lane: heading unknown
  double min_person_speed_mps = 0.5;   // slower persons: heading unknown
  double min_sharpness = 0.5;  // Laplacian variance inside the box over the picture's (motion blur, defocus)
  int grabcut_iterations = 4;
  double min_vehicle_fill = 0.55, min_person_fill = 0.3;  // silhouette area / box area
  double min_box_iou = 0.75;      // silhouette's bounding box against the detection's box
  double min_consistency = 0.65;  // IoU of two cuts of one track (normalised to the box): the same object
  bool matting = true;
  double matting_band = 2.0;  // % of the box height, at least 1 px
  int every_frames = 2;       // a track is cut at most every n frames
  int max_cuts_per_frame = 3;
};

// A kept appearance, with what it was cut from and why it was kept.
struct FootageCut {
  AssetSpec spec;  // source "footage", instance "track N", origin "<source_id> frame K"
  cv::Mat bgra;
  double quality = 0;  // larger = better: height x fill x sharpness x consistency
  int64_t track_id = -1;
  int64_t frame_index = -1;
  std::string why;
  std::filesystem::path folder;  // the asset folder its picture was read from; empty = made in this run
};

// Hard silhouette of an object inside its box by grabCut seeded from the box alone: outside the box is
// background, a core in its middle (vehicles: an ellipse, persons: a vertical strip) foreground, the rest of the
// box probable foreground. The mask covers `crop` (the box with a context margin); 255 = object.
struct BoxCut {
  cv::Rect crop;
  cv::Mat mask;
  double fill = 0;     // mask area / box area
  double box_iou = 0;  // mask's bounding rectangle against the box
};
std::optional<BoxCut> cut_from_box(const cv::Mat& bgr, const cv::Rect2f& box, bool person, int iterations);

// The direction of travel an object's appearance is taken with, relative to the ego's heading (rad), and why;
// nullopt with the reason when it cannot be told (a parked car beside the road may face either way).
struct ViewHeading {
  std::optional<double> yaw;
  std::string why;
};
ViewHeading view_heading(const FootageObject& o, bool person, const FootageHarvestOptions& opt);

class FootageHarvest {
 public:
  FootageHarvest(FootageHarvestOptions o, ClassPriors sizes);
  // Looks at one frame's objects (in order of frames); cuts the best candidates.
  void offer(const Frame& f, const std::vector<FootageObject>& objects);
  // The best cut per track and view, best first.
  std::vector<FootageCut> cuts() const;
  std::vector<FootageCut> cuts_of(const std::string& object_class) const;
  // Objects considered, and why the others were not kept (reason -> count).
  int candidates() const { return candidates_; }
  const std::map<std::string, int>& rejections() const { return rejected_; }
  std::string summary() const;
  // Writes the kept cuts as PNGs and <dir>/assets.yaml (the asset format); returns how many.
  int save(const std::filesystem::path& dir) const;
  double seconds() const { return seconds_; }

 private:
  struct Pending {  // a cut before its picture is made (matting is the cost: only kept cuts pay it)
    FootageCut cut;
    cv::Mat crop_img, mask;
    cv::Rect pic_in_crop;
    int band = 1;
  };
  struct TrackCuts {
    std::vector<FootageCut> kept;  // best per view, confirmed, with their pictures
    std::optional<Pending> pending;  // last cut, not yet confirmed by another
    cv::Mat last_mask;                  // its silhouette normalised to 64x64
    std::optional<double> last_yaw;     // the direction of travel it was cut with
    int64_t last_frame = -1000000;
    int confirmations = 0;
  };
  void reject(const std::string& why) { ++rejected_[why]; }
  FootageHarvestOptions opt_;
  ClassPriors sizes_;
  std::map<int64_t, TrackCuts> tracks_;
  std::map<std::string, int> rejected_;
  int candidates_ = 0;
  double seconds_ = 0;
};

}  // namespace hf::render
