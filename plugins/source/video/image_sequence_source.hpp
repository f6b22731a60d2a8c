// Frame source over a folder of images (sorted by name), e.g. KITTI raw image_02/data.
#pragma once

#include <filesystem>
#include <optional>
#include <vector>

#include "camera_setup.hpp"
#include "folder_clock.hpp"
#include "hazardforge/stage.hpp"

namespace hf::source {

// Reads every file of `path` matching the glob `pattern`, sorted by file name.
// Ports: out `frames` (Frame, BGR 8-bit). Timestamps: the file names' (folder_clock.hpp), else emitted
// index / fps (default 10 Hz); all images must
// share one size. Params: path, pattern, fps, start_frame, max_frames + the camera params of CameraSetup.
class ImageSequenceSource : public SourceStage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  bool next(StageContext& ctx, Outputs& out) override;
  std::optional<int64_t> frame_count() const override { return static_cast<int64_t>(files_.size()); }

 private:
  std::vector<std::filesystem::path> files_;
  CameraSetup setup_;
  FolderClock clock_;  // frame times: the file names' or index / fps
  size_t pos_ = 0;
  cv::Mat read(size_t k) const;
};

// Files of `folder` whose names match the glob `pattern` (fnmatch), sorted by name.
std::vector<std::filesystem::path> list_matching(const std::filesystem::path& folder,
                                                 const std::string& pattern);

}  // namespace hf::source
