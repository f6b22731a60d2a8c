// Detector benchmark: bare net.forward() and whole detect (pre + forward + post) per model and input size.
// "Time" is wall time (for forward/: net.forward() alone, timed by YoloDetector::time_forward); "CPU" is the
// CPU time of the whole process (all OpenCV threads; for forward/ it includes the per-iteration letterbox),
// which a busy shared machine inflates far less than wall time.
//
//   bench_detector [--image=PATH] [--threads=N] [--benchmark_repetitions=N ...]
//
// Uses $HAZARDFORGE_SHARED (else the discovered shared folder) for the models and the default image.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <cstring>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "hazardforge/params.hpp"
#include "hazardforge/process_memory.hpp"
#include "yolo_detector.hpp"

namespace {

struct ModelCase {
  std::string name;
  std::string file;  // below <shared>/models
  int w, h;          // 0 = from the file name
};

const std::vector<ModelCase> kCases = {
    {"yolov8n_640x384", "yolov8n/yolov8n_deq_640x384.onnx", 0, 0},
    {"yolov8n_640x640", "yolov8n/yolov8n_deq_640x640.onnx", 0, 0},
    {"yolox_nano_416x416", "yolox_nano/yolox_nano.onnx", 416, 416},
    {"yolox_nano_640x384", "yolox_nano/yolox_nano.onnx", 640, 384},
    {"yolox_nano_640x640", "yolox_nano/yolox_nano.onnx", 640, 640},
};

}  // namespace

int main(int argc, char** argv) {
  hf::keep_freed_memory_for_reuse();  // the host's allocator policy
  benchmark::Initialize(&argc, argv);
  const std::string shared = hf::shared_root();
  std::string image_path = shared + "/data/udacity-highway/test_images/test1.jpg";
  int threads = 2;
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--image=", 8) == 0) {
      image_path = argv[i] + 8;
    } else if (std::strncmp(argv[i], "--threads=", 10) == 0) {
      threads = std::atoi(argv[i] + 10);
    } else {
      std::cerr << "bench_detector: unknown argument '" << argv[i] << "'\n";
      return 2;
    }
  }
  const cv::Mat image = cv::imread(image_path);
  if (image.empty()) {
    std::cerr << "bench_detector: cannot read image '" << image_path << "'\n";
    return 1;
  }
  benchmark::AddCustomContext(
      "image", image_path + " (" + std::to_string(image.cols) + "x" + std::to_string(image.rows) + ")");
  benchmark::AddCustomContext("cv_threads", std::to_string(threads));

  std::vector<std::shared_ptr<hf::YoloDetector>> detectors;
  try {
    for (const ModelCase& c : kCases) {
      auto d = std::make_shared<hf::YoloDetector>();
      hf::YoloDetector::Config cfg;
      cfg.model = shared + "/models/" + c.file;
      cfg.input_width = c.w;
      cfg.input_height = c.h;
      cfg.threads = threads;
      d->load(cfg);
      detectors.push_back(d);
      // Bare network time: net.forward() on a prepared blob, timed by the detector itself.
      benchmark::RegisterBenchmark(("forward/" + c.name).c_str(),
                                   [d, &image](benchmark::State& st) {
                                     for (auto _ : st) st.SetIterationTime(d->time_forward(image));
                                   })
          ->UseManualTime()
          ->MeasureProcessCPUTime()
          ->Unit(benchmark::kMillisecond)
          ->Iterations(10);
      // What the stage costs per frame: letterbox + blob, forward, decode + NMS.
      benchmark::RegisterBenchmark(("detect/" + c.name).c_str(),
                                   [d, &image](benchmark::State& st) {
                                     size_t n = 0;
                                     for (auto _ : st) n += d->detect_image(image).size();
                                     st.counters["detections"] = static_cast<double>(n) / st.iterations();
                                   })
          ->MeasureProcessCPUTime()
          ->Unit(benchmark::kMillisecond)
          ->Iterations(10);
    }
  } catch (const std::exception& e) {
    std::cerr << "bench_detector: " << e.what() << "\n";
    return 1;
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
