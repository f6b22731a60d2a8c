// Test harness for one stage (like MediaPipe's CalculatorRunner): build it from a YAML snippet, push
// timestamped packets, run, inspect what it emitted. Usable by third-party plugin tests.
//
//   auto r = hf::testing::StageRunner::create<MyDetector>("conf: 0.4");
//   r.push("frames", frame, 0.0);
//   r.run();
//   auto dets = r.collect<hf::Detections>("detections");
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "hazardforge/plugin.hpp"
#include "hazardforge/stage.hpp"

HF_SDK_BEGIN
namespace hf::testing {

class StageRunner {
 public:
  template <class T>
  static StageRunner create(const std::string& yaml_params = "") {
    StageRunner r;
    r.registrar().add<T>();
    r.build(T::describe().kind, T::describe().name, yaml_params);
    return r;
  }

  StageRunner();
  ~StageRunner();
  StageRunner(StageRunner&&) noexcept;
  StageRunner& operator=(StageRunner&&) noexcept;

  // Components the stage may create through ctx.components() (LLM providers, hazard templates).
  Registrar& registrar();
  // Builds a registered stage; params are validated exactly as the host does (throws hf::DiagnosticError).
  void build(const std::string& kind, const std::string& name, const std::string& yaml_params);

  // Queue a packet on an input port for the frame with this timestamp. For multi ports, `producer` names
  // the upstream node.
  void push(const std::string& port, Packet packet, const std::string& producer = "upstream");
  template <PayloadType T>
  void push(const std::string& port, T value, double timestamp, const std::string& producer = "upstream") {
    push(port, Packet::make<T>(std::move(value), timestamp), producer);
  }

  // Opens the stage (once), processes every queued frame in timestamp order. With `finish` the stage's
  // finish() runs afterwards. For a source, calls next() until it returns false or `max_frames` is reached.
  void run(bool finish = true, int64_t max_frames = -1);

  const std::vector<Packet>& outputs(const std::string& port) const;
  template <PayloadType T>
  std::vector<T> collect(const std::string& port) const {
    std::vector<T> v;
    for (const Packet& p : outputs(port)) v.push_back(p.get<T>());
    return v;
  }

  Stage& stage();
  const ComponentInfo& info() const;
  const std::filesystem::path& output_dir() const;
  // What Ctrl-C does in a run: from now on ctx.stop_requested() is true. Safe to call from another thread.
  void request_stop();
  // Log lines the stage wrote, "level: message".
  const std::vector<std::string>& log() const;
  // Inner timings the stage reported with ctx.record_timing(), by label.
  const std::map<std::string, std::vector<double>>& timings() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hf::testing
HF_SDK_END
