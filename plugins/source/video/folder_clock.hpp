// Internal: the clock of an image folder (the video and image_sequence sources).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace hf::source {

// Per-frame times carried by the file names: every stem ends in a run of 13, 16, or 18-19 digits (milliseconds,
// microseconds, nanoseconds since the Unix or GPS epoch, as nuScenes' `..._1538984233512470.jpg`, Argoverse's
// `..._315966070559696000.jpg` and many recorders' exports name their frames), of the same length for all, strictly increasing in name order, with a median
// interval between 1 ms and 10 s. Seconds from the first file, or nullopt (frame counters such as KITTI's
// 0000000000.png have 10 digits and are not times).
struct NamedTimes {
  std::vector<double> seconds;
  std::string unit;  // "ms", "us", "ns"
  double median_interval_s = 0;
};
std::optional<NamedTimes> times_from_names(const std::vector<std::filesystem::path>& files);

// How an image folder's frames are timed: the names' times when they carry them (the stated fps, if any, must
// agree with their median rate within 5 %; else the stated rate wins, with a warning), else index / fps (the
// stated fps, else 10 fps assumed with a warning).
struct FolderClock {
  double fps = 10;            // the stated, the names' median or the assumed rate
  std::vector<double> times;  // s from the first file, one per file; empty: index / fps
  std::string source;         // camera.json's sources.fps
  std::optional<std::string> warning;
  double at(size_t k) const { return times.empty() ? static_cast<double>(k) / fps : times[k]; }
};
// `folder` names the folder in messages, `fps_param` the parameter to set (e.g. "source.fps").
FolderClock folder_clock(const std::vector<std::filesystem::path>& files, double stated_fps,
                         const std::string& folder, const std::string& fps_param);

}  // namespace hf::source
