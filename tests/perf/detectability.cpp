// How often an off-the-shelf detector finds the inserted object: hazards of each class are composited into
// nuScenes keyframes at several distances and headings, YOLO runs on the augmented frames, and an insertion
// counts as found when a detection of its class overlaps the inserted box with IoU >= 0.5. Placements whose
// box already overlaps a real detection of that class in the original frame are skipped, so real objects are
// not counted.
//
// The table also says which label the best-overlapping detection has: for cars, how often YOLO calls the
// inserted car `car` rather than `truck`/`bus` (the monocular estimator uses the label's height prior, so a
// car labelled truck is placed about twice as far away).
//
//   hf_ar_renderer_detectability [--assets DIR] [--frames N] [--class car|person] [--save DIR] [--yolox]
//   (needs $HAZARDFORGE_SHARED; --save writes every augmented frame with the inserted box and the best
//   detection;
//   --yolox asks the independent detector, YOLOX-Nano at 640x384, instead of YOLOv8n)
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ar_renderer.hpp"
#include "hazardforge/geometry.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "nuscenes_source.hpp"
#include "yolo_detector.hpp"

namespace {

using namespace hf;
using namespace hf::render;
namespace fs = std::filesystem;

bool same_class(const std::string& hazard, const std::string& label) {
  if (hazard == "person") return label == "person";
  return label == "car" || label == "truck" || label == "bus";
}

}  // namespace

