// Small in-process stages for host tests: a synthetic source, a detector, a filter and a collecting sink.
#pragma once

#include <mutex>
#include <stdexcept>
#include <thread>

#include "hazardforge/core/host.hpp"
#include "hazardforge/plugin.hpp"

namespace hf::test {

// Emits `count` frames of a flat image whose value is the frame index, at `fps`.
class TestSource : public SourceStage {
 public:
  static ComponentInfo describe() {
    ComponentInfo i = base_info("test_source", "synthetic frames");
    i.params = {ParamSpec::integer("count", 10).range(0, 100000), ParamSpec::number("fps", 10.0).range(0.1, 1000)};
    return i;
  }
  void open(StageContext& ctx) override {
    count_ = ctx.params().get_int("count");
    fps_ = ctx.params().get_double("fps");
  }
  bool next(StageContext&, Outputs& out) override {
    if (n_ >= count_) return false;
    Frame f;
    f.index = n_;
    f.timestamp = static_cast<double>(n_) / fps_;
    f.image = cv::Mat(8, 8, CV_8UC3, cv::Scalar::all(static_cast<double>(n_ % 256)));
    out.emit("frames", f);
    ++n_;
    return true;
  }
  std::optional<int64_t> frame_count() const override { return count_; }

 private:
  int64_t count_ = 0, n_ = 0;
  double fps_ = 10;
};

// One box per frame; emits nothing on frames divisible by `skip_every` (sparse stream); throws at `throw_at`;
// `helper_work` iterations of arithmetic run on a helper thread that each call starts and waits for.
class TestDetector : public Detector {
 public:
  static ComponentInfo describe() {
    ComponentInfo i = base_info("test_detector", "synthetic detections");
    i.params = {ParamSpec::number("conf_threshold", 0.25).range(0, 1).describe("confidence"),
                ParamSpec::integer("throw_at", -1),
                ParamSpec::integer("sleep_ms", 0).range(0, 1000),
                ParamSpec::integer("helper_work", 0).range(0, 1000000000),
                ParamSpec::string("mode", "fast").one_of({"fast", "accurate"}),
                ParamSpec::integer("lanes", 1).range(0, 5).from_scene("road.lanes_left"),
                ParamSpec::path("weights", ""),
                ParamSpec::path("assets", "").from_scene("assets.dir")};
    return i;
  }
  void open(StageContext& ctx) override {
    throw_at_ = ctx.params().get_int("throw_at");
    sleep_ms_ = ctx.params().get_int("sleep_ms");
    helper_work_ = ctx.params().get_int("helper_work");
  }
  Detections detect(StageContext& ctx, const Frame& f) override {
    if (f.index == throw_at_) throw Error("synthetic failure");
    if (sleep_ms_ > 0) std::this_thread::sleep_for(std::chrono::milliseconds(sleep_ms_));
    if (helper_work_ > 0) {  // CPU work done by a helper thread while this one waits for it
      std::thread helper([n = helper_work_] {
        volatile uint64_t x = 1;
        for (int64_t k = 0; k < n; ++k) x = x * 6364136223846793005ull + 1442695040888963407ull;
      });
      helper.join();
    }
    ctx.record_timing("forward", 0.001);
    Detections d;
    d.frame_index = f.index;
    d.items.push_back(Detection{cv::Rect2f(static_cast<float>(f.index), 0, 2, 2), 2, "car", 0.9f});
    return d;
  }

 private:
  int64_t throw_at_ = -1, sleep_ms_ = 0, helper_work_ = 0;
};

// Detections -> Detections, emitting only every `every`-th frame (a sparse stream), for cycles and stickiness.
class TestFilter : public Stage {
 public:
  static ComponentInfo describe() {
    ComponentInfo i;
    i.name = "test_filter";
    i.kind = kind::kFilter;
    i.summary = "passes every n-th packet";
    i.inputs = {port<Detections>("detections")};
    i.outputs = {port<Detections>("detections")};
    i.params = {ParamSpec::integer("every", 1).range(1, 1000)};
    return i;
  }
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override {
    const Detections& d = in.require<Detections>("detections");
    if (d.frame_index % ctx.params().get_int("every") == 0) out.emit("detections", d);
  }
};

// Records everything it sees (per node id) into a process-wide log the tests read.
struct Seen {
  int64_t frame;
  double timestamp;
  std::string port;
  std::string producer;
  std::string type;
};
inline std::mutex g_seen_mu;
inline std::map<std::string, std::vector<Seen>> g_seen;
inline std::map<std::string, int> g_finished;

class TestSink : public Stage {
 public:
  static ComponentInfo describe() {
    ComponentInfo i;
    i.name = "test_sink";
    i.kind = kind::kSink;
    i.summary = "collects packets";
    i.inputs = {multi(any_port("records")), optional(port<Frame>("frames")),
                sticky(port<Detections>("hint")), optional(port<Detections>("detections"))};
    return i;
  }
  void process(StageContext& ctx, const Inputs& in, Outputs&) override {
    std::lock_guard lk(g_seen_mu);
    for (const char* p : {"records", "frames", "hint", "detections"}) {
      auto packets = in.packets(p);
      auto prods = in.producers(p);
      for (size_t k = 0; k < packets.size(); ++k)
        g_seen[ctx.node_id()].push_back({ctx.frame_index(), packets[k]->timestamp(), p, prods[k], packets[k]->type_name()});
    }
  }
  void finish(StageContext& ctx, Outputs&) override {
    std::lock_guard lk(g_seen_mu);
    ++g_finished[ctx.node_id()];
  }
};

inline void register_test_stages(ComponentRegistry& r) {
  r.add<TestSource>();
  r.add<TestDetector>();
  r.add<TestFilter>();
  r.add<TestSink>();
}

inline void reset_seen() {
  std::lock_guard lk(g_seen_mu);
  g_seen.clear();
  g_finished.clear();
}

}  // namespace hf::test
