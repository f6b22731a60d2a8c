// Appearances cut from the recording itself (hazardforge/assets/footage_harvest.hpp).
#include "hazardforge/assets/footage_harvest.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "hazardforge/angles.hpp"
#include "hazardforge/assets/box_geometry.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/number_text.hpp"
#include "hazardforge/realism/matting.hpp"
#include "hazardforge/realism/metrics.hpp"

namespace hf::render {

namespace fs = std::filesystem;

namespace {

constexpr int kNormSize = 64;          // silhouettes are compared at this size
constexpr double kSnapDeg = 25.0;      // a heading this close to the road's direction is taken along it
constexpr double kLaneHalfWidth = 2.0;  // a standing vehicle this close sideways is queued in the ego's lane
constexpr double kMinSizeRatio = 0.6, kMaxSizeRatio = 1.6;  // measured height over the class's typical one
constexpr double kMinWidthRatio = 0.75, kMaxWidthRatio = 1.3;  // the same for the width (seen head-on)
constexpr double kHeadOnDeg = 12.0;      // within this of straight behind or ahead, the box's width is the object's
constexpr double kMaxTurnDeg = 45.0;     // two cuts of one track whose directions differ more disagree

cv::Rect whole_pixels(const cv::Rect2f& b) {
  const int x0 = static_cast<int>(std::floor(b.x)), y0 = static_cast<int>(std::floor(b.y));
  const int x1 = static_cast<int>(std::ceil(b.x + b.width)), y1 = static_cast<int>(std::ceil(b.y + b.height));
  return {x0, y0, x1 - x0, y1 - y0};
}

double mask_iou(const cv::Mat& a, const cv::Mat& b) {
  const double inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni > 0 ? inter / uni : 0.0;
}

std::string short_view_reason(double yaw) {
  const double deg = rad_to_deg(wrap_angle(yaw));
  return num_text(deg, 0) + " deg from the ego's heading";
}

// The cut-out as a BGRA picture of `pic` (crop coordinates): alpha matted around the hard mask's edge (a band
// of `band` px), colour decontaminated; the blurred mask when matting is off or fails.
cv::Mat cut_picture(const cv::Mat& crop_img, const cv::Mat& mask, const cv::Rect& pic, int band, bool matting) {
  cv::Mat alpha;
  if (matting) {
    try {
      alpha = realism::matte(crop_img, realism::trimap_from_mask(mask, band));
    } catch (const Error&) {
      alpha.release();
    }
  }
  if (alpha.empty()) cv::GaussianBlur(mask, alpha, cv::Size(), 0.7);
  const cv::Mat colour = realism::decontaminate(crop_img, alpha);
  std::vector<cv::Mat> ch;
  cv::split(colour(pic), ch);
  ch.push_back(alpha(pic).clone());
  cv::Mat bgra;
  cv::merge(ch, bgra);
  return bgra;
}

}  // namespace

std::vector<FootageObject> footage_objects(const ObjectStates* states, const Tracks* tracks) {
  std::vector<FootageObject> out;
  if (!states) return out;
  for (const ObjectState& s : states->objects) {
    FootageObject o;
    o.track_id = s.track_id;
    o.label = s.label;
    o.box = s.box;
    o.score = s.score;
    o.hits = s.age;
    o.misses = s.misses;
    o.truncated = s.truncated;
    if (std::isfinite(s.distance_m)) o.distance_m = s.distance_m + states->distance_origin_x;
    o.lateral_m = s.lateral_m;
    o.heading_rad = s.heading_rad;
    o.speed_mps = s.speed_mps;
    if (tracks)
      for (const Track& t : tracks->items)
        if (t.id == s.track_id) {
          o.hits = t.hits;
          o.misses = std::max(o.misses, t.misses);
        }
    out.push_back(std::move(o));
  }
  return out;
}

std::optional<BoxCut> cut_from_box(const cv::Mat& bgr, const cv::Rect2f& box, bool person, int iterations) {
  const cv::Rect img(0, 0, bgr.cols, bgr.rows);
  const cv::Rect b = whole_pixels(box) & img;
  if (b.width < 4 || b.height < 4) return std::nullopt;
  const int margin = std::max(8, static_cast<int>(0.25 * std::max(b.width, b.height)));
  BoxCut out;
  out.crop = cv::Rect(b.x - margin, b.y - margin, b.width + 2 * margin, b.height + 2 * margin) & img;
  const cv::Rect in_crop = b - out.crop.tl();
  cv::Mat mask(out.crop.size(), CV_8U, cv::Scalar(cv::GC_BGD));
  mask(in_crop).setTo(cv::GC_PR_FGD);
  // The core: almost surely the object whatever its outline.
  const cv::Point c(in_crop.x + in_crop.width / 2, in_crop.y + in_crop.height / 2);
  if (person)
    cv::rectangle(mask,
                  cv::Rect(c.x - std::max(1, in_crop.width / 8), in_crop.y + in_crop.height / 6,
                           std::max(2, in_crop.width / 4), in_crop.height * 2 / 3),
                  cv::Scalar(cv::GC_FGD), cv::FILLED);
  else
    cv::ellipse(mask, cv::Point(c.x, in_crop.y + in_crop.height * 11 / 20),
                cv::Size(std::max(1, in_crop.width * 3 / 10), std::max(1, in_crop.height / 4)), 0, 0, 360,
                cv::Scalar(cv::GC_FGD), cv::FILLED);
  cv::Mat bgd, fgd;
  try {
    cv::grabCut(bgr(out.crop), mask, cv::Rect(), bgd, fgd, iterations, cv::GC_INIT_WITH_MASK);
  } catch (const cv::Exception&) {
    return std::nullopt;
  }
  cv::Mat fg = (mask == cv::GC_FGD) | (mask == cv::GC_PR_FGD);
  cv::morphologyEx(fg, fg, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_ELLIPSE, {3, 3}));
  out.mask = realism::largest_component(fg);
  out.fill = cv::countNonZero(out.mask(in_crop)) / std::max(1.0, static_cast<double>(in_crop.area()));
  const cv::Rect mb = cv::boundingRect(out.mask);
  const double inter = (mb & in_crop).area(), uni = mb.area() + in_crop.area() - inter;
  out.box_iou = uni > 0 ? inter / uni : 0.0;
  return out;
}

