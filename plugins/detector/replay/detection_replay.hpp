// A detector's recorded detections read back for the same frames: a campaign's attempts reuse what its
// scouting pass detected on the original frames instead of running the network again.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include <hazardforge/stage.hpp>

namespace hf {

// Stage "detection_replay" (detector).
// Ports: frames (Frame) -> detections (Detections): for each frame, the record of `record` in `file` whose
//   'frame' is the frame's index, stamped with the frame's timestamp and size.
// Params: file (JSON lines of the jsonl sink), record (the key of the detections in a line,
// "<node>.detections"). A frame the file has no record for, one whose timestamp differs from the recorded
// frame's (not the recording the detections were made on), or a record that does not read as detections stops
// the run with the file, line and frame named.
class DetectionReplay : public Detector {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  Detections detect(StageContext& ctx, const Frame& frame) override;

  // Reads `file` (as open() does); throws hf::Error naming the file and line of a bad record.
  void load(const std::string& file, const std::string& record);

 private:
  std::string file_;
  std::map<int64_t, Detections> by_frame_;
  std::map<int64_t, double> stamp_;  // the recorded frame's timestamp
};

}  // namespace hf
