// ExternalProgramStage: the line protocol of docs/testing-a-system.md, one frame out, one answer back.
#include "external_program_stage.hpp"

#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>

#include "hazardforge/error.hpp"
#include "hazardforge/json_text.hpp"
#include "hazardforge/output_path.hpp"

namespace hf::system {

namespace fs = std::filesystem;
using Clock = ProgramPipe::Clock;

namespace {

Clock::time_point after(double seconds) {
  return Clock::now() + std::chrono::microseconds(static_cast<long long>(seconds * 1e6));
}

std::string shorten(const std::string& s, size_t n = 120) {
  return s.size() <= n ? s : s.substr(0, n) + "...";
}

// The answer's fields, each checked; throws hf::Error "<what>: ...".
SystemResponse parse_answer(const std::string& line, const Frame& f, const std::string& what) {
  Json j;
  try {
    j = Json::parse(line);
  } catch (const nlohmann::json::exception&) {
    throw Error(what + " answered '" + shorten(line) + "', which is not a JSON line of the protocol");
  }
  if (!j.is_object()) throw Error(what + " answered '" + shorten(line) + "', which is not a JSON object");
  if (!j.contains("frame") || !j["frame"].is_number_integer())
    throw Error(what + " answered without a whole-number 'frame'");
  if (j["frame"].get<int64_t>() != f.index)
    throw Error(what + " answered for frame " + std::to_string(j["frame"].get<int64_t>()) + " instead");
  SystemResponse r;
  r.frame_index = f.index;
  if (j.contains("detections") && !j["detections"].is_null()) {
    if (!j["detections"].is_array()) throw Error(what + ": 'detections' is not a list");
    for (size_t i = 0; i < j["detections"].size(); ++i) {
      const Json& d = j["detections"][i];
      const std::string at = what + ": detections[" + std::to_string(i) + "]";
      if (!d.is_object() || !d.contains("box") || !d["box"].is_array() || d["box"].size() != 4)
        throw Error(at + " has no 'box' [x, y, w, h]");
      float b[4];
      for (int k = 0; k < 4; ++k) {
        if (!d["box"][k].is_number()) throw Error(at + ": 'box' holds something that is not a number");
        b[k] = d["box"][k].get<float>();
        if (!std::isfinite(b[k])) throw Error(at + ": 'box' holds a number that is not finite");
      }
      if (b[2] <= 0 || b[3] <= 0) throw Error(at + ": 'box' has no width or height");
      Detection det;
      det.box = cv::Rect2f(b[0], b[1], b[2], b[3]);
      det.label = d.value("label", "");
      if (d.contains("score")) {
        if (!d["score"].is_number()) throw Error(at + ": 'score' is not a number");
        det.score = d["score"].get<float>();
      } else {
        det.score = 1.f;
      }
      r.detections.push_back(std::move(det));
    }
  }
  if (j.contains("ttc_s") && !j["ttc_s"].is_null()) {
    if (!j["ttc_s"].is_number() || !(j["ttc_s"].get<double>() >= 0))
      throw Error(what + ": 'ttc_s' is not a number >= 0 or null");
    r.ttc_s = j["ttc_s"].get<double>();
  }
  for (const char* key : {"warning", "brake"})
    if (j.contains(key) && !j[key].is_boolean()) throw Error(what + ": '" + key + "' is not true or false");
  r.warning = j.value("warning", false);
  r.brake = j.value("brake", false);
  return r;
}

}  // namespace

ComponentInfo ExternalProgramStage::describe() {
  ComponentInfo i;
  i.name = "external_program";
  i.kind = kind::kSystem;
  i.summary = "a system under test that is a program of its own, in any language (a line protocol)";
  i.doc =
      "Starts `command` (argv; its working folder is the config's), writes one JSON line per frame on its "
      "standard input (the picture's path, or `frames: raw`: the BGR bytes after the line, with the camera, "
      "timestamp and ego speed) and reads one JSON line per frame from its standard output: its detections, "
      "its TTC, and its warning and brake request. Time limits per answer, a program that crashes, hangs, "
      "prints something else or answers for another frame: an error naming the frame. Protocol and "
      "reference clients: docs/testing-a-system.md.";
  i.inputs = {port<Frame>("frames", "the frames the system sees")};
  i.outputs = {port<Detections>("detections", "the program's detections"),
               port<SystemResponse>("response", "the program's answer: detections, TTC, warning, brake")};
  i.params = {
      ParamSpec::string_list("command", {})
          .describe("the program and its arguments (argv; ${NAME} is taken "
                    "from the environment); the program is looked up on "
                    "PATH when it has no '/'"),
      ParamSpec::string("frames", "path")
          .one_of({"path", "raw"})
          .describe("how a frame is given: the picture file's path, or its raw BGR bytes after the line"),
      ParamSpec::number("startup_timeout_s", 30.0).range(0.1, 3600).describe("time for the first answer"),
      ParamSpec::number("frame_timeout_s", 10.0).range(0.01, 3600).describe("time for every later answer"),
      ParamSpec::number("exit_timeout_s", 5.0).range(0.0, 600).describe("time to exit after the last frame"),
      ParamSpec::integer("max_answer_bytes", 1 << 20).range(64, 1 << 28).describe("longest answer line"),
      ParamSpec::path("working_dir", "").describe("the program's working folder (empty: the config's)"),
      ParamSpec::string("stderr_log", "system/stderr.log")
          .describe("the program's standard error, below "
                    "the run folder"),
  };
  return i;
}

std::string ExternalProgramStage::command_text() const {
  std::string s;
  for (const auto& a : command_) s += (s.empty() ? "" : " ") + a;
  return "the program '" + shorten(s, 80) + "'";
}

void ExternalProgramStage::open(StageContext& ctx) {
  const Params& p = ctx.params();
  command_ = p.get_strings("command");
  for (auto& a : command_) a = expand_vars(a);  // ${HAZARDFORGE_SHARED} and the environment's variables
  if (command_.empty() || command_[0].empty())
    throw Error("node '" + ctx.node_id() + "': param 'command' must name the program to start");
  raw_ = p.get_string("frames") == "raw";
  startup_s_ = p.get_double("startup_timeout_s");
  frame_s_ = p.get_double("frame_timeout_s");
  exit_s_ = p.get_double("exit_timeout_s");
  max_reply_ = static_cast<size_t>(p.get_int("max_answer_bytes"));
  stderr_log_ = output_param_path(ctx, "stderr_log");
  frames_dir_ = stderr_log_.parent_path() / "frames";
  fs::path cwd = p.get_path("working_dir");
  if (cwd.empty()) cwd = p.base_dir().empty() ? fs::current_path() : p.base_dir();
  program_ = std::make_unique<ProgramPipe>(command_, cwd, stderr_log_);
  ctx.log(LogLevel::kInfo, "started " + command_text() + " (pid " + std::to_string(program_->pid()) +
                               "), its standard error in " + stderr_log_.string());
  const std::string hello =
      json_text(Json{{"type", "hello"}, {"protocol", 1}, {"frames", raw_ ? "raw" : "path"}}) + "\n";
  if (program_->write_all(hello, after(startup_s_)) != ProgramPipe::Status::kOk)
    throw Error(command_text() + " did not take the hello line within " + std::to_string(startup_s_) +
                " s (" + program_->exit_text() + "); its standard error: " + stderr_log_.string());
}

void ExternalProgramStage::process(StageContext& /*ctx*/, const Inputs& in, Outputs& out) {
  const Frame& f = in.require<Frame>("frames");
  const std::string what = frame_name(f) + ": " + command_text();
  const double limit = first_ ? startup_s_ : frame_s_;
  const auto deadline = after(limit);
  Json line = {{"type", "frame"},
               {"frame", f.index},
               {"timestamp", f.timestamp},
               {"width", f.image.cols},
               {"height", f.image.rows},
               {"camera",
                {{"fx", f.camera.fx},
                 {"fy", f.camera.fy},
                 {"cx", f.camera.cx},
                 {"cy", f.camera.cy},
                 {"height_m", f.camera.height_above_ground()},
                 {"pitch_rad", f.camera.pitch()}}},
               {"ego_speed_mps", f.ego.speed_mps ? finite_or_null(*f.ego.speed_mps) : Json()}};
  std::string bytes;
  if (raw_) {
    cv::Mat img = f.image.isContinuous() ? f.image : f.image.clone();
    line["encoding"] = "bgr8";
    line["bytes"] = img.total() * img.elemSize();
    bytes = json_text(line) + "\n";
    bytes.append(reinterpret_cast<const char*>(img.data), img.total() * img.elemSize());
  } else {
    fs::path file(f.source_id);
    std::error_code ec;
    if (!file.is_absolute() || !fs::is_regular_file(file, ec)) {
      // The frame has no picture file of its own: one is written for the program.
      fs::create_directories(frames_dir_);
      char name[32];
      std::snprintf(name, sizeof name, "%06lld.png", static_cast<long long>(f.index));
      file = frames_dir_ / name;
      if (!cv::imwrite(file.string(), f.image)) throw Error(what + ": cannot write '" + file.string() + "'");
    }
    line["image"] = file.string();
    bytes = json_text(line) + "\n";
  }
  const auto wrote = program_->write_all(bytes, deadline);
  if (wrote == ProgramPipe::Status::kClosed)
    throw Error(what + " exited before taking the frame (" + program_->exit_text() +
                "); its standard error: " + stderr_log_.string());
  if (wrote == ProgramPipe::Status::kTimeout)
    throw Error(what + " did not read the frame within " + std::to_string(limit) + " s");
  std::string answer;
  bool too_long = false;
  const auto got = program_->read_line(answer, deadline, max_reply_, too_long);
  if (got == ProgramPipe::Status::kClosed)
    throw Error(what + " exited without answering (" + program_->exit_text() +
                "); its standard error: " + stderr_log_.string());
  if (got == ProgramPipe::Status::kTimeout)
    throw Error(what + " did not answer within " + std::to_string(limit) + " s");
  if (too_long) throw Error(what + " answered a line longer than " + std::to_string(max_reply_) + " bytes");
  first_ = false;
  SystemResponse r = parse_answer(answer, f, what);
  Detections d;
  d.frame_index = f.index;
  d.image_size = f.image.size();
  d.detector = "external_program";
  d.items = r.detections;
  out.emit("detections", std::move(d));
  out.emit("response", std::move(r));
}

void ExternalProgramStage::finish(StageContext& ctx, Outputs& /*out*/) {
  if (!program_) return;
  const int code = program_->finish(after(exit_s_));
  if (code != 0)
    ctx.log(LogLevel::kWarning, command_text() + " ended with " + program_->exit_text() +
                                    " after the last frame; its standard error: " + stderr_log_.string());
  program_.reset();
}

}  // namespace hf::system