ViewHeading view_heading(const FootageObject& o, bool person, const FootageHarvestOptions& opt) {
  ViewHeading v;
  const double min_speed = person ? opt.min_person_speed_mps : opt.min_vehicle_speed_mps;
  if (o.heading_rad && o.speed_mps && std::isfinite(*o.heading_rad) && *o.speed_mps >= min_speed) {
    double yaw = wrap_angle(*o.heading_rad);
    std::string along;
    if (std::abs(rad_to_deg(yaw)) < kSnapDeg) {
      yaw = 0.0;
      along = ", taken as the ego's direction";
    } else if (std::abs(rad_to_deg(wrap_angle(yaw - kPi))) < kSnapDeg) {
      yaw = kPi;
      along = ", taken as the opposite direction";
    }
    v.yaw = yaw;
    v.why = "moving at " + num_text(*o.speed_mps, 1) + " m/s " + short_view_reason(*o.heading_rad) + along;
    return v;
  }
  if (!person && std::isfinite(o.distance_m) && std::abs(o.lateral_m) < kLaneHalfWidth) {
    v.yaw = 0.0;
    v.why = "standing in the ego's lane, taken as facing the ego's way (queued traffic)";
    return v;
  }
  v.why = person ? "standing still: which way the person faces is unknown"
                 : "standing still beside the ego's lane: which way it faces is unknown";
  return v;
}

FootageHarvest::FootageHarvest(FootageHarvestOptions o, ClassPriors sizes)
    : opt_(std::move(o)), sizes_(std::move(sizes)) {}

