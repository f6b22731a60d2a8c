// StageRunner: drives one stage without a graph, validating params exactly as the host does.
#include "hazardforge/testing/stage_runner.hpp"

#include <atomic>

#include "hazardforge/run_signals.hpp"

#include <unistd.h>

#include <algorithm>
#include <iostream>
#include <optional>
#include <set>

#include "hazardforge/registry.hpp"
#include "hazardforge/yaml_json.hpp"

namespace hf::testing {

namespace {

class RunnerContext : public StageContext {
 public:
  std::string node = "under_test";
  Params params_;
  std::filesystem::path out_dir;
  const ComponentFactory* factory = nullptr;
  std::vector<std::string>* log_lines = nullptr;
  int64_t index = 0;
  double ts = 0.0;

  const std::string& node_id() const override { return node; }
  const Params& params() const override { return params_; }
  const std::filesystem::path& output_dir() const override { return out_dir; }
  const ComponentFactory& components() const override { return *factory; }
  void log(LogLevel level, const std::string& message) const override {
    static const char* names[] = {"debug", "info", "warning", "error"};
    log_lines->push_back(std::string(names[static_cast<int>(level)]) + ": " + message);
  }
  int64_t frame_index() const override { return index; }
  double timestamp() const override { return ts; }
  void record_resource(const std::filesystem::path&) const override {}
  bool stop_requested() const override { return stop != nullptr && stop->load(); }
  void record_timing(const std::string& label, double seconds) const override {
    (*timings)[label].push_back(seconds);
  }
  std::map<std::string, std::vector<double>>* timings = nullptr;
  const std::atomic<bool>* stop = nullptr;
};

struct Slot {
  std::vector<Packet> packets;
  std::vector<std::string> producers;
};

class RunnerInputs : public Inputs {
 public:
  std::map<std::string, Slot> slots;
  const Packet* packet(const std::string& port) const override {
    auto it = slots.find(port);
    return (it == slots.end() || it->second.packets.empty()) ? nullptr : &it->second.packets.front();
  }
  std::vector<const Packet*> packets(const std::string& port) const override {
    std::vector<const Packet*> v;
    if (auto it = slots.find(port); it != slots.end())
      for (const Packet& p : it->second.packets) v.push_back(&p);
    return v;
  }
  std::vector<std::string> producers(const std::string& port) const override {
    auto it = slots.find(port);
    return it == slots.end() ? std::vector<std::string>{} : it->second.producers;
  }
};

class RunnerOutputs : public Outputs {
 public:
  const ComponentInfo* info = nullptr;
  std::map<std::string, std::vector<Packet>>* sink = nullptr;
  double ts = 0.0;
  void emit_packet(const std::string& port, Packet p) override {
    const PortSpec* spec = info->output(port);
    if (!spec) throw Error("stage '" + info->name + "' emitted on undeclared output '" + port + "'");
    if (spec->type_name != kAnyType && (p.type_name() != spec->type_name || p.type_version() != spec->type_version))
      throw Error("stage '" + info->name + "' emitted " + p.type_name() + " on output '" + port + "' declared " +
                  spec->type_str());
    (*sink)[port].push_back(std::move(p));
  }
  double timestamp() const override { return ts; }
};

}  // namespace

struct StageRunner::Impl {
  ComponentRegistry registry;
  // A copy: the registry's storage moves when more components (providers, templates) are registered later.
  std::optional<RegisteredComponent> entry;
  std::unique_ptr<Component> component;
  Stage* stage = nullptr;
  RunnerContext ctx;
  std::map<double, std::map<std::string, Slot>> queued;  // timestamp -> port -> packets
  std::map<std::string, std::vector<Packet>> outputs;
  std::map<std::string, Packet> sticky;
  std::vector<std::string> log;
  std::map<std::string, std::vector<double>> timings;
  bool opened = false;
  std::filesystem::path out_dir;
  std::atomic<bool> stop{false};
};

StageRunner::StageRunner() : impl_(std::make_unique<Impl>()) {
  namespace fs = std::filesystem;
  std::string tmpl = (fs::temp_directory_path() / "hf_stage_runner_XXXXXX").string();
  if (!mkdtemp(tmpl.data())) throw Error("cannot create a temporary output folder");
  impl_->out_dir = tmpl;
}
StageRunner::~StageRunner() {
  if (impl_ && !impl_->out_dir.empty()) {
    std::error_code ec;
    std::filesystem::remove_all(impl_->out_dir, ec);
  }
}
StageRunner::StageRunner(StageRunner&&) noexcept = default;
StageRunner& StageRunner::operator=(StageRunner&&) noexcept = default;

Registrar& StageRunner::registrar() { return impl_->registry; }

void StageRunner::build(const std::string& kind, const std::string& name, const std::string& yaml_params) {
  Impl& m = *impl_;
  const RegisteredComponent* found = m.registry.find(kind, name);
  if (found) m.entry = *found;
  if (!m.entry) throw Error("StageRunner: no registered " + kind + " '" + name + "'");
  YamlDocument doc = parse_yaml(yaml_params.empty() ? "{}" : yaml_params, "<params>");
  ParamLocations locs;
  if (doc.value.is_object())
    for (auto it = doc.value.begin(); it != doc.value.end(); ++it) locs[it.key()] = doc.at("/" + it.key());
  std::vector<Diagnostic> diags;
  Json values = validate_params(m.entry->info.params, doc.value, "stage '" + name + "'", doc.at(""), locs, diags);
  if (!diags.empty()) throw DiagnosticError(std::move(diags));
  m.component = m.entry->make();
  m.stage = dynamic_cast<Stage*>(m.component.get());
  if (!m.stage) throw Error("StageRunner: '" + name + "' is not a stage");
  m.ctx.params_ = Params(std::move(values), std::filesystem::current_path());
  std::set<std::string> stated;
  if (doc.value.is_object())
    for (auto it = doc.value.begin(); it != doc.value.end(); ++it)
      if (!it->is_null()) stated.insert(it.key());
  m.ctx.params_.set_stated(std::move(stated));
  m.ctx.out_dir = m.out_dir;
  m.ctx.factory = &m.registry;
  m.ctx.log_lines = &m.log;
  m.ctx.timings = &m.timings;
  m.ctx.stop = &m.stop;
  m.ctx.node = name;
}

void StageRunner::push(const std::string& port, Packet packet, const std::string& producer) {
  Impl& m = *impl_;
  if (!m.entry) throw Error("StageRunner: build() the stage before pushing packets");
  const PortSpec* spec = m.entry->info.input(port);
  if (!spec) throw Error("stage '" + m.entry->info.name + "' has no input '" + port + "'");
  if (spec->type_name != kAnyType &&
      (packet.type_name() != spec->type_name || packet.type_version() != spec->type_version))
    throw Error("input '" + port + "' takes " + spec->type_str() + ", not " + packet.type_name());
  Slot& s = m.queued[packet.timestamp()][port];
  s.producers.push_back(producer);
  s.packets.push_back(std::move(packet));
}

void StageRunner::run(bool finish, int64_t max_frames) {
  Impl& m = *impl_;
  if (!m.stage) throw Error("StageRunner: build() the stage first");
  IncompleteReportScope incomplete(
      [&m](const std::string& reason) { m.log.push_back("incomplete: " + reason); });
  if (!m.opened) {
    m.stage->open(m.ctx);
    m.opened = true;
  }
  RunnerOutputs out;
  out.info = &m.entry->info;
  out.sink = &m.outputs;
  if (auto* src = dynamic_cast<SourceStage*>(m.stage)) {
    for (int64_t n = 0; max_frames < 0 || n < max_frames; ++n) {
      m.ctx.index = n;
      std::map<std::string, size_t> before;
      for (auto& [port, v] : m.outputs) before[port] = v.size();
      if (!src->next(m.ctx, out)) break;
      // Like the host: a source's packets carry the timestamp of the frame it emitted.
      double ts = m.ctx.ts;
      for (auto& [port, v] : m.outputs)
        for (size_t k = before[port]; k < v.size(); ++k)
          if (v[k].is<Frame>()) ts = v[k].get<Frame>().timestamp;
      for (auto& [port, v] : m.outputs)
        for (size_t k = before[port]; k < v.size(); ++k) v[k] = v[k].restamped(ts);
      out.ts = m.ctx.ts = ts;
    }
  } else {
    int64_t n = 0;
    for (auto& [ts, ports] : m.queued) {
      if (max_frames >= 0 && n >= max_frames) break;
      RunnerInputs in;
      for (auto& [port, slot] : ports) {
        const PortSpec* spec = m.entry->info.input(port);
        if (spec->sticky) m.sticky[port] = slot.packets.back();
        in.slots[port] = slot;
      }
      for (auto& [port, p] : m.sticky)
        if (!in.slots.count(port)) in.slots[port] = Slot{{p}, {"upstream"}};
      bool ready = true;
      for (const PortSpec& p : m.entry->info.inputs)
        if (!p.optional && !in.slots.count(p.name)) ready = false;
      m.ctx.index = n++;
      m.ctx.ts = out.ts = ts;
      if (ready) m.stage->process(m.ctx, in, out);
    }
    m.queued.clear();
  }
  if (finish) m.stage->finish(m.ctx, out);
}

const std::vector<Packet>& StageRunner::outputs(const std::string& port) const {
  static const std::vector<Packet> kEmpty;
  auto it = impl_->outputs.find(port);
  return it == impl_->outputs.end() ? kEmpty : it->second;
}

Stage& StageRunner::stage() { return *impl_->stage; }
const ComponentInfo& StageRunner::info() const { return impl_->entry->info; }
const std::filesystem::path& StageRunner::output_dir() const { return impl_->out_dir; }
void StageRunner::request_stop() {
  impl_->stop = true;
}
const std::vector<std::string>& StageRunner::log() const { return impl_->log; }
const std::map<std::string, std::vector<double>>& StageRunner::timings() const { return impl_->timings; }

}  // namespace hf::testing
