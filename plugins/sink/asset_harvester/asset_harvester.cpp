// The asset_harvester sink: projects annotated 3D boxes, keeps well-visible objects, cuts them out with
// grabCut.
#include "asset_harvester.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <opencv2/imgproc.hpp>

#include "hazardforge/assets/box_geometry.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/realism/matting.hpp"

namespace hf::render {

namespace fs = std::filesystem;

namespace {

std::string short_token(const std::string& s) {
  std::string out;
  for (char c : s)
    if (std::isalnum(static_cast<unsigned char>(c))) out += c;
  return out.substr(0, 8);
}

// Bounding box of the corners that are in front of the camera (for occluders partly behind it).
std::optional<cv::Rect2d> visible_bounds(const CameraModel& cam, const BoxCorners& corners) {
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  int n = 0;
  for (const auto& c : corners) {
    if (cam.ego_to_cam(c)[2] < 0.3) continue;
    auto p = project_point(cam, c);
    if (!p) continue;
    x0 = std::min(x0, p->x);
    y0 = std::min(y0, p->y);
    x1 = std::max(x1, p->x);
    y1 = std::max(y1, p->y);
    ++n;
  }
  if (n == 0) return std::nullopt;
  return cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
}

// Corner lists of the box faces turned towards the camera: vertical faces whose outward normal points at it,
// and the top when the camera is above it.
std::vector<std::array<int, 4>> camera_facing_faces(const CameraModel& cam, const BoxCorners& c) {
  std::vector<std::array<int, 4>> out;
  const cv::Vec3d centre = (c[0] + c[2]) * 0.5;
  for (Face f : {Face::kFront, Face::kRear, Face::kLeft, Face::kRight}) {
    const auto idx = face_corners(f);
    const cv::Vec3d fc = (c[idx[0]] + c[idx[1]]) * 0.5;
    cv::Vec3d n = fc - centre;
    n[2] = 0;
    if (n.dot(cam.t_ego_cam - fc) > 0) out.push_back(idx);
  }
  if (cam.t_ego_cam[2] > c[4][2]) out.push_back({4, 5, 6, 7});
  return out;
}

// The matte may extend a little past the faces (soft edges), never onto the road around them.
cv::Mat grown_faces_for_alpha(const cv::Mat& faces_grown) {
  cv::Mat out;
  cv::dilate(faces_grown, out, cv::getStructuringElement(cv::MORPH_ELLIPSE, {5, 5}));
  return out;
}

}  // namespace

ComponentInfo AssetHarvester::describe() {
  ComponentInfo i;
  i.name = "asset_harvester";
  i.kind = kind::kSink;
  i.summary = "cuts real object appearances (with alpha) out of annotated frames into an asset folder";
  i.doc =
      "Projects each annotated 3D box with the frame's camera, keeps objects that are fully in view, large, "
      "near, "
      "well covered by lidar/radar points and not overlapped by a nearer annotated object, cuts them out "
      "with "
      "grabCut initialised from the projected box (rejecting cuts whose extent disagrees with the projected "
      "faces), "
      "refines the edge by information-flow matting and colour decontamination, classifies the view from the "
      "object's yaw relative to the "
      "camera, and writes PNGs with alpha plus assets.yaml (the format of share/assets) when the stream "
      "ends.";
  i.inputs = {port<Frame>("frames", "frames with annotations (3D boxes in the ego frame)")};
  i.params = {
      ParamSpec::string("out_dir", "assets")
          .describe("asset folder to write; relative = below the run's output folder"),
      ParamSpec::string_list("classes", {"car", "truck", "bus", "person"})
          .describe("project labels to harvest"),
      ParamSpec::integer("min_points", 20)
          .range(-1, std::nullopt)
          .describe("fewest lidar+radar points in the box (objects with unknown counts pass)"),
      ParamSpec::integer("min_height_px", 60)
          .range(8, std::nullopt)
          .describe("smallest projected box height"),
      ParamSpec::integer("min_width_px", 24).range(4, std::nullopt).describe("smallest projected box width"),
      ParamSpec::integer("border_margin_px", 4)
          .range(0, 200)
          .describe("the box must stay this far from the border"),
      ParamSpec::number("max_distance_m", 40.0).range(1.0, 500.0).describe("farthest object harvested"),
      ParamSpec::number("max_occlusion", 0.2)
          .range(0.0, 1.0)
          .describe("largest hidden share the dataset gives the object (nuScenes: its visibility bin)"),
      ParamSpec::number("max_overlap", 0.05)
          .range(0.0, 1.0)
          .describe("largest share of the box covered by nearer annotated objects"),
      ParamSpec::integer("grabcut_iterations", 5).range(1, 20).describe("grabCut iterations"),
      ParamSpec::number("min_fill", 0.35)
          .range(0.0, 1.0)
          .describe("smallest mask area / projected hull area (below = the cut failed)"),
      ParamSpec::number("min_box_iou", 0.7)
          .range(0.0, 1.0)
          .describe(
              "smallest IoU of the cut's bounding box with the projected faces' box (below = rejected: the "
              "mask disagrees with the annotation)"),
      ParamSpec::boolean("matting", true)
          .describe("soft alpha by information-flow matting (OpenCV alphamat) around grabCut's edge"),
      ParamSpec::number("matting_band", 2.0)
          .range(0.5, 10.0)
          .describe("half-width of the matting's unknown band, % of the box height (at least 1 px)"),
      ParamSpec::boolean("decontaminate", true)
          .describe("remove the old background's colour from the soft edge (colour decontamination)"),
      ParamSpec::integer("per_instance_view", 1)
          .range(1, 100)
          .describe("cuts kept per object instance and view"),
      ParamSpec::boolean("append", true).describe("keep the assets already listed in out_dir/assets.yaml"),
  };
  return i;
}

void AssetHarvester::open(StageContext& ctx) {
  const Params& p = ctx.params();
  out_dir_ = p.get_string("out_dir");
  if (out_dir_.empty()) throw Error("out_dir is empty");
  if (out_dir_.is_relative()) out_dir_ = ctx.output_dir() / out_dir_;
  classes_ = p.get_strings("classes");
  min_points_ = static_cast<int>(p.get_int("min_points"));
  min_h_ = static_cast<int>(p.get_int("min_height_px"));
  min_w_ = static_cast<int>(p.get_int("min_width_px"));
  border_ = static_cast<int>(p.get_int("border_margin_px"));
  max_distance_ = p.get_double("max_distance_m");
  max_occlusion_ = p.get_double("max_occlusion");
  max_overlap_ = p.get_double("max_overlap");
  iterations_ = static_cast<int>(p.get_int("grabcut_iterations"));
  min_fill_ = p.get_double("min_fill");
  min_box_iou_ = p.get_double("min_box_iou");
  matting_ = p.get_bool("matting");
  matting_band_ = p.get_double("matting_band");
  decontaminate_ = p.get_bool("decontaminate");
  per_view_ = static_cast<int>(p.get_int("per_instance_view"));
  append_ = p.get_bool("append");
}

void AssetHarvester::process(StageContext& /*ctx*/, const Inputs& in, Outputs& /*out*/) {
  const Frame& f = in.require<Frame>("frames");
  ++frames_;
  if (!f.annotations) return;
  ++frames_with_annotations_;
  const std::string fname = "frame " + std::to_string(f.index) + " (" + f.source_id + ")";
  if (f.image.empty() || f.image.type() != CV_8UC3) throw Error(fname + ": expected a BGR 8-bit image");
  if (!f.camera.valid() || f.camera.width != f.image.cols || f.camera.height != f.image.rows)
    throw Error(fname + ": the camera model does not match the " + std::to_string(f.image.cols) + "x" +
                std::to_string(f.image.rows) + " image");
  const CameraModel& cam = f.camera;
  const auto& objs = f.annotations->objects;
  std::vector<BoxCorners> corners(objs.size());
  std::vector<double> depth(objs.size());
  for (size_t i = 0; i < objs.size(); ++i) {
    const auto& o = objs[i];
    corners[i] = box_corners(o.center_ego[0], o.center_ego[1], o.yaw_ego, o.size_lwh,
                             o.center_ego[2] - o.size_lwh[2] / 2);
    depth[i] = cam.ego_to_cam(o.center_ego)[2];
  }
  const cv::Rect2d img(0, 0, f.image.cols, f.image.rows);
  for (size_t i = 0; i < objs.size(); ++i) {
    const AnnotatedObject& o = objs[i];
    if (std::find(classes_.begin(), classes_.end(), o.label) == classes_.end()) continue;
    ++objects_;
    auto reject = [&](const char* why) { ++rejected_[why]; };
    if (depth[i] <= 0) {
      reject("behind the camera");
      continue;
    }
    if (std::hypot(o.center_ego[0] - cam.t_ego_cam[0], o.center_ego[1] - cam.t_ego_cam[1]) > max_distance_) {
      reject("too far");
      continue;
    }
    if (min_points_ >= 0 && o.num_points >= 0 && o.num_points < min_points_) {
      reject("too few lidar/radar points");
      continue;
    }
    if (o.occlusion > max_occlusion_) {
      reject("flagged occluded");
      continue;
    }
    auto pb = project_box(cam, corners[i], 0.5);
    if (!pb) {
      reject("partly behind the camera");
      continue;
    }
    const cv::Rect2d b = pb->bounds;
    if (b.x < border_ || b.y < border_ || b.x + b.width > img.width - border_ ||
        b.y + b.height > img.height - border_) {
      reject("clipped by the image border");
      continue;
    }
    if (b.height < min_h_ || b.width < min_w_) {
      reject("too small");
      continue;
    }
    double covered = 0;
    for (size_t j = 0; j < objs.size() && covered <= max_overlap_; ++j) {
      if (j == i || depth[j] <= 0 || depth[j] >= depth[i]) continue;
      if (auto ob = visible_bounds(cam, corners[j])) covered = std::max(covered, (*ob & b).area() / b.area());
    }
    if (covered > max_overlap_) {
      reject("overlapped by a nearer object");
      continue;
    }

    // grabCut on a crop around the box: outside the projected box is background, inside the box's hull
    // probably foreground, the rest of the box probably background.
    const double ctx_px = std::max(8.0, 0.25 * std::max(b.width, b.height));
    const cv::Rect crop =
        cv::Rect(static_cast<int>(b.x - ctx_px), static_cast<int>(b.y - ctx_px),
                 static_cast<int>(b.width + 2 * ctx_px), static_cast<int>(b.height + 2 * ctx_px)) &
        cv::Rect(0, 0, f.image.cols, f.image.rows);
    cv::Mat mask(crop.size(), CV_8U, cv::Scalar(cv::GC_BGD));
    const cv::Rect box_in_crop =
        cv::Rect(static_cast<int>(std::floor(b.x)) - crop.x - 1,
                 static_cast<int>(std::floor(b.y)) - crop.y - 1, static_cast<int>(std::ceil(b.width)) + 3,
                 static_cast<int>(std::ceil(b.height)) + 3) &
        cv::Rect(0, 0, crop.width, crop.height);
    mask(box_in_crop).setTo(cv::GC_PR_BGD);
    std::vector<cv::Point2f> pts;
    for (const auto& p : pb->px)
      pts.emplace_back(static_cast<float>(p.x - crop.x), static_cast<float>(p.y - crop.y));
    std::vector<cv::Point2f> hull_f;
    cv::convexHull(pts, hull_f);
    std::vector<cv::Point> hull;
    for (const auto& p : hull_f) hull.emplace_back(cvRound(p.x), cvRound(p.y));
    cv::Mat hull_mask(crop.size(), CV_8U, cv::Scalar(0));
    cv::fillConvexPoly(hull_mask, hull, cv::Scalar(255));
    // Probably foreground: the faces the camera sees (the footprint on the road is not part of the object).
    cv::Mat faces_mask(crop.size(), CV_8U, cv::Scalar(0));
    for (const auto& face : camera_facing_faces(cam, corners[i])) {
      std::vector<cv::Point> poly;
      for (int k : face) poly.emplace_back(cvRound(pb->px[k].x - crop.x), cvRound(pb->px[k].y - crop.y));
      cv::fillConvexPoly(faces_mask, poly, cv::Scalar(255));
    }
    mask.setTo(cv::GC_PR_FGD, faces_mask);
    cv::Mat bgd, fgd;
    cv::Mat crop_img = f.image(crop).clone();
    try {
      cv::grabCut(crop_img, mask, cv::Rect(), bgd, fgd, iterations_, cv::GC_INIT_WITH_MASK);
    } catch (const cv::Exception&) {
      reject("grabCut failed");
      continue;
    }
    cv::Mat fg = ((mask == cv::GC_FGD) | (mask == cv::GC_PR_FGD));
    cv::Mat faces_grown;
    cv::dilate(faces_mask, faces_grown, cv::getStructuringElement(cv::MORPH_ELLIPSE, {5, 5}));
    fg &= faces_grown;
    cv::morphologyEx(fg, fg, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_ELLIPSE, {3, 3}));
    fg = realism::largest_component(fg);
    const double fill =
        cv::countNonZero(fg) / std::max(1.0, static_cast<double>(cv::countNonZero(hull_mask)));
    if (fill < min_fill_) {
      reject("cut too small (grabCut lost the object)");
      continue;
    }
    // The silhouette must span the faces the annotation projects: a cut that lost a side of the object, or
    // took in a neighbour, disagrees with the projected box.
    {
      const cv::Rect mb = cv::boundingRect(fg), fb = cv::boundingRect(faces_mask);
      const double inter = (mb & fb).area(), uni = mb.area() + fb.area() - inter;
      if (uni <= 0 || inter / uni < min_box_iou_) {
        reject("mask disagrees with the projected box");
        continue;
      }
    }

    // The picture: the projected box (plus a pixel). Alpha: information-flow matting in a band around
    // grabCut's edge (soft, no halo of the old background); colour: decontaminated at the edge, so what shows
    // through the soft alpha is the object's colour and not the street it stood on.
    const cv::Rect pic =
        cv::Rect(static_cast<int>(std::floor(b.x)) - 1, static_cast<int>(std::floor(b.y)) - 1,
                 static_cast<int>(std::ceil(b.width)) + 3, static_cast<int>(std::ceil(b.height)) + 3) &
        cv::Rect(0, 0, f.image.cols, f.image.rows);
    cv::Mat alpha_crop;
    if (matting_) {
      const int band = std::max(1, static_cast<int>(std::lround(matting_band_ * b.height / 100.0)));
      try {
        alpha_crop = realism::matte(crop_img, realism::trimap_from_mask(fg, band));
        ++matted_;
      } catch (const Error&) {
        alpha_crop.release();
      }
    }
    if (alpha_crop.empty()) cv::GaussianBlur(fg, alpha_crop, cv::Size(), 0.7);
    alpha_crop &= grown_faces_for_alpha(faces_grown);
    const cv::Mat colour = decontaminate_ ? realism::decontaminate(crop_img, alpha_crop) : crop_img;
    std::vector<cv::Mat> ch;
    cv::split(colour(pic - crop.tl()), ch);
    ch.push_back(alpha_crop(pic - crop.tl()).clone());
    cv::Mat bgra;
    cv::merge(ch, bgra);

    Cut cut;
    AssetSpec& s = cut.spec;
    s.object_class = o.label;
    s.azimuth_deg = camera_azimuth_deg(cam.t_ego_cam, o.center_ego[0], o.center_ego[1], o.yaw_ego);
    s.view = view_for_azimuth(s.azimuth_deg);
    s.size_lwh = o.size_lwh;
    s.image_size = pic.size();
    const cv::Vec3d bottom(o.center_ego[0], o.center_ego[1], o.center_ego[2] - o.size_lwh[2] / 2);
    const auto anchor = project_point(cam, bottom);
    s.anchor_px = anchor ? *anchor - cv::Point2d(pic.tl()) : cv::Point2d(pic.width / 2.0, pic.height);
    for (int k = 0; k < 8; ++k) s.box_corners_px[k] = pb->px[k] - cv::Point2d(pic.tl());
    s.source = "harvested";
    s.instance = o.instance_id.empty() ? f.source_id + "#" + std::to_string(i) : o.instance_id;
    s.origin = f.source_id + " frame " + std::to_string(f.index);
    s.file = s.object_class + "_" + s.view + "_" + short_token(s.instance) + "_f" + std::to_string(f.index) +
             ".png";
    cut.bgra = bgra;
    cut.quality = b.height * fill;
    auto& list = cuts_[s.instance + "/" + s.view];
    list.push_back(std::move(cut));
    std::sort(list.begin(), list.end(), [](const Cut& a, const Cut& c) { return a.quality > c.quality; });
    if (static_cast<int>(list.size()) > per_view_) list.resize(static_cast<size_t>(per_view_));
  }
}

