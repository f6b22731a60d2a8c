// The scenario package sink: pictures as frames arrive, labels at the end.
#include "scenario_package_sink.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>

#include "hazardforge/assets/box_geometry.hpp"
#include "hazardforge/atomic_file.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/json_text.hpp"
#include "hazardforge/output_path.hpp"

namespace hf::sinks {

namespace fs = std::filesystem;

ComponentInfo ScenarioPackageSink::describe() {
  ComponentInfo i;
  i.name = "scenario_package";
  i.kind = kind::kSink;
  i.summary = "the augmented and original frames with the labels of the inserted object (scenario/)";
  i.doc =
      "Writes what a test of a system and a dataset export need from a hazard run into one folder: every "
      "frame as a picture before and after augmentation, and per frame (frames.jsonl) the camera, the ego's "
      "speed and yaw rate, and the labels: the inserted object's drawn box, truncation, occlusion, 3D box in "
      "the camera's axes (KITTI conventions) and in the ego frame, and its ground-truth TTC; the recording's "
      "own objects where the dataset annotates them. Read by the scenario source, hazardforge test and "
      "hazardforge export (docs/testing-a-system.md).";
  i.inputs = {port<Frame>("original", "frames before augmentation"),
              port<Frame>("augmented", "the same frames after augmentation"),
              port<HazardInstance>("hazard", "where the inserted object is")};
  i.params = {
      ParamSpec::string("folder", "scenario").describe("the package's folder, below the run's output folder"),
      ParamSpec::string("image_format", "jpg").one_of({"jpg", "png"}).describe("the pictures' format"),
      ParamSpec::integer("jpeg_quality", 95).range(50, 100).describe("JPEG quality of the pictures"),
  };
  return i;
}

void ScenarioPackageSink::open(StageContext& ctx) {
  dir_ = output_param_path(ctx, "folder", true);
  ext_ = ctx.params().get_string("image_format");
  jpeg_quality_ = static_cast<int>(ctx.params().get_int("jpeg_quality"));
  header_.image_format = ext_;
  fs::create_directories(dir_ / "augmented");
  fs::create_directories(dir_ / "original");
}

std::vector<scenario::LabelledObject> ScenarioPackageSink::recorded_objects(const Frame& f) {
  std::vector<scenario::LabelledObject> out;
  if (!f.annotations) return out;
  const cv::Rect2d img(0, 0, f.image.cols, f.image.rows);
  for (const AnnotatedObject& a : f.annotations->objects) {
    if (a.label.empty()) continue;
    scenario::LabelledObject o;
    o.label = a.label;
    o.instance_id = a.instance_id;
    o.occlusion = std::clamp(a.occlusion, 0.0, 1.0);
    const double z_bottom = a.center_ego[2] - a.size_lwh[2] / 2;
    const auto corners =
        render::box_corners(a.center_ego[0], a.center_ego[1], a.yaw_ego, a.size_lwh, z_bottom);
    const auto proj = render::project_box(f.camera, corners, 0.3);
    if (!proj) continue;  // (part of) it is behind the camera
    const cv::Rect2d full = a.box2d ? *a.box2d : proj->bounds;
    const cv::Rect2d in = full & img;
    if (in.area() <= 0 || full.area() <= 0) continue;
    o.box = cv::Rect2f(in);
    o.truncation = std::clamp(1.0 - in.area() / full.area(), 0.0, 1.0);
    o.visible = true;
    o.box3d = scenario::box3d(f.camera, cv::Vec3d(a.center_ego[0], a.center_ego[1], z_bottom), a.yaw_ego,
                              a.size_lwh);
    o.distance_m = a.center_ego[0];
    auto [it, added] = track_ids_.try_emplace(
        a.instance_id.empty() ? "#" + std::to_string(track_ids_.size()) : a.instance_id,
        static_cast<int64_t>(track_ids_.size()) + 1);
    o.track_id = it->second;
    out.push_back(std::move(o));
  }
  return out;
}

void ScenarioPackageSink::process(StageContext& /*ctx*/, const Inputs& in, Outputs& /*out*/) {
  const Frame& orig = in.require<Frame>("original");
  const Frame& aug = in.require<Frame>("augmented");
  const HazardInstance& hz = in.require<HazardInstance>("hazard");
  if (orig.image.empty() || aug.image.empty() || orig.image.size() != aug.image.size())
    throw Error(frame_name(orig) + ": the original and augmented frames must both have pictures of one size");
  char name[32];
  std::snprintf(name, sizeof name, "%06lld.", static_cast<long long>(orig.index));
  const std::string file = name + ext_;
  const std::vector<int> opts =
      ext_ == "jpg" ? std::vector<int>{cv::IMWRITE_JPEG_QUALITY, jpeg_quality_} : std::vector<int>{};
  for (const auto& [sub, img] : {std::pair<const char*, const cv::Mat*>{"augmented", &aug.image},
                                 std::pair<const char*, const cv::Mat*>{"original", &orig.image}}) {
    const fs::path p = dir_ / sub / file;
    if (!cv::imwrite(p.string(), *img, opts))
      throw Error(frame_name(orig) + ": cannot write '" + p.string() + "'");
  }
  scenario::PackageFrame pf;
  pf.frame = orig.index;
  pf.timestamp = orig.timestamp;
  pf.augmented = "augmented/" + file;
  pf.original = "original/" + file;
  pf.camera = orig.camera;
  pf.ego_speed_mps = orig.ego.speed_mps;
  pf.ego_yaw_rate = orig.ego.yaw_rate;
  if (header_.origin.dataset.empty() && header_.origin.scene.empty()) header_.origin = orig.origin;
  if (std::isfinite(hz.distance_m)) {
    scenario::LabelledObject o;
    o.track_id = 0;
    o.label = hz.object_class;
    o.inserted = true;
    o.kind = hz.kind;
    o.visible = hz.visible && hz.drawn_box.area() > 0;
    o.box = hz.drawn_box.area() > 0 ? hz.drawn_box : hz.box;
    o.truncation = std::clamp(1.0 - hz.in_picture_fraction, 0.0, 1.0);
    o.occlusion = std::clamp(hz.occluded_fraction, 0.0, 1.0);
    o.distance_m = hz.distance_m;
    if (std::isfinite(hz.intended_ttc_s)) o.ttc_s = hz.intended_ttc_s;
    if (std::isfinite(hz.heading_ego))
      o.box3d = scenario::box3d(orig.camera, hz.centre_ego, hz.heading_ego, hz.size_lwh);
    pf.hazard = std::move(o);
    if (header_.kind.empty()) {
      header_.kind = hz.kind;
      header_.object_class = hz.object_class;
    }
  }
  pf.objects = recorded_objects(orig);
  frames_.push_back(std::move(pf));
}

void ScenarioPackageSink::finish(StageContext& /*ctx*/, Outputs& /*out*/) {
  std::string lines;
  for (const auto& f : frames_) lines += json_text(scenario::to_json(f)) + "\n";
  write_file_atomic(dir_ / "frames.jsonl", lines);
  header_.frames = static_cast<int64_t>(frames_.size());
  write_file_atomic(dir_ / "scenario.json", json_text(scenario::to_json(header_), 2) + "\n");
}

}  // namespace hf::sinks
