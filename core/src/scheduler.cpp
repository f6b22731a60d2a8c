// Threaded graph execution with per-edge bounded queues, sticky/optional inputs, timing and clean shutdown.
#include "hazardforge/core/scheduler.hpp"

#include "hazardforge/redact.hpp"
#include "hazardforge/run_signals.hpp"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <ctime>
#include <deque>
#include <iostream>
#include <mutex>
#include <set>
#include <thread>

namespace hf::core {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// CPU time of the calling thread (not of the threads a stage's library starts, e.g. the detector's workers).
double thread_cpu_seconds() {
  timespec t{};
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t) != 0) return 0.0;
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct Message {
  int64_t tick = 0;   // position in the stream
  int64_t frame = 0;  // the recording's frame index (Frame::index; the tick when the source emits no frame)
  double timestamp = 0.0;
  bool final = false;
  std::vector<Packet> packets;
};

class Channel {
 public:
  explicit Channel(size_t cap) : cap_(cap) {}
  void push(Message m) {
    std::unique_lock lk(mu_);
    not_full_.wait(lk, [&] { return q_.size() < cap_; });
    q_.push_back(std::move(m));
    not_empty_.notify_one();
  }
  Message pop() {
    std::unique_lock lk(mu_);
    not_empty_.wait(lk, [&] { return !q_.empty(); });
    Message m = std::move(q_.front());
    q_.pop_front();
    not_full_.notify_one();
    return m;
  }

 private:
  size_t cap_;
  std::mutex mu_;
  std::condition_variable not_full_, not_empty_;
  std::deque<Message> q_;
};

struct Shared {
  std::mutex mu;
  std::vector<std::string> errors;
  std::vector<std::string> log;
  std::vector<std::string> incomplete;
  std::vector<NodeRefusal> refusals;
  bool failed_to_start = false;  // a node failed while being created or opened
  std::set<std::filesystem::path> resources;
  std::atomic<bool> abort{false};
  const RunOptions* options = nullptr;
};

struct Edge {
  std::string port;
  std::string producer;  // node id
  std::unique_ptr<Channel> channel;
};

struct NodeRuntime;

// Creates components with the run's scene block filling their scene-bound params.
class SceneFactory : public ComponentFactory {
 public:
  SceneFactory(const ComponentRegistry& registry, Json scene) : registry_(registry), scene_(std::move(scene)) {}
  std::unique_ptr<Component> create_component(const std::string& kind, const std::string& name,
                                              const Json& params) const override {
    return registry_.create_component(kind, name, params, scene_);
  }
  std::vector<std::string> component_names(const std::string& kind) const override {
    return registry_.component_names(kind);
  }

 private:
  const ComponentRegistry& registry_;
  Json scene_;
};

class NodeContext : public StageContext {
 public:
  NodeRuntime* node = nullptr;
  Shared* shared = nullptr;
  const ComponentFactory* factory = nullptr;
  Params params_;
  std::filesystem::path out_dir;
  int64_t index = 0;
  double ts = 0.0;
  mutable std::map<std::string, std::vector<double>> inner;

  const std::string& node_id() const override;
  const Params& params() const override { return params_; }
  const std::filesystem::path& output_dir() const override { return out_dir; }
  const ComponentFactory& components() const override { return *factory; }
  void log(LogLevel level, const std::string& message) const override;
  void report_incomplete(const std::string& reason) const;
  int64_t frame_index() const override { return index; }
  double timestamp() const override { return ts; }
  void record_resource(const std::filesystem::path& file) const override {
    std::lock_guard lk(shared->mu);
    std::error_code ec;
    shared->resources.insert(std::filesystem::absolute(file, ec).lexically_normal());
  }
  bool stop_requested() const override {
    return shared->abort || (shared->options->interrupt && shared->options->interrupt->load());
  }
  void record_timing(const std::string& label, double seconds) const override { inner[label].push_back(seconds); }
};

class NodeOutputs : public Outputs {
 public:
  const ComponentInfo* info = nullptr;
  double ts = 0.0;
  std::map<std::string, std::vector<Packet>> emitted;
  void emit_packet(const std::string& port, Packet p) override {
    const PortSpec* spec = info->output(port);
    if (!spec) throw Error("emitted on undeclared output '" + port + "'");
    if (spec->type_name != kAnyType && (p.type_name() != spec->type_name || p.type_version() != spec->type_version))
      throw Error("emitted " + p.type_name() + " v" + std::to_string(p.type_version()) + " on output '" + port +
                  "', declared " + spec->type_str());
    emitted[port].push_back(std::move(p));
  }
  double timestamp() const override { return ts; }
};