void AssetHarvester::finish(StageContext& ctx, Outputs& /*out*/) {
  if (frames_ > 0 && frames_with_annotations_ == 0)
    throw Error(
        "asset_harvester: none of the " + std::to_string(frames_) +
        " frames carried annotations; the source must attach them (e.g. nuscenes with annotations: true)");
  AssetIndex index;
  std::set<std::string> new_files;
  for (const auto& [key, list] : cuts_)
    for (const Cut& c : list) new_files.insert(c.spec.file);
  if (append_ && fs::exists(out_dir_ / kAssetIndexFile))
    for (const AssetSpec& s : load_asset_index(out_dir_).assets)
      if (!new_files.count(s.file)) index.assets.push_back(s);
  int written = 0;
  for (const auto& [key, list] : cuts_)
    for (const Cut& c : list) {
      write_png_atomic(out_dir_ / c.spec.file, c.bgra);
      index.assets.push_back(c.spec);
      ++written;
    }
  std::sort(index.assets.begin(), index.assets.end(),
            [](const AssetSpec& a, const AssetSpec& b) { return a.file < b.file; });
  save_asset_index(out_dir_, index,
                   "HazardForge appearance assets harvested from annotated frames (asset_harvester).");
  std::string why;
  for (const auto& [reason, n] : rejected_)
    why += (why.empty() ? "" : ", ") + std::to_string(n) + " " + reason;
  ctx.log(LogLevel::kInfo, "asset_harvester: " + std::to_string(written) + " pictures from " +
                               std::to_string(objects_) + " candidate objects in " + std::to_string(frames_) +
                               " frames written to " + out_dir_.string() + " (" + std::to_string(matted_) +
                               " candidate edges matted)" + (why.empty() ? "" : "; skipped: " + why));
}

}  // namespace hf::render