int main(int argc, char** argv) {
  fs::path assets, save;
  int n_frames = 6;
  bool yolox = false;
  std::vector<std::string> classes = {"car", "person"};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--assets" && i + 1 < argc) {
      assets = argv[++i];
    } else if (a == "--frames" && i + 1 < argc) {
      n_frames = std::atoi(argv[++i]);
    } else if (a == "--save" && i + 1 < argc) {
      save = argv[++i];
    } else if (a == "--class" && i + 1 < argc) {
      classes = {argv[++i]};
    } else if (a == "--yolox") {
      yolox = true;
    } else {
      std::cerr << "usage: hf_ar_renderer_detectability [--assets DIR] [--frames N] [--class car|person] "
                   "[--save DIR] "
                   "[--yolox]\n";
      return 2;
    }
  }
  try {
    const std::string shared = shared_root();
    if (shared.empty()) throw Error("set HAZARDFORGE_SHARED to the shared data folder");
    auto src = testing::StageRunner::create<source::NuScenesSource>("dataroot: " + shared +
                                                                    "/data/nuscenes\nscenes: [scene-0916]");
    src.run();
    const auto frames = src.collect<Frame>("frames");
    // The verifier's detector (YOLOv8n) or the independent one the verification reports beside it
    // (YOLOX-Nano).
    auto yolo = testing::StageRunner::create<YoloDetector>(
        yolox ? "model: " + shared + "/models/yolox_nano/yolox_nano.onnx\ninput_width: 640\ninput_height: 384"
              : "model: " + shared + "/models/yolov8n/yolov8n_deq_640x384.onnx\nconf_threshold: 0.3");
    double clock = 0;  // the harness wants increasing timestamps
    auto detect = [&](const Frame& f) {
      yolo.push("frames", f, clock += 1.0);
      yolo.run(false);
      return yolo.outputs("detections").back().get<Detections>();
    };
    const fs::path defaults = fs::path(share_dir()) / "assets";
    auto lib = std::make_shared<const AssetLibrary>(
        AssetLibrary::load(assets.empty() ? defaults : assets, assets.empty() ? fs::path() : defaults));
    struct Cell {
      int tried = 0, found = 0, exact = 0;  // exact: found with the class's own label (car, not truck/bus)
      double iou_sum = 0;
    };
    std::map<std::string, Cell> table;
    // Away, away turned in by 20 degrees (a car changing lanes ahead), oncoming, crossing.
    const double headings[4] = {0.0, -0.35, CV_PI, CV_PI / 2};
    const char* heading_names[4] = {"away", "away-20", "oncoming", "crossing"};
    for (int fi = 0; fi < n_frames; ++fi) {
      const Frame& f = frames[static_cast<size_t>(fi) * (frames.size() - 1) / std::max(1, n_frames - 1)];
      const Detections original = detect(f);
      for (const std::string& cls : classes)
        for (double dist : {8.0, 12.0, 20.0, 30.0, 40.0})
          for (int h = 0; h < 4; ++h) {
            HazardTrajectory t;
            t.kind = "detectability";
            t.object_class = cls;
            t.size_lwh = cls == "person" ? cv::Vec3d(0.5, 0.6, 1.7) : cv::Vec3d(4.5, 1.85, 1.52);
            t.anchor_time = f.timestamp;
            // `dist` is the range from the camera to the object's near face, as a detection's distance_m is:
            // the object's centre (in the ego frame, from the rear axle) lies its half extent along the line
            // of sight beyond that.
            const double half_depth = t.size_lwh[0] / 2 * std::abs(std::cos(headings[h])) +
                                      t.size_lwh[1] / 2 * std::abs(std::sin(headings[h]));
            const double x = f.camera.t_ego_cam[0] + dist + half_depth;
            t.points = {{f.timestamp - 1, x, 0.5, headings[h], 0, 0},
                        {f.timestamp + 1, x, 0.5, headings[h], 0, 0}};
            RendererOptions o;
            o.ego.mode = EgoMotionMode::kPoses;
            HazardRenderer r(o, lib);
            const auto res = r.render(f, std::make_shared<const HazardTrajectory>(t), {});
            if (!res.hazard.visible) continue;
            bool real = false;
            for (const auto& d : original.items)
              real |= same_class(cls, d.label) && hf::box_iou(d.box, res.hazard.box) > 0.3;
            if (real) continue;
            Frame aug = f;
            aug.image = res.frame.image;
            double best = 0;
            std::string best_label;
            cv::Rect2f best_box;
            for (const auto& d : detect(aug).items)
              if (same_class(cls, d.label) && hf::box_iou(d.box, res.hazard.box) > best) {
                best = hf::box_iou(d.box, res.hazard.box);
                best_label = d.label;
                best_box = d.box;
              }
            char key[64];
            std::snprintf(key, sizeof key, "%-6s %-8s %4.0f m", cls.c_str(), heading_names[h], dist);
            if (!save.empty()) {
              fs::create_directories(save);
              cv::Mat img = aug.image.clone();
              cv::rectangle(img, res.hazard.box, cv::Scalar(0, 255, 0), 2);
              if (best > 0) {
                cv::rectangle(img, best_box, cv::Scalar(0, 0, 255), 2);
                cv::putText(img, best_label, best_box.tl() + cv::Point2f(4, 24), cv::FONT_HERSHEY_SIMPLEX,
                            0.9, cv::Scalar(0, 0, 255), 2);
              }
              char name[96];
              std::snprintf(name, sizeof name, "f%03lld_%s_%s_%02.0fm.png", static_cast<long long>(f.index),
                            cls.c_str(), heading_names[h], dist);
              cv::resize(img, img, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
              cv::imwrite((save / name).string(), img);
            }
            Cell& c = table[key];
            ++c.tried;
            c.found += best >= 0.5;
            c.exact += best >= 0.5 && best_label == cls;
            c.iou_sum += best;
          }
      std::cerr << "frame " << f.index << " done\n";
    }
    std::printf(
        "| class | heading | camera to near face | insertions | found (IoU >= 0.5) | labelled as its class | "
        "mean best IoU "
        "|\n|---|---|---:|---:|---:|---:|---:|\n");
    int tried = 0, found = 0, exact = 0;
    for (const auto& [k, c] : table) {
      char cls[8], head[10];
      double d = 0;
      std::sscanf(k.c_str(), "%7s %9s %lf", cls, head, &d);
      std::printf("| %s | %s | %.0f m | %d | %d | %d | %.2f |\n", cls, head, d, c.tried, c.found, c.exact,
                  c.iou_sum / c.tried);
      tried += c.tried;
      found += c.found;
      exact += c.exact;
    }
    std::printf("| all | | | %d | %d (%.0f %%) | %d (%.0f %%) | |\n", tried, found,
                tried ? 100.0 * found / tried : 0.0, exact, tried ? 100.0 * exact / tried : 0.0);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "hf_ar_renderer_detectability: " << e.what() << "\n";
    return 1;
  }
}