class NodeInputs : public Inputs {
 public:
  std::map<std::string, std::vector<Packet>> packets_;
  std::map<std::string, std::vector<std::string>> producers_;
  const Packet* packet(const std::string& port) const override {
    auto it = packets_.find(port);
    return (it == packets_.end() || it->second.empty()) ? nullptr : &it->second.front();
  }
  std::vector<const Packet*> packets(const std::string& port) const override {
    std::vector<const Packet*> v;
    if (auto it = packets_.find(port); it != packets_.end())
      for (const Packet& p : it->second) v.push_back(&p);
    return v;
  }
  std::vector<std::string> producers(const std::string& port) const override {
    auto it = producers_.find(port);
    return it == producers_.end() ? std::vector<std::string>{} : it->second;
  }
};

struct NodeRuntime {
  const NodeSpec* spec = nullptr;
  std::unique_ptr<Component> component;
  Stage* stage = nullptr;
  SourceStage* source = nullptr;
  NodeContext ctx;
  std::vector<Edge> inputs;                                        // one per connected stream
  std::map<std::string, std::vector<Channel*>> subscribers;        // output port -> channels
  std::vector<double> process_s;
  std::vector<double> process_cpu_s;
  std::atomic<int64_t> done{0};
  bool failed = false;

  std::string who() const {
    return "node '" + spec->id + "' (stage '" + spec->component->info.name + "', " +
           (spec->component->library.empty() ? std::string("built-in") : spec->component->library) + ")";
  }
};

const std::string& NodeContext::node_id() const { return node->spec->id; }

void NodeContext::log(LogLevel level, const std::string& message) const {
  if (level < shared->options->min_log_level) return;
  static const char* names[] = {"debug", "info", "warning", "error"};
  const std::string line =
      "[" + node->spec->id + "] " + names[static_cast<int>(level)] + ": " + redact_urls(message);
  std::lock_guard lk(shared->mu);
  if (!shared->options->quiet || (shared->options->quiet_keeps_warnings && level >= LogLevel::kWarning))
    std::cerr << line << "\n";
  if (level >= LogLevel::kWarning) shared->log.push_back(line);
}

void NodeContext::report_incomplete(const std::string& reason) const {
  log(LogLevel::kWarning, reason);
  std::lock_guard lk(shared->mu);
  shared->incomplete.push_back("node '" + node->spec->id + "': " + redact_urls(reason));
}

void fail(NodeRuntime& n, Shared& sh, const std::string& when, const std::string& what) {
  n.failed = true;
  sh.abort = true;
  std::lock_guard lk(sh.mu);
  sh.errors.push_back(n.who() + ": " + when + ": " + redact_urls(what));
  if (when == "create" || when == "open") sh.failed_to_start = true;
}

void send(NodeRuntime& n, int64_t tick, int64_t frame, double ts, bool final, NodeOutputs& out) {
  for (auto& [port, chans] : n.subscribers) {
    auto it = out.emitted.find(port);
    for (Channel* c : chans) {
      Message m{tick, frame, ts, final, {}};
      if (it != out.emitted.end()) m.packets = it->second;
      c->push(std::move(m));
    }
  }
}

template <class F>
void guarded(NodeRuntime& n, Shared& sh, const std::string& when, F&& f) {
  if (n.failed) return;
  try {
    f();
  } catch (const NoHazardFits& e) {
    {
      std::lock_guard lk(sh.mu);
      sh.refusals.push_back({n.spec->id, n.ctx.index, e.reasons()});
    }
    fail(n, sh, when, e.what());
  } catch (const std::exception& e) {
    fail(n, sh, when, e.what());
  } catch (...) {
    fail(n, sh, when, "unknown exception");
  }
}

