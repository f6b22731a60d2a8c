// KittiSource: KITTI tracking / raw frames, P2 intrinsics and tracking labels converted to the ego frame.
#include "kitti_source.hpp"

#include "hazardforge/image_file.hpp"

#include <fnmatch.h>

#include <algorithm>
#include <cmath>
#include <set>

#include <opencv2/imgcodecs.hpp>

#include "kitti_files.hpp"

namespace hf::source {

namespace fs = std::filesystem;

namespace {

const Json kDefaultLabelMap = {{"Car", "car"},
                               {"Van", "car"},
                               {"Truck", "truck"},
                               {"Pedestrian", "person"},
                               {"Person_sitting", "person"},
                               {"Cyclist", "bicycle"},
                               {"Tram", "bus"}};

// Frame number from a KITTI image name ("000010.png", "0000000042.png"); nullopt when not numeric.
std::optional<int> frame_number(const fs::path& p) {
  const std::string s = p.stem().string();
  if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
  return std::stoi(s);
}

std::vector<fs::path> list_images(const fs::path& folder, const std::string& pattern) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.is_regular_file() && fnmatch(pattern.c_str(), e.path().filename().c_str(), 0) == 0)
      files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

ComponentInfo KittiSource::describe() {
  ComponentInfo i =
      base_info("kitti", "KITTI tracking sequences or raw image folders with P2 intrinsics and labels");
  i.doc =
      "layout tracking: <root>/<split>/image_02/<sequence>/*.png, calib/<sequence>.txt, "
      "label_02/<sequence>.txt "
      "(when present). layout raw: `images` folder and a `calib` file in KITTI tracking format. With "
      "images_required false, frames run over every frame number up to the last label or image, and frames "
      "without an image carry a black image. Labels (DontCare dropped) become ego-frame annotations; "
      "velocities "
      "are camera-relative central differences of the same track id.";
  i.params = {
      ParamSpec::string("layout", "tracking").one_of({"tracking", "raw"}).describe("dataset layout"),
      ParamSpec::path("root", "${HAZARDFORGE_SHARED}/data/kitti-tracking").describe("tracking: dataset root"),
      ParamSpec::string("split", "training").one_of({"training", "testing"}).describe("tracking: split"),
      ParamSpec::string("sequence", "0000").describe("tracking: sequence number, 4 digits"),
      ParamSpec::path("images", "").describe("image folder (raw: required; tracking: overrides the default)"),
      ParamSpec::path("calib", "")
          .describe("calibration file (raw: required; tracking: overrides the default)"),
      ParamSpec::path("labels", "")
          .describe("label file in tracking format (tracking: overrides the default)"),
      ParamSpec::boolean("images_required", true)
          .describe("false: iterate over all frame numbers up to the last label/image, black frames where no "
                    "image"),
      ParamSpec::string("pattern", "*.png").describe("image file glob"),
      ParamSpec::number("fps", 10.0).range(0.001, 1000).describe("frame rate (KITTI: 10 Hz)"),
      ParamSpec::integer("image_width", 1242)
          .range(1, 16384)
          .describe("size of black frames when no image exists"),
      ParamSpec::integer("image_height", 375)
          .range(1, 16384)
          .describe("size of black frames when no image exists"),
      ParamSpec::number("camera_height", 1.65).range(0.1, 10).describe("camera height above the ground, m"),
      ParamSpec::number("camera_pitch_deg", 0.0)
          .range(-45, 45)
          .describe("downward pitch, deg (KITTI rectified: level)"),
      ParamSpec::number("camera_forward", 0.0)
          .range(-10, 10)
          .describe("camera position ahead of the ego origin, m"),
      ParamSpec::number("ego_speed_mps", -1.0)
          .range(-1, 100)
          .describe("constant ego speed, m/s (-1 = unknown)"),
      ParamSpec::number("max_velocity_dt", 0.2)
          .range(0.01, 100)
          .describe("max time to a neighbouring label of the same track for a velocity, s"),
      ParamSpec::object("label_map", kDefaultLabelMap)
          .describe("KITTI type -> project class; unmapped = empty label"),
      ParamSpec::boolean("annotations", true).describe("attach labels as annotations"),
      ParamSpec::integer("start_frame", 0)
          .range(0, std::nullopt)
          .describe("skip this many frames of the stream"),
      ParamSpec::integer("max_frames", -1).range(-1, std::nullopt).describe("frames to emit (-1 = all)"),
  };
  return i;
}

void KittiSource::open(StageContext& ctx) {
  const Params& p = ctx.params();
  layout_ = p.get_string("layout");
  fps_ = p.get_double("fps");
  const bool images_required = p.get_bool("images_required");
  fs::path images = p.get_path("images"), calib = p.get_path("calib"), labels = p.get_path("labels");
  if (layout_ == "tracking") {
    const std::string seq = p.get_string("sequence");
    const fs::path base = p.get_path("root") / p.get_string("split");
    if (images.empty()) images = base / "image_02" / seq;
    if (calib.empty()) calib = base / "calib" / (seq + ".txt");
    if (labels.empty() && fs::exists(base / "label_02" / (seq + ".txt")))
      labels = base / "label_02" / (seq + ".txt");
    scene_ = p.get_string("split") + " sequence " + seq;
  } else {
    if (images.empty()) throw Error("kitti source: layout 'raw' needs the 'images' folder");
    if (calib.empty()) throw Error("kitti source: layout 'raw' needs a 'calib' file");
    // A raw drive keeps its images in <drive>/image_02/data.
    const fs::path dir = fs::absolute(images).lexically_normal();
    scene_ = (dir.filename() == "data" && dir.has_parent_path() ? dir.parent_path().parent_path() : dir)
                 .filename()
                 .string();
  }
  const kitti::Calibration cal = kitti::read_calibration(calib);
  ctx.record_resource(calib);

  // Images by frame number.
  std::map<int, fs::path> image_of;
  if (fs::is_directory(images)) {
    int pos = 0;
    for (const fs::path& f : list_images(images, p.get_string("pattern"))) {
      // Numbered names give the frame; anything else counts in name order.
      const int n = frame_number(f).value_or(pos);
      image_of[n] = f;
      ++pos;
    }
  }
  if (images_required && image_of.empty())
    throw Error("KITTI image folder '" + images.string() + "' " +
                (fs::is_directory(images) ? "has no file matching '" + p.get_string("pattern") + "'"
                                          : "does not exist") +
                (labels.empty() ? "" : " (images_required: false iterates over the label frames)"));

  std::map<int, std::vector<kitti::Label>> by_frame;
  if (!labels.empty() && p.get_bool("annotations")) {
    by_frame = kitti::read_labels(labels);
    ctx.record_resource(labels);
  }

  // Camera: the image size comes from the first image, else the params.
  int w = static_cast<int>(p.get_int("image_width")), h = static_cast<int>(p.get_int("image_height"));
  if (!image_of.empty()) {
    const fs::path& first = image_of.begin()->second;
    cv::Mat probe = cv::imread(first.string(), cv::IMREAD_UNCHANGED);
    if (probe.empty()) throw Error("KITTI image '" + first.string() + "' cannot be read");
    w = probe.cols;
    h = probe.rows;
  }
  camera_ =
      CameraModel::pinhole(w, h, cal.fx(), cal.fy(), cal.cx(), cal.cy(), p.get_double("camera_height"),
                           p.get_double("camera_pitch_deg") * CV_PI / 180.0, p.get_double("camera_forward"));
  const double ego_speed = p.get_double("ego_speed_mps");
  if (ego_speed >= 0) ego_.speed_mps = ego_speed;
  const cv::Vec3d ego_velocity(std::max(ego_speed, 0.0), 0, 0);

  // Frame numbers to emit.
  std::vector<int> numbers;
  if (images_required) {
    for (const auto& [n, f] : image_of) numbers.push_back(n);
  } else {
    int last = -1;
    if (!image_of.empty()) last = image_of.rbegin()->first;
    if (!by_frame.empty()) last = std::max(last, by_frame.rbegin()->first);
    if (last < 0)
      throw Error("kitti source: neither images in '" + images.string() + "' nor labels to iterate over");
    for (int n = 0; n <= last; ++n) numbers.push_back(n);
  }

  // Label centres in the ego frame, per track, for the velocity differences.
  const cv::Vec3d t02 = cal.cam0_to_cam2();
  auto to_ego = [&](const kitti::Label& l) {
    // KITTI location is the bottom centre; camera y points down, so the centre is h/2 above it.
    const cv::Vec3d c0 = l.location - cv::Vec3d(0, l.h / 2, 0);
    return camera_.cam_to_ego(c0 + t02);
  };
  std::map<int, std::map<int, cv::Vec3d>> track_pos;  // track -> frame -> centre
  for (const auto& [n, ls] : by_frame)
    for (const auto& l : ls)
      if (l.type != "DontCare" && l.track_id >= 0) track_pos[l.track_id][n] = to_ego(l);
  const int max_gap =
      std::max(1, static_cast<int>(std::floor(p.get_double("max_velocity_dt") * fps_ + 1e-9)));
  const Json label_map = p.raw("label_map");
  for (auto it = label_map.begin(); it != label_map.end(); ++it)
    if (!it->is_string()) throw Error("parameter 'label_map': value of '" + it.key() + "' is not a string");

  for (int n : numbers) {
    Item item;
    item.kitti_frame = n;
    if (auto it = image_of.find(n); it != image_of.end()) item.image = it->second;
    if (!labels.empty() && p.get_bool("annotations")) {
      auto ann = std::make_shared<Annotations>();
      ann->ego_velocity_ego = ego_velocity;
      if (auto it = by_frame.find(n); it != by_frame.end()) {
        for (const kitti::Label& l : it->second) {
          if (l.type == "DontCare") continue;
          AnnotatedObject o;
          o.instance_id = std::to_string(l.track_id);
          o.category = l.type;
          o.label = label_map.contains(l.type) ? label_map[l.type].get<std::string>() : "";
          o.center_ego = to_ego(l);
          o.size_lwh = cv::Vec3d(l.l, l.w, l.h);
          // Heading rotation_y = 0 points along camera x; direction (cos ry, 0, -sin ry) in camera axes.
          const cv::Vec3d dir =
              camera_.R_ego_cam * cv::Vec3d(std::cos(l.rotation_y), 0, -std::sin(l.rotation_y));
          o.yaw_ego = std::atan2(dir[1], dir[0]);
          o.box2d = l.box2d;
          // KITTI's occlusion state (0 fully visible, 1 partly, 2 largely occluded, 3 unknown) as a hidden
          // share.
          o.occlusion = l.occluded <= 0 ? 0.0 : l.occluded == 1 ? 0.4 : l.occluded == 2 ? 0.8 : 1.0;
          const auto& tp = track_pos[l.track_id];
          auto prev = tp.lower_bound(n);  // == n
          auto next = std::next(prev);
          const bool has_prev = prev != tp.begin() && n - std::prev(prev)->first <= max_gap;
          const bool has_next = next != tp.end() && next->first - n <= max_gap;
          if (has_prev || has_next) {
            const auto a = has_prev ? std::prev(prev) : prev, b = has_next ? next : prev;
            const double dt = (b->first - a->first) / fps_;
            // Relative velocity plus the (known or zero) ego velocity, so velocity_ego - ego_velocity_ego is
            // exactly the camera-relative velocity TTC needs.
            o.velocity_ego = (b->second - a->second) * (1.0 / dt) + ego_velocity;
          }
          ann->objects.push_back(std::move(o));
        }
      }
      item.annotations = std::move(ann);
    }
    items_.push_back(std::move(item));
  }
  const auto start = static_cast<size_t>(p.get_int("start_frame"));
  for (size_t k = start; k < items_.size(); ++k) frames_.push_back(k);
  if (const long long m = p.get_int("max_frames"); m >= 0 && static_cast<size_t>(m) < frames_.size())
    frames_.resize(static_cast<size_t>(m));
  if (frames_.empty()) throw Error("kitti source: no frames to emit from '" + images.string() + "'");
  ctx.log(LogLevel::kInfo, "KITTI " + layout_ + ": " + std::to_string(frames_.size()) + " frames, " +
                               std::to_string(image_of.size()) + " images" +
                               (labels.empty() ? std::string() : ", labels " + labels.string()));
}

bool KittiSource::next(StageContext& /*ctx*/, Outputs& out) {
  if (pos_ >= frames_.size()) return false;
  const Item& it = items_[frames_[pos_]];
  const int first = items_[frames_.front()].kitti_frame;
  Frame f;
  f.index = static_cast<int64_t>(pos_);
  f.timestamp = (it.kitti_frame - first) / fps_;
  if (!it.image.empty()) {
    f.image = read_color_image(
        it.image, "KITTI image '" + it.image.string() + "' (frame " + std::to_string(it.kitti_frame) + ")");
    if (f.image.cols != camera_.width || f.image.rows != camera_.height)
      throw Error("KITTI image '" + it.image.string() + "' is " + std::to_string(f.image.cols) + "x" +
                  std::to_string(f.image.rows) + " but the sequence started at " +
                  std::to_string(camera_.width) + "x" + std::to_string(camera_.height));
    f.source_id = it.image.filename().string();
  } else {
    f.image = cv::Mat(camera_.height, camera_.width, CV_8UC3, cv::Scalar::all(0));
    f.source_id = "frame " + std::to_string(it.kitti_frame);
  }
  f.camera = camera_;
  f.ego = ego_;
  f.annotations = it.annotations;
  f.origin.dataset = "kitti";
  f.origin.scene = scene_;
  f.origin.dataset_frame = it.kitti_frame;
  f.meta = {{"layout", layout_},
            {"has_image", !it.image.empty()},
            {"velocity_reference", ego_.speed_mps ? "ego_speed_param" : "camera"}};
  const double ts = f.timestamp;
  out.emit_packet("frames", Packet::make<Frame>(std::move(f), ts));
  ++pos_;
  return true;
}
}  // namespace hf::source
