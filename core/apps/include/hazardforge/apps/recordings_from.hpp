// A campaign's `recordings_from:` entries: whole datasets and file patterns turned into recordings, each with
// the facts its source carries (docs/campaigns.md "Recordings found, not listed").
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace hf::apps {

// One recording found by an entry: its name (not yet made unique) and the overrides that point the entry's
// config at it and state its facts.
struct FoundRecording {
  std::string name;
  std::vector<std::string> set;
};

// Something an entry found but cannot use, and why (reported; the campaign goes on without it).
struct SkippedRecording {
  std::string what;  // a path or a recording's name
  std::string reason;
};

struct FoundRecordings {
  std::vector<FoundRecording> found;
  std::vector<SkippedRecording> skipped;
};

// nuScenes: every scene of a dataroot's table folder (`version`, or the only v1.0-* folder there) whose name
// matches one of `patterns` (shell patterns; none = every scene), as `source.dataroot`, `source.version`,
// `source.scenes`; the side traffic keeps from the log's location (log.json), or from the UTC offset in the
// camera files' log names where log.json is absent (+0800 Singapore keeps left, -0400/-0500 Boston right).
// Throws hf::Error when the dataroot has no readable scene table.
FoundRecordings nuscenes_recordings(const std::filesystem::path& dataroot, const std::string& version,
                                    const std::vector<std::string>& patterns);

// KITTI raw: every `image_02/data` folder of PNG frames below `root` (a drive, a date folder or the whole
// download), as `source.path` with `source.fps=10`; the camera from the drive's calib_cam_to_cam.txt
// (P_rect_02) or a KITTI-tracking calibration file (P2) beside it or above it up to `root`, mounted 1.65 m
// above the road; traffic keeps right (Karlsruhe). Throws hf::Error when `root` is not a readable folder.
FoundRecordings kitti_raw_recordings(const std::filesystem::path& root);

// Video files and image folders matching shell patterns (glob(3), with {a,b} and ~), as `source.path`.
// A match that is empty, unreadable or neither a video file nor a folder of pictures is skipped.
FoundRecordings file_recordings(const std::vector<std::string>& patterns);

// A path-safe recording name from any text: characters other than letters, digits, '-', '_' and '.' become
// '_'; made unique against `taken` by appending -2, -3, ... (and added to it).
std::string unique_recording_name(const std::string& text, std::vector<std::string>& taken);

}  // namespace hf::apps
