// The CLI's commands as functions (exit codes: 0 ok, 1 bad input or failure, 2 usage, 130 interrupted).
#pragma once

#include <atomic>
#include <string>
#include <vector>

#include "hazardforge/core/host.hpp"

namespace hf::apps {

// The CLI uses the host through its public interface (hazardforge/core/*.hpp).
using core::Host;

// SIGINT (Ctrl-C) and SIGTERM (kill, timeout, a service manager, a campaign's death) both set `*flag`: the
// command stops as for Ctrl-C, every stage finishes and the manifest says "interrupted". A second signal of
// the same kind ends the process at once; one of the other kind does not, so a run stopped by SIGTERM still
// finishes when its parent command forwards a Ctrl-C as SIGINT.
void install_stop_signals(std::atomic<bool>* flag);

struct CommonOptions {
  std::string config;
  std::vector<std::string> overrides;
  std::string set_base;  // --set-base: the folder relative paths in --set values refer to (default: current)
  std::string output_dir;
  int64_t max_frames = -1;
  std::string frames;  // --frames FIRST:LAST, the recording's frame window
  bool quiet = false;
  bool resume = false;               // --resume: run the same config again into a folder that holds its run
  bool overwrite = false;            // --overwrite: clear a folder that holds an earlier run first
  bool load_config_plugins = false;  // validate/graph: also load the config's plugin_paths
  std::vector<std::string> argv;
  const std::atomic<bool>* interrupt = nullptr;
};

struct BenchOptions {
  int repeat = 3;
  int64_t max_frames = -1;
  std::string detector_node;
};

struct ExperimentOptions {
  std::string spec;
  std::string output_dir;
  int jobs = 1;
  bool force = false;
  std::vector<std::string> plugin_paths;
  const std::atomic<bool>* interrupt = nullptr;
};

struct CalibrateOptions {
  std::string folder;
  int cols = 9;
  int rows = 6;
  double square = 1.0;
  std::string output;
};

struct HarvestOptions {
  std::string output_dir;
  std::string config;
  std::vector<std::string> overrides;
  std::vector<std::string> argv;
  const std::atomic<bool>* interrupt = nullptr;
};

// A frame window "FIRST:LAST" (either side may be empty: ":40", "12:"). Throws hf::Error naming the text.
struct FrameWindow {
  int64_t first = 0;
  int64_t last = -1;  // -1 = to the end
};
FrameWindow parse_frame_window(const std::string& text);

int cmd_run(Host& host, const CommonOptions& o);
int cmd_validate(Host& host, const CommonOptions& o);
int cmd_plugins(Host& host, bool json);
int cmd_inspect(Host& host, const std::string& name, bool markdown);
int cmd_inspect_all(Host& host, bool markdown);
int cmd_graph(Host& host, const CommonOptions& o);
int cmd_bench(Host& host, const CommonOptions& o, const BenchOptions& b);
int cmd_eval(Host& host, const CommonOptions& o);
int cmd_experiment(Host& host, const ExperimentOptions& o);
int cmd_calibrate(const CalibrateOptions& o);
int cmd_assets_harvest(Host& host, const HarvestOptions& o);

// Text of `inspect` for one registered component (plain or Markdown).
std::string describe_component(const RegisteredComponent& c, bool markdown);

}  // namespace hf::apps
