// Benchmark of every per-frame step of the assessment graph except detector inference, at 1600x900 with N
// synthetic objects (N = 10 and 50): trackers, the monocular and kalman estimators, the risk metrics (the
// keypoint ones track corners in the frame image), jsonl records,
// the annotated overlay, and the annotated_video sink with its H.264 encoder (draw + encode).
//
//   bench_non_inference [--benchmark_repetitions=5 --benchmark_report_aggregates_only=true ...]
//
// Stages run through StageRunner exactly as the host calls them (packet in, process(), packet out), so the
// times include packet creation. The objects move on smooth periodic paths (approaching and receding cars,
// trucks, people across the view), so trackers keep stable ids and velocities exist. The video benchmarks use
// the nuScenes CAM_FRONT keyframes under $HAZARDFORGE_SHARED when present (encoding cost depends on the
// picture), else a synthetic moving texture; they report wall time (the encoder is a separate process).
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "annotated_video_sink.hpp"
#include "centroid_tracker.hpp"
#include "drac_metric.hpp"
#include "hazardforge/image_file.hpp"
#include "hazardforge/params.hpp"
#include "hazardforge/testing/benchmark_main.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "jsonl_sink.hpp"
#include "kalman_estimator.hpp"
#include "monocular_estimator.hpp"
#include "overlay.hpp"
#include "sort_tracker.hpp"
#include "time_headway_metric.hpp"
#include "ttc_keypoints_metric.hpp"
#include "ttc_paper_metric.hpp"
#include "ttc_scale_metric.hpp"

namespace {

namespace fs = std::filesystem;
using hf::testing::StageRunner;

constexpr int kWidth = 1600, kHeight = 900;
constexpr double kDt = 0.1;        // s between frames
constexpr int kPeriod = 100;       // frames; every path repeats, so the sequence loops without a jump
constexpr int kWarmup = 10;        // frames fed before timing, so tracks and velocity histories exist
constexpr int64_t kRenew = 2000;   // runners collect every output; a fresh one (untimed) bounds memory
const std::vector<std::string> kMetrics = {"ttc", "ttc_scale", "thw", "drac"};

hf::CameraModel camera() { return hf::CameraModel::pinhole(kWidth, kHeight, 1250, 1250, 800, 450, 1.5, 0.0, 1.7); }

struct Scene {
  std::vector<hf::Detections> dets;                   // per frame of the period
  std::vector<hf::Tracks> tracks;                     // centroid tracker output on dets (second period)
  std::vector<hf::ObjectStates> states;               // monocular estimator output on tracks
  std::vector<std::vector<hf::RiskAssessment>> risks;  // per frame, one per kMetrics
};

cv::Mat base_image() {
  static const cv::Mat img = [] {
    cv::Mat m(kHeight, kWidth, CV_8UC3);
    cv::randu(m, cv::Scalar::all(40), cv::Scalar::all(200));
    cv::GaussianBlur(m, m, cv::Size(0, 0), 3);
    return m;
  }();
  return img;
}

// Real frames for the encoder (its cost depends on the content), cycled; a moving synthetic texture without
// the shared data.
const std::vector<cv::Mat>& video_frames() {
  static const std::vector<cv::Mat> frames = [] {
    std::vector<cv::Mat> v;
    const fs::path dir = fs::path(hf::shared_root()) / "data/nuscenes/samples/CAM_FRONT";
    std::vector<fs::path> files;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec))
      if (e.path().extension() == ".jpg") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const fs::path& f : files) {
      cv::Mat m = cv::imread(f.string());
      if (m.size() == cv::Size(kWidth, kHeight)) v.push_back(m);
    }
    if (v.empty()) {
      std::cerr << "bench_non_inference: no nuScenes frames in " << dir << "; encoding a synthetic texture\n";
      for (int i = 0; i < 20; ++i) {
        cv::Mat m;
        cv::warpAffine(base_image(), m, cv::Mat_<double>({2, 3}, {1, 0, 6.0 * i, 0, 1, 2.0 * i}),
                       cv::Size(kWidth, kHeight), cv::INTER_LINEAR, cv::BORDER_REFLECT);
        v.push_back(m);
      }
    } else {
      std::cerr << "bench_non_inference: encoding " << v.size() << " nuScenes frames from " << dir << "\n";
    }
    return v;
  }();
  return frames;
}

