#include "detection_replay.hpp"

#include <cmath>
#include <fstream>

namespace hf {

ComponentInfo DetectionReplay::describe() {
  ComponentInfo i = Detector::base_info("detection_replay",
                                        "a detector's recorded detections read back for the same frames");
  i.doc =
      "Reads the detections a detector node recorded through the jsonl sink (one JSON line per frame, the "
      "detections under the key '<node>.detections') and emits them again for the frames with the same "
      "index, "
      "instead of detecting: a campaign's attempts reuse its scouting pass's detections on the original "
      "frames "
      "this way. The detections are the recorded ones exactly; a frame without a record is an error.";
  i.params = {
      ParamSpec::path("file", "").describe("JSON lines of the jsonl sink holding the recorded detections"),
      ParamSpec::string("record", "detector.detections")
          .describe("key of the detections in each line: the recording node's id and port"),
  };
  return i;
}

void DetectionReplay::load(const std::string& file, const std::string& record) {
  file_ = file;
  by_frame_.clear();
  stamp_.clear();
  std::ifstream in(file);
  if (!in) throw Error("file '" + file + "': cannot read");
  std::string line;
  for (int64_t n = 1; std::getline(in, line); ++n) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const Json j = Json::parse(line, nullptr, false);
    const std::string at = file + ":" + std::to_string(n) + ": ";
    if (j.is_discarded() || !j.is_object() || !j.contains("frame") || !j["frame"].is_number_integer())
      throw Error(at + "not a line of the jsonl sink (a JSON object with an integer 'frame')");
    if (!j.contains(record)) continue;  // a frame the detector did not see
    try {
      Detections d = j[record].get<Detections>();
      d.frame_index = j["frame"].get<int64_t>();
      if (j.contains("timestamp") && j["timestamp"].is_number())
        stamp_[d.frame_index] = j["timestamp"].get<double>();
      by_frame_[d.frame_index] = std::move(d);
    } catch (const std::exception& e) {
      throw Error(at + "'" + record + "': " + e.what());
    }
  }
  if (by_frame_.empty()) throw Error("file '" + file + "' has no record '" + record + "'");
}

void DetectionReplay::open(StageContext& ctx) {
  const std::filesystem::path file = ctx.params().get_path("file");
  if (file.empty()) throw Error("param 'file' is required: the recorded detections");
  load(file.string(), ctx.params().get_string("record"));
  ctx.record_resource(file);
}

Detections DetectionReplay::detect(StageContext& /*ctx*/, const Frame& frame) {
  const auto it = by_frame_.find(frame.index);
  if (it == by_frame_.end())
    throw Error("frame " + std::to_string(frame.index) + ": no recorded detections in " + file_);
  if (const auto t = stamp_.find(frame.index);
      t != stamp_.end() && std::abs(t->second - frame.timestamp) > 1e-6)
    throw Error("frame " + std::to_string(frame.index) + " at t = " + std::to_string(frame.timestamp) +
                " s was recorded at t = " + std::to_string(t->second) + " s in " + file_ +
                ": not the frames the detections were made on");
  Detections d = it->second;
  d.image_size = frame.image.size();
  return d;
}

}  // namespace hf
