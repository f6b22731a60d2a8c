// The external_program stage: a system under test that is a program of its own (docs/testing-a-system.md).
#pragma once

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "hazardforge/stage.hpp"
#include "program_pipe.hpp"

namespace hf::system {

// Stage "external_program" (kind system).
//  inputs:  frames (Frame).
//  outputs: detections (Detections), response (SystemResponse): the program's answer for each frame.
//  Starts `command` in the config's folder at open(), says hello, then per frame writes one JSON line (the
//  picture's path, or its raw BGR bytes after the line) and reads one JSON line back, each within its time
//  limit. A program that does not answer in time, exits, answers for another frame or with something that is
//  not the protocol's JSON stops the run with an error naming the frame; its standard error goes to
//  <stderr_log> in the run folder.
class ExternalProgramStage : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

 private:
  std::string command_text() const;

  std::vector<std::string> command_;
  bool raw_ = false;
  double startup_s_ = 30, frame_s_ = 10, exit_s_ = 5;
  size_t max_reply_ = 1 << 20;
  std::filesystem::path stderr_log_, frames_dir_;
  std::unique_ptr<ProgramPipe> program_;
  bool first_ = true;
};

}  // namespace hf::system