// The sources' frame read (hf::read_color_image) beside OpenCV's imread of the same 1600x900 nuScenes JPEGs,
// cycled over the first 40 (the page cache is warm after the first pass): what decoding costs a source node.
void BM_ReadFrame(benchmark::State& state) {
  static const std::vector<fs::path> files = [] {
    std::vector<fs::path> v;
    std::error_code ec;
    for (const auto& e :
         fs::directory_iterator(fs::path(hf::shared_root()) / "data/nuscenes/samples/CAM_FRONT", ec))
      if (e.path().extension() == ".jpg") v.push_back(e.path());
    std::sort(v.begin(), v.end());
    if (v.size() > 40) v.resize(40);
    return v;
  }();
  if (files.empty()) {
    state.SkipWithError("no nuScenes CAM_FRONT frames under the shared data");
    return;
  }
  const bool sdk = state.range(0) != 0;
  state.SetLabel(sdk ? "hf::read_color_image" : "cv::imread");
  size_t i = 0;
  for (auto _ : state) {
    const fs::path& f = files[i++ % files.size()];
    cv::Mat m = sdk ? hf::read_color_image(f, "frame") : cv::imread(f.string(), cv::IMREAD_COLOR);
    benchmark::DoNotOptimize(m.data);
  }
}

hf::Frame frame(int64_t k) {
  hf::Frame f;
  f.index = k;
  f.timestamp = k * kDt;
  f.image = base_image();
  f.camera = camera();
  f.ego.speed_mps = 10.0;
  f.source_id = "synthetic";
  return f;
}

template <class T>
T at(const std::vector<T>& v, int64_t k) {
  T x = v[static_cast<size_t>(k % kPeriod)];
  x.frame_index = k;
  return x;
}

// N objects on periodic paths inside the view, then the real tracker/estimator/metrics over them.
const Scene& scene(int n) {
  static std::map<int, std::unique_ptr<Scene>> cache;
  auto& s = cache[n];
  if (s) return *s;
  s = std::make_unique<Scene>();
  const hf::CameraModel cam = camera();
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(0, 1);
  struct Obj {
    std::string label;
    double x0, side, h, w, amp, phase;
  };
  std::vector<Obj> objs;
  for (int i = 0; i < n; ++i) {
    const double r = u(rng);
    Obj o;
    if (r < 0.6) {
      o = {"car", 0, 0, 1.52, 1.85, 0, 0};
    } else if (r < 0.75) {
      o = {"truck", 0, 0, 3.2, 2.5, 0, 0};
    } else {
      o = {"person", 0, 0, 1.7, 0.6, 0, 0};
    }
    o.x0 = 10.0 + 60.0 * u(rng);
    o.side = 2 * u(rng) - 1;
    o.amp = 1.0 + 4.0 * u(rng);
    o.phase = 2 * M_PI * u(rng);
    objs.push_back(o);
  }
  for (int k = 0; k < kPeriod; ++k) {
    hf::Detections d;
    d.frame_index = k;
    d.image_size = {kWidth, kHeight};
    d.detector = "synthetic";
    for (const Obj& o : objs) {
      const double x = o.x0 + o.amp * std::sin(2 * M_PI * k / kPeriod + o.phase);
      const double y = o.side * 0.5 * (x - 1.7);  // inside the 65 degree horizontal view
      const auto bottom = cam.project_ego({x, y, 0.0}), top = cam.project_ego({x, y, o.h});
      const double depth = cam.ego_to_cam({x, y, 0.0})[2];
      const double w = cam.fx * o.w / depth;
      hf::Detection det;
      det.box = cv::Rect2f(static_cast<float>(bottom->x - w / 2), static_cast<float>(top->y),
                           static_cast<float>(w), static_cast<float>(bottom->y - top->y));
      det.label = o.label;
      det.class_id = o.label == "person" ? 0 : o.label == "car" ? 2 : 7;
      det.score = 0.8f;
      d.items.push_back(det);
    }
    s->dets.push_back(std::move(d));
  }
  // Two periods through the real stages; the second is steady (every object tracked, velocities known).
  auto tracker = StageRunner::create<hf::CentroidTracker>();
  for (int64_t k = 0; k < 2 * kPeriod; ++k) {
    tracker.push("frames", frame(k), k * kDt);
    tracker.push("detections", at(s->dets, k), k * kDt);
  }
  tracker.run();
  const auto tracks = tracker.collect<hf::Tracks>("tracks");
  auto est = StageRunner::create<hf::MonocularEstimator>();
  for (int64_t k = 0; k < 2 * kPeriod; ++k) {
    est.push("frames", frame(k), k * kDt);
    est.push("tracks", tracks.at(static_cast<size_t>(k)), k * kDt);
  }
  est.run();
  const auto states = est.collect<hf::ObjectStates>("states");
  s->tracks.assign(tracks.begin() + kPeriod, tracks.end());
  s->states.assign(states.begin() + kPeriod, states.end());
  std::vector<StageRunner> metrics;
  metrics.push_back(StageRunner::create<hf::TtcPaperMetric>());
  metrics.push_back(StageRunner::create<hf::TtcScaleMetric>());
  metrics.push_back(StageRunner::create<hf::TimeHeadwayMetric>());
  metrics.push_back(StageRunner::create<hf::DracMetric>());
  s->risks.resize(kPeriod);
  for (StageRunner& m : metrics) {
    for (int64_t k = 0; k < 2 * kPeriod; ++k) {
      m.push("frames", frame(k), k * kDt);
      m.push("states", states.at(static_cast<size_t>(k)), k * kDt);
    }
    m.run();
    const auto r = m.collect<hf::RiskAssessment>("risk");
    for (int k = 0; k < kPeriod; ++k) s->risks[k].push_back(r.at(static_cast<size_t>(k + kPeriod)));
  }
  return *s;
}

