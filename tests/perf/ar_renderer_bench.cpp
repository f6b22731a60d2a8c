// Cost of the ar_renderer per 1600x900 frame (Google Benchmark): pass-through and compositing at several
// distances (ego motion from the frames is the ground_odometry stage's, benchmarked there). Single OpenCV
// thread, so the numbers are per-core work.
//
//   build/bin/hf_ar_renderer_bench --benchmark_min_time=3 --benchmark_repetitions=3
//   --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "ar_renderer.hpp"
#include "ego_motion.hpp"
#include "hazardforge/testing/benchmark_main.hpp"

namespace {

using namespace hf;
using namespace hf::render;

CameraModel camera() {
  return CameraModel::pinhole(1600, 900, 1266, 1266, 800, 450, 1.5, 0.02, 1.5);
}

// A road-like frame: noise texture (the compositing cost does not depend on content).
const cv::Mat& background() {
  static const cv::Mat img = [] {
    cv::Mat n(900, 1600, CV_32F), acc(900, 1600, CV_32F, cv::Scalar(0));
    cv::RNG rng(3);
    for (double s : {1.5, 4.0, 12.0}) {
      rng.fill(n, cv::RNG::NORMAL, 0.0, 1.0);
      cv::GaussianBlur(n, n, cv::Size(), s);
      cv::Scalar m, sd;
      cv::meanStdDev(n, m, sd);
      acc += n / sd[0];
    }
    cv::Mat g, bgr;
    acc.convertTo(g, CV_8U, 20.0, 110);
    cv::cvtColor(g, bgr, cv::COLOR_GRAY2BGR);
    return bgr;
  }();
  return img;
}

std::shared_ptr<const AssetLibrary> assets() {
  static auto lib =
      std::make_shared<const AssetLibrary>(AssetLibrary::load(std::filesystem::path(share_dir()) / "assets"));
  return lib;
}

// Ego and hazard both drive forward at 10 m/s; the hazard also weaves sideways, so it keeps its distance,
// changes its view and moves in the image (motion blur on) in every frame.
std::shared_ptr<const HazardTrajectory> weaving(const std::string& cls, double distance) {
  auto t = std::make_shared<HazardTrajectory>();
  t->kind = "bench";
  t->object_class = cls;
  t->size_lwh = cls == "person" ? cv::Vec3d(0.5, 0.6, 1.7) : cv::Vec3d(4.5, 1.85, 1.52);
  for (int k = 0; k <= 40000; ++k) {
    const double s = k * 0.04;
    t->points.push_back({s, distance + 10.0 * s, 1.5 * std::sin(s), 0.3 * std::cos(s), 10.0, 0.0});
  }
  return t;
}

void run_frames(benchmark::State& state, const std::shared_ptr<const HazardTrajectory>& traj,
                bool realism = false, bool clip_to_box = true) {
  cv::setNumThreads(1);
  RendererOptions o;
  o.ego.mode = EgoMotionMode::kPoses;
  o.realism.enabled = realism;  // drawing alone; BM_CarRealism adds the appearance measurement
  o.composite.clip_to_box = clip_to_box;
  HazardRenderer r(o, assets());
  Frame f;
  f.image = background();
  f.camera = camera();
  int64_t k = 0;
  auto frame = [&] {
    f.index = k;
    f.timestamp = 0.04 * static_cast<double>(k);
    f.ego.T_world_ego = planar_pose(10.0 * f.timestamp, 0.0, 0.0);
    ++k;
    return r.render(f, traj, {});
  };
  // The first frame prepares the appearance (the sprite's picture at that size, the scene's light): drawn
  // once before the timed loop, so that a case the library runs for few iterations times frames, not that
  // set-up.
  benchmark::DoNotOptimize(frame().frame.image.data);
  double composite = 0, realism_s = 0;
  int64_t timed = 0;
  for (auto _ : state) {
    auto res = frame();
    composite += res.composite_seconds;
    realism_s += res.realism_seconds;
    benchmark::DoNotOptimize(res.frame.image.data);
    ++timed;
  }
  state.counters["composite_ms"] = benchmark::Counter(1e3 * composite / static_cast<double>(timed));
  state.counters["realism_ms"] = benchmark::Counter(1e3 * realism_s / static_cast<double>(timed));
}

void BM_PassThrough(benchmark::State& state) {
  run_frames(state, nullptr);
}
BENCHMARK(BM_PassThrough)->Unit(benchmark::kMillisecond);

void BM_Car(benchmark::State& state) {
  run_frames(state, weaving("car", static_cast<double>(state.range(0))));
}
BENCHMARK(BM_Car)->Arg(8)->Arg(15)->Arg(30)->Arg(60)->Unit(benchmark::kMillisecond);

// The same without keeping the silhouette to the projected box: what that step costs.
void BM_CarUnclipped(benchmark::State& state) {
  run_frames(state, weaving("car", static_cast<double>(state.range(0))), false, false);
}
BENCHMARK(BM_CarUnclipped)->Arg(8)->Arg(15)->Unit(benchmark::kMillisecond);

// The same with the realism measurement of the drawn car (hazardforge/realism) on: its cost on top of
// drawing.
void BM_CarRealism(benchmark::State& state) {
  run_frames(state, weaving("car", static_cast<double>(state.range(0))), true);
}
BENCHMARK(BM_CarRealism)->Arg(8)->Arg(15)->Arg(30)->Unit(benchmark::kMillisecond);

void BM_Person(benchmark::State& state) {
  run_frames(state, weaving("person", static_cast<double>(state.range(0))));
}
BENCHMARK(BM_Person)->Arg(6)->Arg(15)->Unit(benchmark::kMillisecond);

}  // namespace

HF_BENCHMARK_MAIN();
