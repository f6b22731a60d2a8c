// run / validate / plugins / inspect / graph / eval: thin layers over the host facade.
#include "hazardforge/apps/commands.hpp"
#include "hazardforge/json_text.hpp"
#include "hazardforge/number_text.hpp"
#include "hazardforge/redact.hpp"

#include <algorithm>
#include <csignal>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

namespace hf::apps {

using namespace hf::core;  // the host's public interface

namespace {

std::atomic<bool>* g_stop_flag = nullptr;

extern "C" void on_stop_signal(int sig) {
  if (g_stop_flag) g_stop_flag->store(true);
  std::signal(sig, SIG_DFL);  // the same signal again ends the process at once
}

}  // namespace

void install_stop_signals(std::atomic<bool>* flag) {
  g_stop_flag = flag;
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  for (int sig : {SIGINT, SIGTERM}) sigaction(sig, &sa, nullptr);
}

namespace {

void print_load_errors(const std::vector<std::string>& errors) {
  for (const auto& e : errors) std::cerr << "error: " << e << "\n";
}

std::string param_line(const ParamSpec& p) {
  std::ostringstream os;
  os << p.name << " (" << param_type_name(p.type);
  if (p.required())
    os << ", required";
  else
    os << ", default " << hf::json_text(p.default_value);
  if (p.min || p.max) {
    os << ", range ";
    os << (p.min ? general_text(*p.min) : std::string("-inf")) << ".."
       << (p.max ? general_text(*p.max) : std::string("inf"));
  }
  if (!p.choices.empty()) {
    os << ", one of";
    for (const auto& c : p.choices) os << " " << c;
  }
  os << ")";
  return os.str();
}

std::string port_flags(const PortSpec& p) {
  std::string f;
  if (p.sticky)
    f += " sticky";
  else if (p.optional)
    f += " optional";
  if (p.multi) f += " multi";
  return f;
}

FolderUse folder_use(const CommonOptions& o) {
  return o.overwrite ? FolderUse::kOverwrite : o.resume ? FolderUse::kResume : FolderUse::kNew;
}

RunRequest run_request(const CommonOptions& o) {
  RunRequest req;
  req.config = o.config;
  req.overrides = o.overrides;
  req.overrides_dir = o.set_base;
  req.output_dir = o.output_dir;
  req.max_frames = o.max_frames;
  req.quiet = o.quiet;
  req.argv = o.argv;
  req.interrupt = o.interrupt;
  req.folder_use = folder_use(o);
  if (!o.frames.empty()) {
    const FrameWindow w = parse_frame_window(o.frames);
    req.first_frame = w.first;
    req.last_frame = w.last;
  }
  return req;
}

}  // namespace

std::string describe_component(const RegisteredComponent& c, bool md) {
  const ComponentInfo& i = c.info;
  std::ostringstream os;
  if (md) {
    os << "### `" << i.name << "` (" << i.kind << ")\n\n" << i.summary << "\n\n";
    if (!i.doc.empty()) os << i.doc << "\n\n";
    os << "Plugin `" << c.plugin_name << "` " << c.plugin_version << "\n\n";
    if (!i.inputs.empty() || !i.outputs.empty()) {
      os << "| port | direction | type | flags | description |\n|---|---|---|---|---|\n";
      for (const auto& p : i.inputs)
        os << "| `" << p.name << "` | in | " << p.type_str() << " |" << port_flags(p) << " | " << p.doc
           << " |\n";
      for (const auto& p : i.outputs)
        os << "| `" << p.name << "` | out | " << p.type_str() << " | | " << p.doc << " |\n";
      os << "\n";
    }
    if (!i.params.empty()) {
      os << "| param | type | default | range / choices | description |\n|---|---|---|---|---|\n";
      for (const auto& p : i.params) {
        std::string range;
        if (p.min || p.max) {
          std::ostringstream r;
          r << (p.min ? general_text(*p.min) : "") << " .. " << (p.max ? general_text(*p.max) : "");
          range = r.str();
        }
        for (const auto& ch : p.choices) range += (range.empty() ? "" : ", ") + ch;
        os << "| `" << p.name << "` | " << param_type_name(p.type) << " | "
           << (p.required() ? std::string("*required*") : "`" + hf::json_text(p.default_value) + "`") << " | "
           << range << " | " << p.doc << (p.scene_key.empty() ? "" : " (scene: `" + p.scene_key + "`)")
           << " |\n";
      }
      os << "\n";
    }
    return os.str();
  }
  os << i.kind << "/" << i.name << " — " << i.summary << "\n";
  os << "  plugin:  " << c.plugin_name << " " << c.plugin_version << "\n";
  os << "  library: " << (c.library.empty() ? "<built-in>" : c.library) << "\n";
  if (!i.doc.empty()) os << "\n" << i.doc << "\n";
  if (!i.inputs.empty()) {
    os << "\ninputs:\n";
    for (const auto& p : i.inputs)
      os << "  " << std::left << std::setw(14) << p.name << " " << p.type_str() << port_flags(p)
         << (p.doc.empty() ? "" : "  — " + p.doc) << "\n";
  }
  if (!i.outputs.empty()) {
    os << "\noutputs:\n";
    for (const auto& p : i.outputs)
      os << "  " << std::left << std::setw(14) << p.name << " " << p.type_str()
         << (p.doc.empty() ? "" : "  — " + p.doc) << "\n";
  }
  if (!i.params.empty()) {
    os << "\nparams:\n";
    for (const auto& p : i.params)
      os << "  " << param_line(p) << (p.doc.empty() ? "" : "\n      " + p.doc)
         << (p.scene_key.empty() ? "" : "\n      from scene." + p.scene_key) << "\n";
  }
  return os.str();
}

FrameWindow parse_frame_window(const std::string& text) {
  const auto colon = text.find(':');
  auto number = [&](const std::string& part, int64_t empty) -> int64_t {
    if (part.empty()) return empty;
    size_t used = 0;
    int64_t v = -1;
    try {
      v = std::stoll(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != part.size() || v < 0)
      throw Error("--frames '" + text + "': '" + part + "' is not a frame index (0, 1, 2, ...)");
    return v;
  };
  if (colon == std::string::npos)
    throw Error("--frames '" + text + "': expected FIRST:LAST, e.g. 12:40 or 12:");
  FrameWindow w{number(text.substr(0, colon), 0), number(text.substr(colon + 1), -1)};
  if (w.last >= 0 && w.last < w.first)
    throw Error("--frames '" + text + "': the last frame comes before the first");
  return w;
}

int cmd_run(Host& host, const CommonOptions& o) {
  RunOutcome out = run_config(host, run_request(o));
  if (!out.message.empty()) std::cerr << redact_urls(out.message) << "\n";
  if (out.result && out.exit_code == 0) {
    const RunResult& r = *out.result;
    std::cerr << "done: " << r.frames << " frames in " << std::fixed << std::setprecision(1) << r.wall_s
              << " s (" << (r.wall_s > 0 ? static_cast<double>(r.frames) / r.wall_s : 0.0) << " frames/s) -> "
              << out.output_dir.string() << "\n";
  }
  return out.exit_code;
}

int cmd_validate(Host& host, const CommonOptions& o) {
  try {
    Graph g = load_graph(host, o.config, o.overrides, nullptr, o.load_config_plugins, {}, o.set_base);
    for (const Diagnostic& w : g.warnings) std::cerr << w.str() << "\n";
    std::cout << o.config << ": ok (" << g.nodes.size() << " nodes)\n";
    return 0;
  } catch (const Error& e) {
    std::cerr << redact_urls(e.what()) << "\n";
    return 1;
  }
}

int cmd_plugins(Host& host, bool json) {
  std::vector<std::string> errors = host.load_plugins();
  if (json) {
    Json j = {{"search_path", Json::array()}, {"plugins", Json::array()}, {"errors", errors}};
    for (const auto& p : host.searched()) j["search_path"].push_back(p.string());
    for (const auto& p : host.loader().plugins())
      j["plugins"].push_back({{"name", p.name},
                              {"version", p.version},
                              {"license", p.license},
                              {"path", p.path.string()},
                              {"description", p.description},
                              {"components", p.components}});
    std::cout << hf::json_text(j, 2) << "\n";
  } else {
    std::cout << "search path:\n";
    for (const auto& p : host.searched()) std::cout << "  " << p.string() << "\n";
    std::cout << "\n";
    for (const auto& p : host.loader().plugins()) {
      std::cout << p.name << " " << p.version << " (" << p.license << ")  " << p.path.string() << "\n";
      if (!p.description.empty()) std::cout << "  " << p.description << "\n";
      for (const auto& c : p.components) {
        const auto slash = c.find('/');
        const RegisteredComponent* rc = host.registry().find(c.substr(0, slash), c.substr(slash + 1));
        std::cout << "    " << std::left << std::setw(34) << c << (rc ? rc->info.summary : "") << "\n";
      }
    }
  }
  print_load_errors(errors);
  return errors.empty() ? 0 : 1;
}

int cmd_inspect(Host& host, const std::string& name, bool markdown) {
  std::vector<std::string> errors = host.load_plugins();
  print_load_errors(errors);
  std::string why;
  const RegisteredComponent* c = host.registry().find(name, false, &why);
  if (!c) {
    std::cerr << "error: " << why << "\n";
    return 1;
  }
  std::cout << describe_component(*c, markdown);
  return errors.empty() ? 0 : 1;
}

int cmd_inspect_all(Host& host, bool markdown) {
  std::vector<std::string> errors = host.load_plugins();
  print_load_errors(errors);
  std::vector<const RegisteredComponent*> all;
  for (const auto& c : host.registry().all()) all.push_back(&c);
  // Grouped by kind in pipeline order, then by name, so the generated page is stable.
  const std::vector<std::string> order = {
      kind::kSource,    kind::kDetector,    kind::kTracker, kind::kEstimator,      kind::kRiskMetric,
      kind::kGenerator, kind::kLlmProvider, kind::kPlanner, kind::kHazardTemplate, kind::kRenderer,
      kind::kVerifier,  kind::kFilter,      kind::kSystem,  kind::kSink};
  auto rank = [&](const std::string& k) {
    auto it = std::find(order.begin(), order.end(), k);
    return static_cast<size_t>(it - order.begin());
  };
  std::sort(all.begin(), all.end(), [&](const auto* a, const auto* b) {
    return std::make_pair(rank(a->info.kind), a->info.name) <
           std::make_pair(rank(b->info.kind), b->info.name);
  });
  if (markdown)
    std::cout
        << "# Stage and component reference\n\nGenerated by `hazardforge inspect --all --markdown`; do not "
           "edit by hand (a test checks it matches the code).\n\n";
  std::string last_kind;
  for (const auto* c : all) {
    if (markdown && c->info.kind != last_kind) std::cout << "## " << c->info.kind << "\n\n";
    last_kind = c->info.kind;
    std::cout << describe_component(*c, markdown) << (markdown ? "" : "\n");
  }
  return errors.empty() ? 0 : 1;
}

int cmd_graph(Host& host, const CommonOptions& o) {
  try {
    Graph g = load_graph(host, o.config, o.overrides, nullptr, o.load_config_plugins, {}, o.set_base);
    std::cout << g.to_dot();
    return 0;
  } catch (const Error& e) {
    std::cerr << redact_urls(e.what()) << "\n";
    return 1;
  }
}

int cmd_eval(Host& host, const CommonOptions& o) {
  // A graph without an evaluation sink writes no report: refused before it runs (a run that completes and
  // then fails the command would leave a manifest saying "completed" behind an exit code of 1).
  try {
    const Graph g = load_graph(host, o.config, o.overrides, nullptr, o.load_config_plugins, {}, o.set_base);
    const bool evaluates = std::any_of(g.nodes.begin(), g.nodes.end(), [](const NodeSpec& n) {
      return n.component && n.component->info.kind == kind::kSink && n.component->info.name == "evaluation";
    });
    if (!evaluates) {
      std::cerr << "error: " << o.config
                << ": the graph has no evaluation sink (stage 'evaluation'), so it writes no report; 'eval' is "
                   "for evaluation configs (configs/eval_*.yaml), 'run' for the others\n";
      return 1;
    }
  } catch (const Error& e) {
    std::cerr << redact_urls(e.what()) << "\n";
    return 1;
  }
  RunOutcome out = run_config(host, run_request(o));
  if (!out.message.empty()) std::cerr << redact_urls(out.message) << "\n";
  if (out.exit_code != 0) return out.exit_code;
  // Print every Markdown report the run wrote (evaluation sinks name theirs report.md).
  int printed = 0;
  std::error_code ec;
  for (const auto& e : std::filesystem::recursive_directory_iterator(out.output_dir, ec)) {
    if (e.path().filename() != "report.md") continue;
    std::ifstream in(e.path());
    std::cout << in.rdbuf() << "\n";
    std::cerr << "report: " << e.path().string() << "\n";
    ++printed;
  }
  if (printed == 0) {
    std::cerr << "error: " << o.config
              << ": the run wrote no report.md — does the graph have an evaluation sink?\n";
    return 1;
  }
  return 0;
}

}  // namespace hf::apps