// Times `push(runner, k); runner.run(false)` per iteration: one frame through the stage.
void run_stage(benchmark::State& st, const std::function<StageRunner()>& make,
               const std::function<void(StageRunner&, int64_t)>& push) {
  StageRunner r = make();
  int64_t k = 0;
  auto warm = [&] {
    for (int i = 0; i < kWarmup; ++i, ++k) {
      push(r, k);
      r.run(false);
    }
  };
  warm();
  int64_t since = 0;
  for (auto _ : st) {
    push(r, k++);
    r.run(false);
    if (++since == kRenew) {
      st.PauseTiming();
      r = make();
      warm();
      since = 0;
      st.ResumeTiming();
    }
  }
  st.counters["objects"] = static_cast<double>(st.range(0));
}

template <class T>
void BM_Tracker(benchmark::State& st) {
  const Scene& s = scene(static_cast<int>(st.range(0)));
  run_stage(
      st, [] { return StageRunner::create<T>(); },
      [&](StageRunner& r, int64_t k) {
        r.push("frames", frame(k), k * kDt);
        r.push("detections", at(s.dets, k), k * kDt);
      });
}

void BM_Monocular(benchmark::State& st) {
  const Scene& s = scene(static_cast<int>(st.range(0)));
  run_stage(
      st, [] { return StageRunner::create<hf::MonocularEstimator>(); },
      [&](StageRunner& r, int64_t k) {
        r.push("frames", frame(k), k * kDt);
        r.push("tracks", at(s.tracks, k), k * kDt);
      });
}

// The filtered estimator with its keypoint scale step (corners and pyramidal KLT on the 1600x900 frame).
void BM_Kalman(benchmark::State& st) {
  const Scene& s = scene(static_cast<int>(st.range(0)));
  run_stage(
      st, [] { return StageRunner::create<hf::KalmanEstimator>(); },
      [&](StageRunner& r, int64_t k) {
        r.push("frames", frame(k), k * kDt);
        r.push("tracks", at(s.tracks, k), k * kDt);
      });
}

template <class T>
void BM_Metric(benchmark::State& st) {
  const Scene& s = scene(static_cast<int>(st.range(0)));
  run_stage(
      st, [] { return StageRunner::create<T>(); },
      [&](StageRunner& r, int64_t k) {
        r.push("frames", frame(k), k * kDt);
        r.push("states", at(s.states, k), k * kDt);
      });
}

void BM_JsonlRecords(benchmark::State& st) {
  const Scene& s = scene(static_cast<int>(st.range(0)));
  run_stage(
      st, [] { return StageRunner::create<hf::sink::JsonlSink>(); },
      [&](StageRunner& r, int64_t k) {
        r.push("records", at(s.states, k), k * kDt, "estimator");
        for (size_t m = 0; m < kMetrics.size(); ++m) {
          hf::RiskAssessment a = s.risks[static_cast<size_t>(k % kPeriod)][m];
          a.frame_index = k;
          r.push("records", std::move(a), k * kDt, kMetrics[m]);
        }
      });
}

hf::sink::OverlayInputs overlay_inputs(const Scene& s, int64_t k) {
  hf::sink::OverlayInputs in;
  const size_t i = static_cast<size_t>(k % kPeriod);
  in.tracks = &s.tracks[i];
  in.states = &s.states[i];
  for (size_t m = 0; m < kMetrics.size(); ++m) in.risks.emplace_back(kMetrics[m], &s.risks[i][m]);
  return in;
}