void run_source(NodeRuntime& n, Shared& sh, const RunOptions& opt) {
  IncompleteReportScope incomplete([&n](const std::string& reason) { n.ctx.report_incomplete(reason); });
  int64_t tick = 0;
  int64_t last_frame = 0;
  double last_ts = 0.0;
  std::optional<int64_t> read_last;  // the last index the source read, in the frame window or not
  while (true) {
    const bool stop = sh.abort || (opt.interrupt && opt.interrupt->load()) ||
                      (opt.max_frames >= 0 && tick >= opt.max_frames);
    NodeOutputs out;
    out.info = &n.spec->component->info;
    bool produced = false;
    if (!stop && !n.failed) {
      n.ctx.index = tick;
      const auto t0 = Clock::now();
      const double c0 = thread_cpu_seconds();
      guarded(n, sh, "frame " + std::to_string(tick), [&] { produced = n.source->next(n.ctx, out); });
      if (produced) {
        n.process_cpu_s.push_back(thread_cpu_seconds() - c0);  // read first: the CPU interval lies in the wall one
        n.process_s.push_back(seconds_since(t0));
      }
    }
    std::optional<int64_t> index;  // the recording's frame index, when the source emitted a frame
    double ts = last_ts;
    if (produced)
      for (auto& [port, v] : out.emitted)
        for (const Packet& p : v)
          if (p.is<Frame>()) {
            ts = p.get<Frame>().timestamp;
            index = p.get<Frame>().index;
          }
    if (produced && index) read_last = *index;
    if (produced && index && (*index < opt.first_frame || (opt.last_frame >= 0 && *index > opt.last_frame))) {
      n.process_s.pop_back();  // outside the frame window: it never leaves the source
      n.process_cpu_s.pop_back();
      if (*index < opt.first_frame) continue;
      produced = false;  // past the window: the stream ends here, without this frame
      out.emitted.clear();
    }
    if (produced) {
      for (auto& [port, v] : out.emitted)
        for (Packet& p : v) p = p.restamped(ts);
      last_ts = ts;
      last_frame = index.value_or(tick);
      n.ctx.ts = ts;
      n.ctx.index = last_frame;
      send(n, tick, last_frame, ts, false, out);
      n.done = ++tick;
      continue;
    }
    // A frame window the recording does not reach is a mistake in the command, not an empty run.
    if (tick == 0 && !stop && !n.failed && (opt.first_frame > 0 || opt.last_frame >= 0))
      fail(n, sh, "frames",
           "the frame window " + std::to_string(opt.first_frame) + ":" +
               (opt.last_frame >= 0 ? std::to_string(opt.last_frame) : std::string()) +
               " holds no frame of the recording (" +
               (read_last ? "its frames end at index " + std::to_string(*read_last) : std::string("it has none")) +
               ")");
    out.ts = last_ts;
    guarded(n, sh, "finish", [&] { n.stage->finish(n.ctx, out); });
    send(n, tick, last_frame, last_ts, true, out);
    n.done = tick;
    return;
  }
}

void run_node(NodeRuntime& n, Shared& sh) {
  IncompleteReportScope incomplete([&n](const std::string& reason) { n.ctx.report_incomplete(reason); });
  const ComponentInfo& info = n.spec->component->info;
  std::map<std::string, Packet> held;  // sticky ports
  while (true) {
    NodeInputs in;
    int64_t tick = 0;
    int64_t frame = 0;
    double ts = 0.0;
    bool final = false;
    for (Edge& e : n.inputs) {
      Message m = e.channel->pop();
      tick = m.tick;
      frame = m.frame;
      ts = m.timestamp;
      final = final || m.final;
      for (Packet& p : m.packets) {
        in.packets_[e.port].push_back(std::move(p));
        in.producers_[e.port].push_back(e.producer);
      }
    }
    for (const PortSpec& p : info.inputs) {
      if (!p.sticky) continue;
      if (auto it = in.packets_.find(p.name); it != in.packets_.end() && !it->second.empty()) {
        held[p.name] = it->second.back();
      } else if (auto h = held.find(p.name); h != held.end()) {
        in.packets_[p.name] = {h->second};
        in.producers_[p.name] = {"(held)"};
      }
    }
    bool ready = true;
    bool any = false;
    for (const PortSpec& p : info.inputs) {
      const bool has = in.packets_.count(p.name) && !in.packets_[p.name].empty();
      any = any || has;
      if (!p.optional && !has) ready = false;
    }
    NodeOutputs out;
    out.info = &info;
    out.ts = ts;
    n.ctx.index = frame;
    n.ctx.ts = ts;
    if (ready && any) {
      const auto t0 = Clock::now();
      const double c0 = thread_cpu_seconds();
      guarded(n, sh, "frame " + std::to_string(frame), [&] { n.stage->process(n.ctx, in, out); });
      if (!final) {
        n.process_cpu_s.push_back(thread_cpu_seconds() - c0);  // read first: the CPU interval lies in the wall one
        n.process_s.push_back(seconds_since(t0));
      }
    }
    if (final) {
      guarded(n, sh, "finish", [&] { n.stage->finish(n.ctx, out); });
      send(n, tick, frame, ts, true, out);
      n.done = tick;
      return;
    }
    send(n, tick, frame, ts, false, out);
    n.done = tick + 1;
  }
}

}  // namespace

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  double m = v[mid];
  if (v.size() % 2 == 0) m = (m + *std::max_element(v.begin(), v.begin() + mid)) / 2.0;
  return m;
}

