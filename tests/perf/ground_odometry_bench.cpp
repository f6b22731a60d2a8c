// Cost of the ground_odometry stage per 1600x900 frame (Google Benchmark): the footage kit's ground-plane
// odometry on a rendered road (asphalt noise, dashed lane lines) driven at 20 m/s, at 25 and 10 frames/s.
// Single OpenCV thread, so the numbers are one core's work.
//
//   build/bin/hf_ground_odometry_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "ground_odometry_stage.hpp"
#include "hazardforge/testing/benchmark_main.hpp"
#include "synthetic_road.hpp"

namespace {

using namespace hf;

// The stage's frame step as it runs it (GroundOdometry::add); each sequence of 12 frames restarts the
// odometry (the restart and the first frame, which has nothing to compare with, are not timed).
void BM_GroundOdometry(benchmark::State& state) {
  cv::setNumThreads(1);
  const double fps = static_cast<double>(state.range(0));
  const CameraModel cam = CameraModel::pinhole(1600, 900, 1266, 1266, 800, 450, 1.5, 0.02, 1.5);
  std::vector<cv::Mat> frames;
  for (int k = 0; k < 12; ++k)
    frames.push_back(test::road::render(cam, test::road::pose_at(k / fps, 20.0, 0.0)));
  std::unique_ptr<footage::GroundOdometry> odo;
  auto restart = [&] {
    odo = std::make_unique<footage::GroundOdometry>(cam, footage::OdometryOptions{});
    odo->add(frames[0], 0, 0.0);
  };
  restart();
  int64_t k = 1, n = 0, measured = 0;
  for (auto _ : state) {
    if (k == static_cast<int64_t>(frames.size())) {
      state.PauseTiming();
      restart();
      k = 1;
      state.ResumeTiming();
    }
    const auto s = odo->add(frames[static_cast<size_t>(k)], k, static_cast<double>(k) / fps);
    ++k;
    measured += s.measured ? 1 : 0;
    ++n;
  }
  state.counters["measured"] = benchmark::Counter(static_cast<double>(measured) / static_cast<double>(n));
}
BENCHMARK(BM_GroundOdometry)->Arg(25)->Arg(10)->Unit(benchmark::kMillisecond);

}  // namespace

HF_BENCHMARK_MAIN();