// What the annotated_video sink does before encoding: copy the shared frame, draw boxes, labels and banners.
void BM_AnnotatedOverlay(benchmark::State& st) {
  const Scene& s = scene(static_cast<int>(st.range(0)));
  const auto& frames = video_frames();
  int64_t k = 0;
  for (auto _ : st) {
    cv::Mat img = frames[static_cast<size_t>(k) % frames.size()].clone();
    hf::sink::draw_overlay(img, k, k * kDt, overlay_inputs(s, k), 2);
    benchmark::DoNotOptimize(img.data);
    ++k;
  }
  st.counters["objects"] = static_cast<double>(st.range(0));
}

// The whole annotated_video sink per frame: overlay + H.264 through ffmpeg (args: objects, preset index).
void BM_AnnotatedVideoSink(benchmark::State& st) {
  const Scene& s = scene(static_cast<int>(st.range(0)));
  const auto& frames = video_frames();
  const std::vector<std::string> presets = {"ultrafast", "superfast", "veryfast"};
  const std::string preset = presets.at(static_cast<size_t>(st.range(1)));
  st.SetLabel(preset);
  auto make = [&] { return StageRunner::create<hf::sink::AnnotatedVideoSink>("{fps: 10, preset: " + preset + "}"); };
  auto push = [&](StageRunner& r, int64_t k) {
    const double t = k * kDt;
    hf::Frame f = frame(k);
    f.image = frames[static_cast<size_t>(k) % frames.size()];
    r.push("frames", f, t);
    r.push("tracks", at(s.tracks, k), t);
    r.push("states", at(s.states, k), t);
    for (size_t m = 0; m < kMetrics.size(); ++m) {
      hf::RiskAssessment a = s.risks[static_cast<size_t>(k % kPeriod)][m];
      a.frame_index = k;
      r.push("risk", std::move(a), t, kMetrics[m]);
    }
  };
  auto child_cpu = [] {
    rusage u{};
    getrusage(RUSAGE_CHILDREN, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
           static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
  };
  const double cpu0 = child_cpu();
  StageRunner r = make();
  int64_t k = 0;
  for (auto _ : st) {
    push(r, k++);
    r.run(false);
  }
  r.run(true);  // finish(): closes the encoder (after the loop, so untimed)
  // The encoder's own CPU time (ffmpeg is a child process, reaped in finish()), which "CPU" above excludes.
  if (k > 0) st.counters["encoder_cpu_ms"] = (child_cpu() - cpu0) * 1e3 / static_cast<double>(k);
  const auto& tm = r.timings();
  if (tm.count("encode")) {
    std::vector<double> e = tm.at("encode");
    std::nth_element(e.begin(), e.begin() + static_cast<std::ptrdiff_t>(e.size() / 2), e.end());
    st.counters["encode_median_ms"] = e[e.size() / 2] * 1e3;
  }
  st.counters["objects"] = static_cast<double>(st.range(0));
}

}  // namespace

BENCHMARK_TEMPLATE(BM_Tracker, hf::CentroidTracker)->Name("tracker/centroid")->Arg(10)->Arg(50);
BENCHMARK_TEMPLATE(BM_Tracker, hf::SortTracker)->Name("tracker/sort")->Arg(10)->Arg(50);
BENCHMARK(BM_Monocular)->Name("estimator/monocular")->Arg(10)->Arg(50);
BENCHMARK(BM_Kalman)->Name("estimator/kalman")->Arg(10)->Arg(50)->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_Metric, hf::TtcPaperMetric)->Name("risk/ttc_paper")->Arg(10)->Arg(50);
BENCHMARK_TEMPLATE(BM_Metric, hf::TtcScaleMetric)->Name("risk/ttc_scale")->Arg(10)->Arg(50);
BENCHMARK_TEMPLATE(BM_Metric, hf::TtcKeypointsMetric)
    ->Name("risk/ttc_keypoints")
    ->Arg(10)
    ->Arg(50)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_Metric, hf::TimeHeadwayMetric)->Name("risk/thw")->Arg(10)->Arg(50);
BENCHMARK_TEMPLATE(BM_Metric, hf::DracMetric)->Name("risk/drac")->Arg(10)->Arg(50);
BENCHMARK(BM_ReadFrame)->Name("source/read_frame")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_JsonlRecords)->Name("sink/jsonl_records")->Arg(10)->Arg(50);
BENCHMARK(BM_AnnotatedOverlay)->Name("sink/annotated_overlay")->Arg(10)->Arg(50)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AnnotatedVideoSink)
    ->Name("sink/annotated_video")
    ->Args({50, 0})
    ->Args({50, 2})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(4.0)
    ->UseRealTime();

HF_BENCHMARK_MAIN();