RunResult run_graph(const Graph& graph, const ComponentRegistry& registry, const RunOptions& opt) {
  RunResult result;
  Shared sh;
  sh.options = &opt;
  std::error_code ec;
  std::filesystem::create_directories(opt.output_dir, ec);
  if (ec) {
    result.errors.push_back(opt.output_dir.string() + ": cannot create output folder: " + ec.message());
    return result;
  }

  const SceneFactory factory(registry, graph.scene);
  std::vector<std::unique_ptr<NodeRuntime>> nodes;
  std::map<std::string, NodeRuntime*> by_id;
  for (const NodeSpec& spec : graph.nodes) {
    auto n = std::make_unique<NodeRuntime>();
    n->spec = &spec;
    n->ctx.node = n.get();
    n->ctx.shared = &sh;
    n->ctx.factory = &factory;
    n->ctx.params_ = Params(spec.params, graph.dir);
    n->ctx.params_.set_stated(spec.stated);
    n->ctx.out_dir = opt.output_dir;
    by_id[spec.id] = n.get();
    nodes.push_back(std::move(n));
  }
  // Wire edges: one channel per (consumer input port, stream).
  for (auto& n : nodes) {
    for (const auto& [port, streams] : n->spec->inputs) {
      for (const std::string& s : streams) {
        auto pit = graph.producers.find(s);
        if (pit == graph.producers.end()) continue;
        NodeRuntime* prod = by_id.at(pit->second.first);
        Edge e{port, s, std::make_unique<Channel>(opt.queue_capacity)};
        prod->subscribers[pit->second.second].push_back(e.channel.get());
        n->inputs.push_back(std::move(e));
      }
    }
  }
  // Create and open every node before any frame flows, so a bad model path fails fast.
  for (auto& n : nodes) {
    guarded(*n, sh, "create", [&] {
      n->component = n->spec->component->make();
      n->stage = dynamic_cast<Stage*>(n->component.get());
      if (!n->stage) throw Error("component is not a stage");
      n->source = dynamic_cast<SourceStage*>(n->stage);
    });
    if (!n->failed) guarded(*n, sh, "open", [&] { n->stage->open(n->ctx); });
    if (n->failed) break;
  }
  const auto t0 = Clock::now();
  if (sh.errors.empty()) {
    NodeRuntime* src = nullptr;
    for (auto& n : nodes)
      if (n->source) src = n.get();
    std::optional<int64_t> total;
    if (src) total = src->source->frame_count();
    if (total && opt.last_frame >= 0) total = std::min(*total, opt.last_frame + 1);
    if (total) total = std::max<int64_t>(0, *total - opt.first_frame);
    if (total && opt.max_frames >= 0) total = std::min(*total, opt.max_frames);
    std::vector<std::thread> threads;
    for (auto& n : nodes) {
      NodeRuntime* np = n.get();
      if (np->source) threads.emplace_back([np, &sh, &opt] { run_source(*np, sh, opt); });
      else if (np->inputs.empty()) continue;  // validated graphs have none; be safe
      else threads.emplace_back([np, &sh] { run_node(*np, sh); });
    }
    std::atomic<bool> finished{false};
    std::thread monitor;
    if (opt.on_progress) {
      monitor = std::thread([&] {
        while (!finished) {
          int64_t done = INT64_MAX;
          for (auto& n : nodes) done = std::min<int64_t>(done, n->done.load());
          opt.on_progress(done == INT64_MAX ? 0 : done, total);
          for (int i = 0; i < 10 && !finished; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
      });
    }
    for (auto& t : threads) t.join();
    finished = true;
    if (monitor.joinable()) monitor.join();
    if (opt.on_progress) {
      int64_t done = INT64_MAX;
      for (auto& n : nodes) done = std::min<int64_t>(done, n->done.load());
      opt.on_progress(done, total);
    }
    if (src) result.frames = static_cast<int64_t>(src->process_s.size());
  }
  result.wall_s = seconds_since(t0);
  result.interrupted = opt.interrupt && opt.interrupt->load();
  result.errors = sh.errors;
  result.log = sh.log;
  result.incomplete = sh.incomplete;
  result.refusals = sh.refusals;
  result.failed_to_start = sh.failed_to_start;
  result.resources.assign(sh.resources.begin(), sh.resources.end());
  for (auto& n : nodes) {
    NodeTiming t{n->spec->id,
                 n->spec->component->info.name,
                 n->spec->component->info.kind,
                 n->process_s,
                 n->ctx.inner,
                 n->process_cpu_s};
    result.timings.push_back(std::move(t));
  }
  // Components are destroyed here, in reverse order; libraries stay loaded.
  while (!nodes.empty()) nodes.pop_back();
  return result;
}

}  // namespace hf::core