void FootageHarvest::offer(const Frame& f, const std::vector<FootageObject>& objects) {
  if (f.image.empty() || f.image.type() != CV_8UC3 || !f.camera.valid()) return;
  const auto t0 = std::chrono::steady_clock::now();
  const CameraModel& cam = f.camera;
  struct Candidate {
    const FootageObject* o;
    double yaw;
    std::string view_why;
  };
  std::vector<Candidate> cands;
  for (const FootageObject& o : objects) {
    if (std::find(opt_.classes.begin(), opt_.classes.end(), o.label) == opt_.classes.end()) continue;
    ++candidates_;
    const bool person = o.label == "person";
    if (o.misses > 0) {
      reject("not matched in this frame");
      continue;
    }
    if (o.hits < opt_.min_track_hits) {
      reject("its track too young");
      continue;
    }
    if (o.score < opt_.min_score) {
      reject("weak detection");
      continue;
    }
    if (o.truncated || truncation_flags(o.box, f.image.size(), opt_.border_margin_px)) {
      reject("cut by the picture's border");
      continue;
    }
    if (o.box.height < opt_.min_height_px) {
      reject("too small");
      continue;
    }
    if (!std::isfinite(o.distance_m)) {
      reject("no range");
      continue;
    }
    if (o.distance_m > opt_.max_distance_m) {
      reject("too far");
      continue;
    }
    const auto it = tracks_.find(o.track_id);
    if (it != tracks_.end() && f.index - it->second.last_frame < opt_.every_frames) continue;
    bool hidden = false;
    for (const FootageObject& p : objects) {
      if (&p == &o) continue;
      const double share = (p.box & o.box).area() / std::max(1.0f, o.box.area());
      const bool nearer = p.box.y + p.box.height > o.box.y + o.box.height;
      if ((nearer && share > opt_.max_overlap) || share > 0.25) hidden = true;
    }
    if (hidden) {
      reject("hidden in part by another object");
      continue;
    }
    const ViewHeading vh = view_heading(o, person, opt_);
    if (!vh.yaw) {
      reject(vh.why);
      continue;
    }
    cands.push_back({&o, *vh.yaw, vh.why});
  }
  std::sort(cands.begin(), cands.end(),
            [](const Candidate& a, const Candidate& b) { return a.o->box.height > b.o->box.height; });
  if (static_cast<int>(cands.size()) > opt_.max_cuts_per_frame)
    cands.resize(static_cast<size_t>(opt_.max_cuts_per_frame));
  if (cands.empty()) {
    seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return;
  }
  cv::Mat gray;
  cv::cvtColor(f.image, gray, cv::COLOR_BGR2GRAY);
  const double frame_sharpness = std::max(1e-6, realism::laplacian_variance(gray));
  const cv::Rect img(0, 0, f.image.cols, f.image.rows);

  for (const Candidate& c : cands) {
    const FootageObject& o = *c.o;
    const bool person = o.label == "person";
    const cv::Rect b = whole_pixels(o.box) & img;
    const double sharp = realism::laplacian_variance(gray(b)) / frame_sharpness;
    if (sharp < opt_.min_sharpness) {
      reject("blurred");
      continue;
    }
    // Size for its range (camera model): the near face's depth, the box's height (and width when the view
    // is head-on) in metres; a size far from the class's typical one means the range or the box is off.
    const ClassSize prior = sizes_.has(o.label) ? sizes_.at(o.label) : ClassSize{};
    const double extent_x = std::abs(prior.length * std::cos(c.yaw)) + std::abs(prior.width * std::sin(c.yaw));
    const double x_c = o.distance_m + extent_x / 2;
    const double z_cam = cam.ego_to_cam(cv::Vec3d(o.distance_m, o.lateral_m, prior.height / 2))[2];
    const double az = camera_azimuth_deg(cam.t_ego_cam, x_c, o.lateral_m, c.yaw);
    const bool head_on = angle_diff_deg(az, 0) < kHeadOnDeg || angle_diff_deg(az, 180) < kHeadOnDeg;
    cv::Vec3d size(prior.length, prior.width, prior.height);
    if (z_cam > 0.5) {
      size[2] = o.box.height * z_cam / cam.fy;
      if (head_on && !person) size[1] = o.box.width * z_cam / cam.fx;
    }
    if (size[2] < kMinSizeRatio * prior.height || size[2] > kMaxSizeRatio * prior.height ||
        size[1] < kMinWidthRatio * prior.width || size[1] > kMaxWidthRatio * prior.width) {
      reject("its size for its range is not a " + o.label + "'s");
      continue;
    }
    const auto proj = project_box(cam, box_corners(x_c, o.lateral_m, c.yaw, size), 0.3);
    if (!proj || proj->bounds.width < 1 || proj->bounds.height < 1) {
      reject("its box does not project");
      continue;
    }

    // A track already cut in this view at about this size is not cut again (the cost is grabCut and matting).
    TrackCuts& tc = tracks_[o.track_id];
    const std::string view = view_for_azimuth(az);
    if (std::any_of(tc.kept.begin(), tc.kept.end(), [&](const FootageCut& k) {
          return k.spec.view == view && k.spec.image_size.height * 1.15 >= o.box.height;
        }))
      continue;
    const auto cut = cut_from_box(f.image, o.box, person, opt_.grabcut_iterations);
    if (!cut) {
      reject("grabCut failed");
      continue;
    }
    if (cut->fill < (person ? opt_.min_person_fill : opt_.min_vehicle_fill)) {
      reject("the silhouette lost the object");
      continue;
    }
    if (cut->box_iou < opt_.min_box_iou) {
      reject("the silhouette disagrees with the box");
      continue;
    }
    // Silhouette consistency along the track: the cut, normalised to its box, against the track's last one.
    cv::Mat norm;
    cv::resize(cut->mask(b - cut->crop.tl()), norm, {kNormSize, kNormSize}, 0, 0, cv::INTER_NEAREST);
    const bool recent = f.index - tc.last_frame <= 4 * opt_.every_frames;
    const bool same_way = tc.last_yaw && rad_to_deg(std::abs(angle_diff(c.yaw, *tc.last_yaw))) <= kMaxTurnDeg;
    const double consistency =
        (recent && same_way && !tc.last_mask.empty()) ? mask_iou(norm, tc.last_mask) : 0.0;
    tc.last_mask = norm;
    tc.last_frame = f.index;
    tc.last_yaw = c.yaw;

    // The picture: the box plus a pixel; matted when the cut is kept (a confirmed pair).
    const cv::Rect pic = cv::Rect(b.x - 1, b.y - 1, b.width + 2, b.height + 2) & img;
    Pending pend;
    pend.crop_img = f.image(cut->crop).clone();
    pend.mask = cut->mask;
    pend.pic_in_crop = pic - cut->crop.tl();
    pend.band = std::max(1, static_cast<int>(std::lround(opt_.matting_band * o.box.height / 100.0)));
    FootageCut& fc = pend.cut;
    fc.track_id = o.track_id;
    fc.frame_index = f.index;
    AssetSpec& s = fc.spec;
    s.object_class = o.label;
    s.azimuth_deg = az;
    s.view = view_for_azimuth(az);
    s.size_lwh = size;
    s.image_size = pic.size();
    // The box's corners as projected, fitted to the detection's box (the box is what the picture shows; the
    // range only shapes the perspective).
    const cv::Point2d sc(o.box.width / proj->bounds.width, o.box.height / proj->bounds.height);
    auto fit = [&](const cv::Point2d& p) {
      return cv::Point2d(o.box.x + (p.x - proj->bounds.x) * sc.x - pic.x,
                         o.box.y + (p.y - proj->bounds.y) * sc.y - pic.y);
    };
    for (int k = 0; k < 8; ++k) s.box_corners_px[k] = fit(proj->px[k]);
    const auto anchor = project_point(cam, cv::Vec3d(x_c, o.lateral_m, 0.0));
    s.anchor_px = anchor ? fit(*anchor) : cv::Point2d(pic.width / 2.0, pic.height - 1.0);
    s.source = "footage";
    s.instance = "track " + std::to_string(o.track_id);
    s.origin = f.source_id + " frame " + std::to_string(f.index);
    s.file = "footage_" + o.label + "_" + s.view + "_t" + std::to_string(o.track_id) + "_f" +
             std::to_string(f.index) + ".png";
    fc.quality = o.box.height * cut->fill * std::min(sharp, 1.5) * std::max(consistency, 0.5);
    fc.why = "track " + std::to_string(o.track_id) + " (" + o.label + ") at frame " + std::to_string(f.index) +
             ": " + std::to_string(b.width) + "x" + std::to_string(b.height) + " px, whole and unhidden, " +
             "sharpness " + num_text(sharp, 2) + " of the picture's, the silhouette fills " +
             num_text(cut->fill, 2) + " of its box and matches the track's previous cut (IoU " +
             num_text(consistency, 2) + "); " + c.view_why + "; " + num_text(size[2], 2) + " m tall, " +
             num_text(size[1], 2) + " m wide at " + num_text(o.distance_m, 1) + " m: " + s.view + " view";
    if (consistency < opt_.min_consistency) {
      if (tc.pending)
        reject(recent && !same_way ? "its direction of travel changed between two cuts"
                                   : "the silhouette changed between two cuts of its track");
      tc.pending = std::move(pend);  // the first of a pair (or a new start): confirmed by the next cut
      continue;
    }
    auto keep = [&](const Pending& k) {
      auto same = std::find_if(tc.kept.begin(), tc.kept.end(),
                               [&](const FootageCut& e) { return e.spec.view == k.cut.spec.view; });
      if (same != tc.kept.end() && k.cut.quality <= same->quality) return;
      FootageCut done = k.cut;
      done.bgra = cut_picture(k.crop_img, k.mask, k.pic_in_crop, k.band, opt_.matting);
      if (same == tc.kept.end())
        tc.kept.push_back(std::move(done));
      else
        *same = std::move(done);
    };
    if (tc.pending) keep(*tc.pending);
    keep(pend);
    tc.pending = std::move(pend);
    ++tc.confirmations;
  }
  seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::vector<FootageCut> FootageHarvest::cuts() const {
  std::vector<FootageCut> out;
  for (const auto& [id, tc] : tracks_)
    for (const FootageCut& c : tc.kept) out.push_back(c);
  std::stable_sort(out.begin(), out.end(),
                   [](const FootageCut& a, const FootageCut& b) { return a.quality > b.quality; });
  return out;
}

std::vector<FootageCut> FootageHarvest::cuts_of(const std::string& object_class) const {
  std::vector<FootageCut> out = cuts();
  std::erase_if(out, [&](const FootageCut& c) { return c.spec.object_class != object_class; });
  return out;
}

std::string FootageHarvest::summary() const {
  const std::vector<FootageCut> all = cuts();
  std::map<std::string, int> per;
  for (const FootageCut& c : all) ++per[c.spec.object_class + " " + c.spec.view];
  std::string kept;
  for (const auto& [k, n] : per) kept += (kept.empty() ? "" : ", ") + std::to_string(n) + " " + k;
  std::string why;
  for (const auto& [reason, n] : rejected_) why += (why.empty() ? "" : ", ") + std::to_string(n) + " " + reason;
  return std::to_string(all.size()) + " appearances cut from the footage" + (kept.empty() ? "" : " (" + kept + ")") +
         " out of " + std::to_string(candidates_) + " object sightings" + (why.empty() ? "" : "; not kept: " + why);
}

int FootageHarvest::save(const fs::path& dir) const {
  const std::vector<FootageCut> all = cuts();
  if (all.empty()) return 0;
  fs::create_directories(dir);
  AssetIndex index;
  for (const FootageCut& c : all) {
    write_png_atomic(dir / c.spec.file, c.bgra);
    index.assets.push_back(c.spec);
  }
  save_asset_index(dir, index,
                   "HazardForge appearance assets cut from a recording's own tracked road users (footage harvest).");
  return static_cast<int>(all.size());
}

}  // namespace hf::render
