// hazardforge export: the scenario packages' augmented frames and labels as KITTI tracking or COCO datasets.
#include "hazardforge/apps/dataset_export.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "hazardforge/apps/scenarios.hpp"
#include "hazardforge/atomic_file.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/image_file.hpp"
#include "hazardforge/json_text.hpp"

namespace hf::apps {

namespace fs = std::filesystem;

namespace {

std::string seq_name(size_t i) {
  char b[32];
  std::snprintf(b, sizeof b, "%04zu", i);
  return b;
}
std::string frame_name6(size_t i) {
  char b[32];
  std::snprintf(b, sizeof b, "%06zu", i);
  return b;
}
std::string g(double v) {
  char b[48];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

// KITTI's object types for the project's classes (KITTI has no bus: Misc).
std::string kitti_type(const std::string& label) {
  if (label == "car") return "Car";
  if (label == "truck") return "Truck";
  if (label == "person") return "Pedestrian";
  if (label == "bicycle" || label == "motorcycle") return "Cyclist";
  return "Misc";
}
// KITTI's occlusion states from the hidden share: fully visible, partly, largely.
int kitti_occluded(double hidden) {
  return hidden < 0.2 ? 0 : hidden < 0.5 ? 1 : 2;
}
// The tracking benchmark's truncation levels (integers, unlike the object benchmark's fraction) from the
// share outside the picture: inside, partly out, largely out.
int kitti_truncated(double out) {
  return out < 0.01 ? 0 : out < 0.5 ? 1 : 2;
}

// The labelled objects of a frame: the inserted one while it shows, then the recording's.
std::vector<const scenario::LabelledObject*> labels_of(const scenario::PackageFrame& f) {
  std::vector<const scenario::LabelledObject*> out;
  if (f.hazard && f.hazard->visible && f.hazard->box.area() > 0) out.push_back(&*f.hazard);
  for (const auto& o : f.objects)
    if (o.box.area() > 0) out.push_back(&o);
  return out;
}

void export_kitti(const std::vector<Scenario>& scenarios, const fs::path& out) {
  const fs::path train = out / "training";
  std::string seqs;
  size_t labels = 0;
  for (size_t s = 0; s < scenarios.size(); ++s) {
    const Scenario& sc = scenarios[s];
    const std::string S = seq_name(s);
    fs::create_directories(train / "image_02" / S);
    fs::create_directories(train / "label_02");
    fs::create_directories(train / "calib");
    fs::create_directories(train / "ttc_02");
    std::ostringstream lab, ttc, frames;
    for (size_t k = 0; k < sc.pkg.frames.size(); ++k) {
      const auto& f = sc.pkg.frames[k];
      const fs::path src = sc.pkg.picture(f, true);
      const cv::Mat img = read_color_image(src, "scenario picture '" + src.string() + "'");
      const fs::path dst = train / "image_02" / S / (frame_name6(k) + ".png");
      if (!cv::imwrite(dst.string(), img)) throw Error("cannot write '" + dst.string() + "'");
      frames << k << " " << f.frame << " " << g(f.timestamp) << "\n";
      for (const auto* o : labels_of(f)) {
        // 0-based pixel coordinates: the last column and row are width - 1 and height - 1.
        const double left = o->box.x, top = o->box.y;
        const double right = std::min<double>(o->box.x + o->box.width, img.cols - 1);
        const double bottom = std::min<double>(o->box.y + o->box.height, img.rows - 1);
        const std::string box = g(left) + " " + g(top) + " " + g(right) + " " + g(bottom);
        lab << k << " " << o->track_id << " " << kitti_type(o->label) << " " << kitti_truncated(o->truncation)
            << " " << kitti_occluded(o->occlusion) << " ";
        if (o->box3d) {
          const auto& d = *o->box3d;
          lab << g(scenario::observation_angle(d)) << " " << box << " " << g(d.dimensions_hwl[0]) << " "
              << g(d.dimensions_hwl[1]) << " " << g(d.dimensions_hwl[2]) << " " << g(d.location_cam[0]) << " "
              << g(d.location_cam[1]) << " " << g(d.location_cam[2]) << " " << g(d.rotation_y) << "\n";
        } else {  // KITTI's values for an unknown 3D box
          lab << "-10 " << box << " -1 -1 -1 -1000 -1000 -1000 -10\n";
        }
        ttc << k << " " << o->track_id << " " << (o->ttc_s ? g(*o->ttc_s) : std::string("nan")) << "\n";
        ++labels;
      }
    }
    write_file_atomic(train / "label_02" / (S + ".txt"), lab.str());
    write_file_atomic(train / "ttc_02" / (S + ".txt"), ttc.str());
    fs::create_directories(train / "frames_02");
    write_file_atomic(train / "frames_02" / (S + ".txt"), frames.str());
    // Calibration: every camera is this one (P = [K | 0]); the "velodyne" frame is the ego frame.
    const CameraModel& cam = sc.pkg.frames.front().camera;
    std::ostringstream c;
    const std::string P =
        g(cam.fx) + " 0 " + g(cam.cx) + " 0 0 " + g(cam.fy) + " " + g(cam.cy) + " 0 0 0 1 0";
    for (int i = 0; i < 4; ++i) c << "P" << i << ": " << P << "\n";
    c << "R_rect 1 0 0 0 1 0 0 0 1\n";
    const cv::Matx33d R = cam.R_ego_cam.t();
    const cv::Vec3d t = -(R * cam.t_ego_cam);
    c << "Tr_velo_cam";
    for (int r = 0; r < 3; ++r)
      c << " " << g(R(r, 0)) << " " << g(R(r, 1)) << " " << g(R(r, 2)) << " " << g(t[r]);
    c << "\nTr_imu_velo 1 0 0 0 0 1 0 0 0 0 1 0\n";
    write_file_atomic(train / "calib" / (S + ".txt"), c.str());
    seqs += S + " " + sc.id + " " + sc.pkg.header.kind + " " + sc.pkg.header.object_class + "\n";
  }
  write_file_atomic(out / "sequences.txt", seqs);
  std::cerr << "export: " << scenarios.size() << " sequences, " << labels
            << " labels in KITTI tracking format in " << out.string() << "\n";
}

void export_coco(const std::vector<Scenario>& scenarios, const fs::path& out) {
  static const std::map<std::string, int> ids = {{"person", 1},     {"bicycle", 2}, {"car", 3},
                                                 {"motorcycle", 4}, {"bus", 6},     {"truck", 8}};
  fs::create_directories(out / "images");
  Json images = Json::array(), anns = Json::array(), cats = Json::array();
  for (const auto& [name, id] : ids)
    cats.push_back({{"id", id}, {"name", name}, {"supercategory", name == "person" ? "person" : "vehicle"}});
  std::sort(cats.begin(), cats.end(), [](const Json& a, const Json& b) { return a["id"] < b["id"]; });
  int64_t image_id = 0, ann_id = 0;
  for (size_t s = 0; s < scenarios.size(); ++s) {
    const Scenario& sc = scenarios[s];
    for (size_t k = 0; k < sc.pkg.frames.size(); ++k) {
      const auto& f = sc.pkg.frames[k];
      const std::string file = seq_name(s) + "_" + frame_name6(k) + ".jpg";
      const fs::path src = sc.pkg.picture(f, true);
      const fs::path dst = out / "images" / file;
      if (src.extension() == ".jpg") {
        fs::copy_file(src, dst, fs::copy_options::overwrite_existing);
      } else {
        const cv::Mat img = read_color_image(src, "scenario picture '" + src.string() + "'");
        if (!cv::imwrite(dst.string(), img, {cv::IMWRITE_JPEG_QUALITY, 95}))
          throw Error("cannot write '" + dst.string() + "'");
      }
      ++image_id;
      images.push_back({{"id", image_id},
                        {"file_name", file},
                        {"width", f.camera.width},
                        {"height", f.camera.height},
                        {"sequence", seq_name(s)},
                        {"scenario", sc.id},
                        {"frame", f.frame},
                        {"timestamp", f.timestamp}});
      for (const auto* o : labels_of(f)) {
        const auto it = ids.find(o->label);
        if (it == ids.end()) continue;
        const cv::Rect2f b = o->box;
        Json a = {{"id", ++ann_id},
                  {"image_id", image_id},
                  {"category_id", it->second},
                  {"bbox", {b.x, b.y, b.width, b.height}},
                  {"area", static_cast<double>(b.width) * b.height},
                  {"segmentation", Json::array({Json::array({b.x, b.y, b.x + b.width, b.y, b.x + b.width,
                                                             b.y + b.height, b.x, b.y + b.height})})},
                  {"iscrowd", 0},
                  {"track_id", o->track_id},
                  {"inserted", o->inserted},
                  {"ttc_s", o->ttc_s ? Json(*o->ttc_s) : Json()},
                  {"truncation", o->truncation},
                  {"occlusion", o->occlusion}};
        if (o->box3d) {
          a["location_cam"] = {o->box3d->location_cam[0], o->box3d->location_cam[1],
                               o->box3d->location_cam[2]};
          a["dimensions_hwl"] = {o->box3d->dimensions_hwl[0], o->box3d->dimensions_hwl[1],
                                 o->box3d->dimensions_hwl[2]};
          a["rotation_y"] = o->box3d->rotation_y;
        }
        anns.push_back(std::move(a));
      }
    }
  }
  const Json doc = {{"info",
                     {{"description", "HazardForge verified scenarios: augmented frames and their labels"},
                      {"version", "1"}}},
                    {"licenses", Json::array()},
                    {"categories", cats},
                    {"images", images},
                    {"annotations", anns}};
  write_file_atomic(out / "annotations.json", json_text(doc) + "\n");
  std::cerr << "export: " << images.size() << " images, " << anns.size() << " annotations in COCO format in "
            << out.string() << "\n";
}

}  // namespace

int cmd_export(const ExportOptions& o) {
  if (o.format != "kitti-tracking" && o.format != "coco") {
    std::cerr << "export: --format must be kitti-tracking or coco, not '" << o.format << "'\n";
    return 2;
  }
  const fs::path out = fs::absolute(o.output_dir);
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_empty(out, ec)) {
    std::cerr << "export: '" << out.string() << "' is not empty; give a new folder\n";
    return 2;
  }
  try {
    const std::vector<Scenario> scenarios = find_scenarios(o.scenarios);
    if (scenarios.empty()) {
      std::cerr << "export: no scenario to export\n";
      return 2;
    }
    fs::create_directories(out);
    if (o.format == "kitti-tracking")
      export_kitti(scenarios, out);
    else
      export_coco(scenarios, out);
  } catch (const Error& e) {
    std::cerr << "export: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace hf::apps
