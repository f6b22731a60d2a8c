// The ar_renderer stage: places a planned hazard in each frame from the ego motion and composites its
// picture.
#include "ar_renderer.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include "hazardforge/assets/box_geometry.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/number_text.hpp"
#include "hazardforge/geometry.hpp"
#include "hazardforge/realism/compare.hpp"
#include "hazardforge/realism/metrics.hpp"

namespace hf::render {

namespace fs = std::filesystem;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

cv::Vec3d transform(const cv::Matx44d& T, const cv::Vec3d& p) {
  return {T(0, 0) * p[0] + T(0, 1) * p[1] + T(0, 2) * p[2] + T(0, 3),
          T(1, 0) * p[0] + T(1, 1) * p[1] + T(1, 2) * p[2] + T(1, 3),
          T(2, 0) * p[0] + T(2, 1) * p[1] + T(2, 2) * p[2] + T(2, 3)};
}

cv::Vec3d rotate(const cv::Matx44d& T, const cv::Vec3d& v) {
  return {T(0, 0) * v[0] + T(0, 1) * v[1] + T(0, 2) * v[2], T(1, 0) * v[0] + T(1, 1) * v[1] + T(1, 2) * v[2],
          T(2, 0) * v[0] + T(2, 1) * v[1] + T(2, 2) * v[2]};
}

}  // namespace

HazardRenderer::HazardRenderer(RendererOptions o, std::shared_ptr<const AssetLibrary> assets)
    : opt_(o), assets_(std::move(assets)), ego_(o.ego) {
  if (opt_.footage) {
    ClassPriors sizes = opt_.vehicle_sizes;
    if (sizes.all().empty()) sizes = ClassPriors::load(share_dir() + "/class_sizes.yaml");
    harvest_ = std::make_unique<FootageHarvest>(opt_.footage_harvest, std::move(sizes));
    if (!opt_.footage_bank.empty() && fs::exists(opt_.footage_bank / kAssetIndexFile)) {
      const AssetLibrary bank = AssetLibrary::load(opt_.footage_bank);
      for (size_t i = 0; i < bank.specs().size(); ++i) {
        FootageCut c;
        c.spec = bank.specs()[i];
        c.bgra = bank.picture(i);
        c.folder = opt_.footage_bank;
        c.spec.instance = "scouted " + c.spec.instance;  // that pass's track numbers are not this run's
        c.why = "cut from this recording by the scouting pass (" + c.spec.origin + ", " + c.spec.view + " view, " +
                num_text(c.spec.size_lwh[2], 2) + " m tall)";
        bank_.push_back(std::move(c));
      }
    }
  }
}

std::vector<std::string> HazardRenderer::take_notes() {
  std::vector<std::string> n;
  n.swap(notes_);
  return n;
}

double HazardRenderer::observe(const Frame& frame, const ObjectStates* states, const Tracks* tracks) {
  if (!harvest_ || !identity_.empty()) return 0.0;
  if (states) saw_states_ = true;
  const double before = harvest_->seconds();
  harvest_->offer(frame, footage_objects(states, tracks));
  return harvest_->seconds() - before;
}

const LoadedAsset* HazardRenderer::first_pick(const HazardTrajectory& T, double az, double drawn_h) {
  drawn_from_ = assets_.get();
  if (!harvest_) return nullptr;
  const std::string cls = T.object_class;
  std::vector<FootageCut> cuts = harvest_->cuts_of(cls);
  for (const FootageCut& b : bank_)
    if (b.spec.object_class == cls && std::none_of(cuts.begin(), cuts.end(), [&](const FootageCut& c) {
          return c.spec.file == b.spec.file;
        }))
      cuts.push_back(b);
  std::string why;
  if (cuts.empty()) {
    why = "the footage offered no " + cls + " appearance before the hazard appeared (" + harvest_->summary() + ")";
  } else {
    footage_lib_ = std::make_unique<AssetLibrary>();
    for (const FootageCut& c : cuts)
      footage_lib_->add(c.spec, c.bgra, c.folder.empty() ? opt_.footage_dir : c.folder, false);
    const std::string own = taken_id_ ? "track " + std::to_string(*taken_id_) : std::string();
    const LoadedAsset& best = footage_lib_->select(cls, az, own, opt_.max_view_error_deg);
    const double err = angle_diff_deg(best.spec.azimuth_deg, az);
    const auto used = std::find_if(cuts.begin(), cuts.end(),
                                   [&](const FootageCut& c) { return c.spec.file == best.spec.file; });
    if (err > opt_.max_view_error_deg) {
      why = "the footage's " + cls + " appearances show other views (nearest " + best.spec.view + ", " +
            num_text(err, 0) + " deg from the hazard's " + view_for_azimuth(az) + ")";
    } else if (best.spec.image_size.height * opt_.footage_max_upscale < drawn_h) {
      why = "the footage's best " + best.spec.view + " " + cls + " is " +
            std::to_string(best.spec.image_size.height) + " px tall, the hazard is drawn " +
            num_text(drawn_h, 0) + " px tall (more than footage_max_upscale " +
            num_text(opt_.footage_max_upscale, 1) + " times larger)";
    } else {
      drawn_from_ = footage_lib_.get();
      notes_.push_back("appearance: " + best.spec.file + ", cut from this footage" +
                       (best.spec.instance == own ? " (the taken-over object itself)" : "") + ": " +
                       (used != cuts.end() ? used->why : best.spec.origin));
      return &best;
    }
  }
  // Without tracked objects (no states input) there was nothing to cut: that is the graph's choice, not a
  // shortcoming of the footage.
  (saw_states_ || !bank_.empty() ? warnings_ : notes_)
      .push_back("appearance: " + why + "; drawn from " + assets_->describe_folders());
  return nullptr;
}

std::vector<std::string> HazardRenderer::take_warnings() {
  std::vector<std::string> w;
  w.swap(warnings_);
  for (auto& e : ego_.take_warnings()) w.push_back(std::move(e));
  return w;
}

void HazardRenderer::start_hazard(const HazardTrajectory& t) {
  const std::string what = "trajectory '" + t.kind + "' (" + t.object_class + ")";
  if (t.points.empty()) throw Error(what + ": no points");
  if (t.object_class.empty()) throw Error("trajectory '" + t.kind + "': object_class is empty");
  for (int k = 0; k < 3; ++k)
    if (!(t.size_lwh[k] > 0) || !std::isfinite(t.size_lwh[k]))
      throw Error(what + ": size_lwh must be three positive sizes");
  for (size_t i = 0; i < t.points.size(); ++i) {
    const auto& p = t.points[i];
    if (!std::isfinite(p.t) || !std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.heading))
      throw Error(what + ": point " + std::to_string(i) + " has a non-finite value");
    if (i > 0 && p.t <= t.points[i - 1].t)
      throw Error(what + ": point " + std::to_string(i) + " does not increase in time");
  }
  identity_.clear();
  taken_id_.reset();
  taken_box_.reset();
  taken_unseen_ = 0;
  taken_lateral_.reset();
  lane_shift_.reset();
  reached_ = false;
  warned_taken_missing_ = false;
  if (t.spec.track_id) taken_id_ = *t.spec.track_id;
  compositor_ = CompositorState{};
  prev_center_px_.reset();
  warned_future_anchor_ = false;
}

HazardRenderer::Result HazardRenderer::render(const Frame& f,
                                              const std::shared_ptr<const HazardTrajectory>& traj,
                                              const std::vector<OccluderCandidate>& occluders) {
  if (f.image.empty() || f.image.type() != CV_8UC3)
    throw Error(frame_name(f) + ": expected a BGR 8-bit image");
  if (!f.camera.valid())
    throw Error(frame_name(f) + ": the frame has no valid camera model (width/height/fx/fy)");
  if (f.camera.width != f.image.cols || f.camera.height != f.image.rows)
    throw Error(frame_name(f) + ": camera model is " + std::to_string(f.camera.width) + "x" +
                std::to_string(f.camera.height) + " but the image is " + std::to_string(f.image.cols) + "x" +
                std::to_string(f.image.rows));
  Result res;
  res.frame = f;
  res.hazard.frame_index = f.index;
  measure_realism(f, occluders, res);

  auto t0 = std::chrono::steady_clock::now();
  ego_.update(f);
  res.ego_seconds = seconds_since(t0);
  if (opt_.scene_light && opt_.composite.shadow &&
      static_cast<int>(light_.samples().size()) < opt_.scene_light_max_samples) {
    const auto tl = std::chrono::steady_clock::now();
    const ClassGroups& groups = realism::reference_groups();
    std::vector<VehicleView> views;
    for (const auto& o : occluders) {
      if (o.label.empty() || !groups.same(o.label, "car") || o.score < opt_.realism.min_score || o.misses > 0)
        continue;
      if (o.truncated || truncation_flags(o.box, f.image.size())) continue;  // its bottom is not its contact
      VehicleView v;
      v.box = o.box;
      const ClassSize size = opt_.vehicle_sizes.has(o.label) ? opt_.vehicle_sizes.at(o.label) : ClassSize{};
      v.length_m = size.length;
      v.width_m = size.width;
      v.height_m = size.height;
      views.push_back(v);
    }
    light_.add(f.image, f.camera, views, yaw_of(ego_.current()));
    res.light_seconds = seconds_since(tl);
  }

  if (traj != traj_) {
    if (traj) {
      const auto tp = std::chrono::steady_clock::now();
      start_hazard(*traj);
      // All views of the class now, so no frame of the hazard pays for preparing a picture.
      if (!assets_->classes().empty()) assets_->prepare_class(traj->object_class);
      res.prepare_seconds = seconds_since(tp);
    }
    traj_ = traj;
  }
  if (!traj_) return res;
  const HazardTrajectory& T = *traj_;
  res.hazard.kind = T.kind;
  res.hazard.object_class = T.object_class;
  auto pt = T.at(f.timestamp);
  // After its plan ends the hazard carries on as it ended (HazardTrajectory::continued_at) instead of
  // vanishing mid-road, and a real object it replaces does not come back; once the ego has reached it (a plan
  // that ends at contact, or a stopped object the ego runs into) it is no longer drawn.
  const bool continued = !pt && f.timestamp > T.points.back().t;
  if (continued) pt = T.continued_at(f.timestamp);
  if (!pt) {
    prev_center_px_.reset();
    return res;  // before the hazard starts or after it ends: the frame passes through
  }
  t0 = std::chrono::steady_clock::now();
  // A taken-over real object leaves the picture first; the hazard is then drawn in its place.
  std::vector<OccluderCandidate> others = occluders;
  if (taken_id_) {
    const auto tt = std::chrono::steady_clock::now();
    cv::Mat cleaned = f.image.clone();
    res.hazard.taken_over = remove_taken_over(cleaned, occluders);
    res.takeover_seconds = seconds_since(tt);
    if (res.hazard.taken_over) {
      res.frame.image = cleaned;
      const cv::Rect2f gone = res.hazard.taken_over->box;
      std::erase_if(others, [&](const OccluderCandidate& o) {
        return o.track_id == *taken_id_ || hf::box_iou(o.box, gone) > 0.7f;
      });
    }
  }
  const auto anchor = ego_.pose_at(T.anchor_time);
  if (!anchor) {
    if (T.anchor_time < ego_.first_time() - 1e-6)
      throw Error("trajectory '" + T.kind + "': anchor_time " + std::to_string(T.anchor_time) +
                  " s is before the first frame (" + std::to_string(ego_.first_time()) +
                  " s), so the anchor frame's pose is unknown");
    if (!warned_future_anchor_) {
      warnings_.push_back(frame_name(f) + ": trajectory '" + T.kind +
                          "' is anchored at t=" + std::to_string(T.anchor_time) +
                          " s, a frame not seen yet; it is drawn from there on");
      warned_future_anchor_ = true;
    }
    return res;
  }
  // Anchor frame -> current ego frame.
  const cv::Matx44d cur_from_anchor = invert_rigid(ego_.current()) * *anchor;
  const cv::Vec3d size = T.size_lwh;
  BoxCorners corners = box_corners(pt->x, pt->y, pt->heading, size);
  for (auto& c : corners) c = transform(cur_from_anchor, c);
  cv::Vec3d centre = transform(cur_from_anchor, cv::Vec3d(pt->x, pt->y, 0.0));
  // A hazard in place of a real object stays in the lane that object drives in: while it still moves as the
  // real one did when it was taken over, its sideways offset follows the real one's measured offset
  // (smoothed), so an error in the ego's estimated yaw does not slide it out of the lane (on the KITTI raw
  // clip the footage's yaw rate read -2..-4 deg/s while the queue went straight). Once it has departed from
  // that motion (braked), the real one no longer tells where it is: the last correction is held, so a
  // stopped hazard does not slide sideways with the drift of a real car's measured offset (0.25 m over 2 s
  // on the KITTI clip while the ego stood still).
  const bool moves_as_taken = !continued && std::abs(pt->speed - T.points.front().speed) < 0.3;
  if (res.hazard.taken_over && taken_lateral_ && (moves_as_taken || !lane_shift_)) {
    const double shift = *taken_lateral_ - centre[1];
    lane_shift_ = lane_shift_ ? 0.7 * *lane_shift_ + 0.3 * shift : shift;
  }
  if (res.hazard.taken_over && lane_shift_) {
    for (auto& c : corners) c[1] += *lane_shift_;
    centre[1] += *lane_shift_;
    res.hazard.taken_over->lateral_shift_m = *lane_shift_;
  }
  const double heading = pt->heading + yaw_of(cur_from_anchor);
  if (continued && (reached_ || centre[0] - opt_.ego_front_m - size[0] / 2 <= 0)) {
    reached_ = true;
    prev_center_px_.reset();
    res.composite_seconds = seconds_since(t0);
    return res;
  }
  res.hazard.distance_m = centre[0];
  res.hazard.lateral_m = centre[1];
  res.hazard.centre_ego = cv::Vec3d(centre[0], centre[1], 0.0);
  res.hazard.heading_ego = wrap_angle(heading);
  res.hazard.size_lwh = size;

  // Intended TTC by the GUIDE protocol: gap to the front bumper over the closing speed, when in the path.
  const cv::Vec3d v_obj = rotate(
      cur_from_anchor, cv::Vec3d(pt->speed * std::cos(pt->heading), pt->speed * std::sin(pt->heading), 0));
  const cv::Vec3d v_ego = ego_.velocity_ego();
  const cv::Vec3d v_rel = v_obj - v_ego;
  const double closing = -v_rel[0];
  const double gap = centre[0] - opt_.ego_front_m - size[0] / 2;
  const EgoPath path = opt_.corridor.path_for(std::hypot(v_ego[0], v_ego[1]), ego_.yaw_rate());
  if (opt_.corridor.contains(centre[0], centre[1], size[1], path) && closing > 0.1)
    res.hazard.intended_ttc_s = std::max(gap, 0.0) / closing;

  const auto proj = project_box(f.camera, corners, 0.3);
  if (!proj) {
    prev_center_px_.reset();
    res.composite_seconds = seconds_since(t0);
    return res;  // (part of) the object is behind the camera
  }
  const cv::Rect2d img(0, 0, f.image.cols, f.image.rows);
  const cv::Rect2d clipped = proj->bounds & img;
  if (clipped.area() <= 0) {
    prev_center_px_.reset();
    res.composite_seconds = seconds_since(t0);
    return res;
  }
  res.hazard.box = cv::Rect2f(clipped);

  const double az = camera_azimuth_deg(f.camera.t_ego_cam, centre[0], centre[1], heading);
  const LoadedAsset* picked = identity_.empty() ? first_pick(T, az, proj->bounds.height) : nullptr;
  if (!picked) picked = &drawn_from_->select(T.object_class, az, identity_, opt_.max_view_error_deg);
  if (identity_.empty()) {
    identity_ = picked->spec.instance;
    // A picture of the default set: one of its colours, the same for the same hazard (its class, start and
    // first point), different across hazards.
    if (picked->spec.source == "generated") {
      const std::vector<std::string> colours = assets_->generated_instances(T.object_class);
      if (colours.size() > 1) {
        char key[160];
        std::snprintf(key, sizeof key, "%s|%.3f|%.3f|%.3f", T.object_class.c_str(), T.anchor_time,
                      T.points[0].x, T.points[0].y);
        uint64_t h = 1469598103934665603ull;  // FNV-1a
        for (const char* c = key; *c; ++c) h = (h ^ static_cast<unsigned char>(*c)) * 1099511628211ull;
        identity_ = colours[h % colours.size()];
        picked = &assets_->select(T.object_class, az, identity_, opt_.max_view_error_deg);
      }
    }
  }
  const LoadedAsset& asset = *picked;
  res.asset_file = (asset.dir / asset.spec.file).string();
  res.hazard.picture_file = res.asset_file;
  res.hazard.picture_source = asset.spec.source;

  Placement pl;
  pl.asset = &asset;
  pl.corners_px = proj->px;
  const cv::Point2d cen_px((proj->bounds.x + proj->bounds.width / 2),
                           (proj->bounds.y + proj->bounds.height / 2));
  if (prev_center_px_ && f.timestamp > prev_t_)
    pl.velocity_px_s = (cen_px - *prev_center_px_) / (f.timestamp - prev_t_);
  prev_center_px_ = cen_px;
  prev_t_ = f.timestamp;

  if (opt_.occlusion) {
    double near_depth = 1e18;
    for (double d : proj->depth) near_depth = std::min(near_depth, d);
    for (const auto& o : others) {
      if (o.score < opt_.occluder_min_score) continue;
      if ((cv::Rect2d(o.box) & proj->bounds).area() <= 0) continue;
      // Depth of the occluder where it stands on the road (bottom centre of its box); an estimator's distance
      // when the bottom is above the horizon.
      std::optional<double> depth;
      if (auto g = f.camera.pixel_to_ground({o.box.x + o.box.width / 2.0, o.box.y + o.box.height}))
        depth = f.camera.ego_to_cam(*g)[2];
      else if (o.distance_m)
        depth = *o.distance_m - f.camera.t_ego_cam[0];
      if (depth && *depth < near_depth) pl.occluders.push_back(o.box);
    }
  }

  if (opt_.scene_light && opt_.composite.shadow) {
    // The sun's shadow, fixed in the world: its direction in this frame's ego axes, its reach from the
    // hazard's height.
    const SceneLight light = light_.estimate();
    if (light.directional) {
      const double az = light.azimuth - yaw_of(ego_.current());
      const double reach = light.length_per_height * size[2];
      const cv::Vec3d shift(reach * std::cos(az), reach * std::sin(az), 0.0);
      std::array<cv::Point2d, 4> cast;
      bool ok = true;
      for (size_t i = 0; i < 4 && ok; ++i) {
        const auto q = f.camera.project_ego(corners[i] + shift);
        ok = q.has_value();
        if (ok) cast[i] = *q;
      }
      if (ok) {
        pl.cast_px = cast;
        pl.cast_darkness = light.darkness;
      }
    }
  }

  cv::Mat out = res.frame.image.clone();
  // A cut from this recording has the camera's exposure and white balance already: moving its colours
  // towards the surroundings' would only grey a dark car on a light road.
  CompositeOptions co = opt_.composite;
  if (asset.spec.source == "footage") {
    co.harmonize_luma *= opt_.footage_harmonize;
    co.harmonize_chroma *= opt_.footage_harmonize;
  }
  res.composite = composite(out, pl, co, compositor_);
  if (res.composite.drawn) res.frame.image = out;
  if (res.hazard.taken_over) {
    // What of the real object's box the drawn hazard does not hide (alpha below one half) stays inpainted.
    TakenOver& to = *res.hazard.taken_over;
    const cv::Rect box = cv::Rect(to.box) & cv::Rect(0, 0, f.image.cols, f.image.rows);
    const cv::Rect both = res.composite.drawn ? (box & res.composite.roi) : cv::Rect();
    double hidden = 0;
    if (both.area() > 0) {
      const cv::Mat a = res.composite.alpha(both - res.composite.roi.tl());
      hidden = cv::countNonZero(a >= 128);
    }
    to.uncovered_fraction = box.area() > 0 ? 1.0 - hidden / box.area() : 0.0;
  }
  res.hazard.occluded_fraction = std::clamp(res.composite.occluded_fraction(), 0.0, 1.0);
  res.hazard.in_picture_fraction = res.composite.in_picture_fraction();
  res.hazard.visible = res.composite.drawn && res.hazard.occluded_fraction < 0.999;
  if (res.hazard.visible) {
    // The box a detector would draw: around what is seen of the silhouette. The projected 3D box is wider
    // (a walking person's footprint, a car's length seen obliquely) and keeps what nearer objects hide.
    const cv::Rect seen = cv::boundingRect(res.composite.alpha >= 128);
    if (seen.area() > 0) res.hazard.drawn_box = cv::Rect2f(seen + res.composite.roi.tl());
  }
  res.composite_seconds = seconds_since(t0);
  if (opt_.realism.enabled && res.hazard.visible) {
    const auto tr = std::chrono::steady_clock::now();
    res.hazard.appearance = realism::measure(res.frame.image, res.composite.alpha, res.composite.roi.tl(),
                                             res.hazard.box, T.object_class, &f.camera);
    res.realism_seconds += seconds_since(tr);
  }
  return res;
}

std::optional<TakenOver> HazardRenderer::remove_taken_over(cv::Mat& image,
                                                           const std::vector<OccluderCandidate>& objects) {
  TakenOver to;
  to.track_id = *taken_id_;
  to.uncovered_fraction = 1.0;  // until the hazard is drawn over it
  const OccluderCandidate* found = nullptr;
  for (const auto& o : objects)
    if (o.track_id == *taken_id_ && o.misses == 0) found = &o;
  if (!found && taken_box_) {
    // The track was lost or renumbered: the box that best continues the last one, if any does.
    float best = 0.3f;
    for (const auto& o : objects)
      if (const float v = hf::box_iou(o.box, *taken_box_); v > best) best = v, found = &o;
  }
  if (found) {
    taken_box_ = found->box;
    taken_unseen_ = 0;
    to.seen = true;
    if (found->lateral_m) taken_lateral_ = found->lateral_m;
  } else if (taken_box_ && ++taken_unseen_ <= 5) {
    to.seen = false;  // held for a few frames: a missed detection must not bring the real object back
  } else {
    if (!taken_box_ && !warned_taken_missing_) {
      warnings_.push_back(
          "the hazard takes over track " + std::to_string(*taken_id_) +
          ", which is not among the renderer's tracked objects (its states or tracks input): the "
          "real object is not removed");
      warned_taken_missing_ = true;
    }
    return std::nullopt;
  }
  const cv::Rect img(0, 0, image.cols, image.rows);
  const cv::Rect2f b = *taken_box_;
  // The box grown by 4 % and 3 px each way (detector boxes are tight), filled from its surroundings: a lead
  // that keeps its place in the picture hides the same background in every neighbouring frame, so the fill is
  // spatial. Large boxes are filled at a reduced scale (at most 96 px across; the fill is smooth anyway): the
  // drawn hazard hides most of it.
  const float gx = 0.04f * b.width + 3, gy = 0.04f * b.height + 3;
  const cv::Rect hole = cv::Rect(cv::Rect2f(b.x - gx, b.y - gy, b.width + 2 * gx, b.height + 2 * gy)) & img;
  to.box = cv::Rect2f(hole);
  if (hole.area() <= 0) return to;
  const int margin = std::max(8, static_cast<int>(0.15 * std::max(hole.width, hole.height)));
  const cv::Rect roi =
      cv::Rect(hole.x - margin, hole.y - margin, hole.width + 2 * margin, hole.height + 2 * margin) & img;
  cv::Mat mask = cv::Mat::zeros(roi.size(), CV_8U);
  mask(hole - roi.tl()).setTo(255);
  const double scale = std::min(1.0, 96.0 / std::max(roi.width, roi.height));
  cv::Mat src = image(roi), small, small_mask, filled;
  if (scale < 1.0) {
    cv::resize(src, small, cv::Size(), scale, scale, cv::INTER_AREA);
    cv::resize(mask, small_mask, small.size(), 0, 0, cv::INTER_NEAREST);
  } else {
    small = src;
    small_mask = mask;
  }
  cv::inpaint(small, small_mask, filled, 3, cv::INPAINT_TELEA);
  if (scale < 1.0) cv::resize(filled, filled, roi.size(), 0, 0, cv::INTER_LINEAR);
  filled.copyTo(src, mask);
  return to;
}

void HazardRenderer::measure_realism(const Frame& f, const std::vector<OccluderCandidate>& objects,
                                     Result& res) const {
  if (!opt_.realism.enabled || opt_.realism.references <= 0 || f.index % opt_.realism.reference_every != 0)
    return;
  const auto t0 = std::chrono::steady_clock::now();
  // The tallest well-detected, whole road users of each group: vehicles and people.
  const ClassGroups& groups = realism::reference_groups();
  for (const char* group : {"car", "person"}) {
    std::vector<const OccluderCandidate*> pick;
    for (const auto& o : objects)
      if (!o.label.empty() && groups.same(o.label, group) && o.score >= opt_.realism.min_score &&
          o.box.height >= opt_.realism.min_height_px && o.truncated == 0 && o.misses == 0)
        pick.push_back(&o);
    std::sort(pick.begin(), pick.end(), [](const OccluderCandidate* a, const OccluderCandidate* b) {
      return a->box.height > b->box.height;
    });
    if (pick.size() > static_cast<size_t>(opt_.realism.references))
      pick.resize(static_cast<size_t>(opt_.realism.references));
    std::vector<cv::Rect2f> measured;
    for (const OccluderCandidate* o : pick) {
      measured.push_back(o->box);
      cv::Rect crop;
      const cv::Mat mask = realism::object_mask(f.image, o->box, &crop);
      if (mask.empty()) continue;
      AppearanceStats s = realism::measure(f.image, mask, crop.tl(), o->box, o->label, &f.camera);
      s.source = "detection";
      if (std::isfinite(s.edge_contrast)) res.hazard.references.push_back(std::move(s));
    }
    if (opt_.realism.annotations && f.annotations)
      for (AppearanceStats& s : annotated_references(f, group, measured))
        res.hazard.references.push_back(std::move(s));
  }
  res.realism_seconds += seconds_since(t0);
}

std::vector<AppearanceStats> HazardRenderer::annotated_references(
    const Frame& f, const std::string& group, const std::vector<cv::Rect2f>& measured) const {
  const ClassGroups& groups = realism::reference_groups();
  const auto& objs = f.annotations->objects;
  const cv::Rect2d image(0, 0, f.image.cols, f.image.rows);
  struct Seen {
    size_t index;
    cv::Rect2f box;
    double depth;
  };
  std::vector<Seen> seen;  // every annotated object in front of the camera (the group's and its occluders)
  for (size_t k = 0; k < objs.size(); ++k) {
    const auto box = annotation_image_box(f.camera, objs[k]);
    if (!box) continue;
    const cv::Rect2d in = *box & image;
    if (in.area() <= 0) continue;
    seen.push_back({k, cv::Rect2f(in), f.camera.ego_to_cam(objs[k].center_ego)[2]});
  }
  std::vector<const Seen*> pick;
  for (const Seen& s : seen) {
    const AnnotatedObject& o = objs[s.index];
    if (o.label.empty() || !groups.same(o.label, group)) continue;
    if (o.occlusion > opt_.realism.max_occlusion || o.num_points == 0) continue;  // no lidar/radar return
    if (s.box.height < opt_.realism.min_height_px || truncation_flags(s.box, f.image.size()) != 0) continue;
    bool known = false;
    for (const cv::Rect2f& m : measured) known = known || box_iou(m, s.box) >= 0.5;
    if (known) continue;
    // Hidden in this picture: nearer annotated boxes over it (the dataset's hint spans all its cameras).
    double covered = 0;
    for (const Seen& n : seen)
      if (&n != &s && n.depth < s.depth) covered += (n.box & s.box).area();
    if (covered > opt_.realism.max_occlusion * s.box.area()) continue;
    pick.push_back(&s);
  }
  std::sort(pick.begin(), pick.end(),
            [](const Seen* a, const Seen* b) { return a->box.height > b->box.height; });
  if (pick.size() > static_cast<size_t>(opt_.realism.references))
    pick.resize(static_cast<size_t>(opt_.realism.references));
  std::vector<AppearanceStats> out;
  for (const Seen* s : pick) {
    cv::Rect crop;
    const cv::Mat mask = realism::object_mask(f.image, s->box, &crop);
    if (mask.empty()) continue;
    // A projected 3D box is wider than the object's outline where its corners stick out (an oblique car):
    // the silhouette's own extent inside it is the box that size and aspect are read from, as a detector's.
    const cv::Rect outline = cv::boundingRect(mask) + crop.tl();
    const cv::Rect2f box = cv::Rect2f(outline) & s->box;
    AppearanceStats m = realism::measure(f.image, mask, crop.tl(), box.area() > 0 ? box : s->box,
                                         objs[s->index].label, &f.camera);
    m.source = "annotation";
    if (std::isfinite(m.edge_contrast)) out.push_back(std::move(m));
  }
  return out;
}

// ---- stage
// -------------------------------------------------------------------------------------------------------

ComponentInfo ArRenderer::describe() {
  ComponentInfo i;
  i.name = "ar_renderer";
  i.kind = kind::kRenderer;
  i.summary = "composites a planned hazard into the video, anchored in the world, with occlusion and shadow";
  i.doc =
      "Places the hazard's 3D box (HazardTrajectory, anchor frame = ego frame at anchor_time) in each frame "
      "from "
      "the ego motion (dataset poses, the recording's ego track, or the frames' own speed and yaw rate: a "
      "source's, or what the ground_odometry stage measured on the frames), projects it with the "
      "frame's "
      "camera, picks the asset whose view matches the object's heading relative to the camera, warps it with "
      "a "
      "homography onto the projected box faces and blends it with harmonised colour, feathered edges, motion "
      "blur, a contact shadow and occlusion by nearer detected objects. Outputs are stamped with the frame's "
      "time; frames outside the trajectory pass through unchanged.";
  i.inputs = {port<Frame>("frames", "original frames"),
              sticky(port<HazardTrajectory>("trajectory", "the planned hazard; the latest one is used")),
              optional(port<Tracks>("tracks", "tracked objects (occluders)")),
              optional(port<ObjectStates>("states", "objects with distances (occluders)")),
              optional(port<Detections>("detections", "detected objects (occluders)"))};
  i.outputs = {
      port<Frame>("frames", "augmented frames: same index, time, camera, ego and meta; new image"),
      port<HazardInstance>("hazard", "where the hazard is in each frame (box, distance, intended TTC)"),
      port<Frame>("visible_frames",
                  "the augmented frames in which the hazard is visible, only those (for an independent "
                  "re-detection that costs nothing on the other frames); none when visible_frames is off")};
  i.params = {
      ParamSpec::path("assets_dir", "")
          .from_scene("assets.dir")
          .describe("folder with assets.yaml and the pictures; empty = the photographic default set when it "
                    "was built at set-up, else the generated one (share/assets)"),
      ParamSpec::boolean("fallback_assets", true)
          .describe("use the default sets for classes/views assets_dir lacks: the photographic one, then the "
                    "generated one"),
      ParamSpec::boolean("photo_assets", true)
          .describe("the photographic default set cut at set-up out of the shared nuScenes scene (when it was "
                    "built) comes before the generated one (share/assets)"),
      ParamSpec::boolean("footage_appearances", true)
          .describe("cut the recording's own whole, sharp, stable road users out of the frames before the "
                    "hazard appears (grabCut seeded by their boxes, matted; view from their motion, size from "
                    "the camera) and draw the hazard with one when it shows the needed view, else from "
                    "assets_dir (the log says which and why); the cuts are written to appearances/ in the run "
                    "folder, an asset folder for later runs"),
      ParamSpec::number("footage_min_height_px", 40.0)
          .range(8.0, 2000.0)
          .describe("smallest box cut from the footage"),
      ParamSpec::path("footage_assets_dir", "")
          .describe("an asset folder of cuts from this same recording made by an earlier pass over all of it "
                    "(a campaign's scouting pass: the footage_harvester sink), chosen among like the run's "
                    "own; empty = none"),
      ParamSpec::number("footage_harmonize", 0.2)
          .range(0.0, 1.0)
          .describe("share of harmonize_luma and harmonize_chroma applied to a cut from this recording (its "
                    "exposure and white balance are the camera's already)"),
      ParamSpec::number("footage_max_upscale", 3.0)
          .range(1.0, 20.0)
          .describe("a footage cut is used only if the hazard is first drawn at most this many times its "
                    "height (a larger one would show the cut's blur)"),
      ParamSpec::string("ego_motion", "auto")
          .one_of({"auto", "poses", "track", "constant_speed"})
          .describe(
              "how the hazard is kept fixed in the world: auto = poses when frames carry them, else the "
              "recording's ego track (Frame.ego_track: what the video source estimated), else constant_speed "
              "= dead reckoning on each frame's own speed and yaw rate (a source's, or the ground_odometry "
              "stage's measured on the frames), else ego_speed_mps (the former flow mode is that stage now)"),
      ParamSpec::number("ego_speed_mps", -1.0)
          .from_scene("ego.speed_mps")
          .range(-1.0, 80.0)
          .describe("ego speed for constant_speed on frames that carry none (the frame's own speed first); "
                    "-1 = unknown"),
      ParamSpec::number("max_view_error_deg", 30.0)
          .range(0.0, 180.0)
          .describe("an asset of the kept instance / assets_dir is used when its view is this close"),
      ParamSpec::boolean("shadow", true).describe("draw a soft contact shadow"),
      ParamSpec::number("shadow_strength", 0.5).range(0.0, 1.0).describe("darkening at the shadow's core"),
      ParamSpec::boolean("scene_light", true)
          .describe("read the sun's shadow (direction, reach, darkness) off the road beside the recording's "
                    "vehicles and cast the hazard's the same way; diffuse light: the contact shadow only"),
      ParamSpec::number("harmonize_luma", 0.6)
          .range(0.0, 1.0)
          .describe("how far the asset's lightness mean/std move to the surroundings' (Lab)"),
      ParamSpec::number("harmonize_chroma", 0.4).range(0.0, 1.0).describe("same for the colour channels"),
      ParamSpec::number("exposure_smoothing", 0.7)
          .range(0.0, 0.99)
          .describe("temporal smoothing of the surroundings' statistics (no flicker)"),
      ParamSpec::boolean("grain", true).describe("add sensor noise at the level measured beside the object"),
      ParamSpec::number("feather_px", 0.8).range(0.0, 5.0).describe("Gaussian sigma of the alpha edge, px"),
      ParamSpec::number("match_sharpness", 1.0)
          .range(0.0, 10.0)
          .describe("blur the picture until its interior is no sharper than this times the frame around it "
                    "(variance of the Laplacian): the recording's own blur; 0 = off"),
      ParamSpec::boolean("clip_to_box", true)
          .describe("draw only on the object's projected box, grown by 4 % of its height + 2 px: a picture "
                    "showing faces the frame does not (a car seen a little from its side, placed straight "
                    "ahead) leaves no ghost of them beside the box"),
      ParamSpec::number("exposure_s", 0.01)
          .range(0.0, 0.1)
          .describe("camera exposure time: motion blur = image-plane speed x exposure; 0 = none"),
      ParamSpec::boolean("occlusion", true).describe("keep nearer detected objects in front of the hazard"),
      ParamSpec::number("occluder_min_score", 0.3)
          .range(0.0, 1.0)
          .describe("weakest detection that occludes"),
      ParamSpec::number("ego_front_m", 3.4)
          .range(0.0, 10.0)
          .describe("ego origin (rear axle) to front bumper, for the intended TTC"),
      ParamSpec::boolean("visible_frames", true)
          .describe("emit the frames with the hazard visible on the visible_frames output"),
      ParamSpec::boolean("realism", true)
          .describe(
              "measure the inserted object's appearance (edge contrast, halo, sharpness, noise, Lab, size) "
              "and the recording's real road users the same way, into the hazard packet"),
      ParamSpec::integer("realism_references", 1)
          .range(0, 20)
          .describe("real objects measured per class group (vehicles, people) and frame, tallest first"),
      ParamSpec::integer("realism_reference_every", 3)
          .range(1, 1000)
          .describe("measure real objects on every n-th frame (frame index divisible by n)"),
      ParamSpec::number("realism_min_score", 0.5)
          .range(0.0, 1.0)
          .describe("weakest detection measured as a real reference"),
      ParamSpec::boolean("realism_annotations", true)
          .describe(
              "also measure the dataset's annotated road users (3D boxes projected into the picture, when "
              "the "
              "source attaches them), up to realism_references per group and frame besides the detections'"),
      ParamSpec::number("realism_max_occlusion", 0.2)
          .range(0.0, 1.0)
          .describe(
              "largest hidden share of an annotated reference: the dataset's hint, and the nearer annotated "
              "boxes over it in the picture"),
  };
  for (auto& p : Corridor::params()) i.params.push_back(p);
  return i;
}

RendererOptions renderer_options(const Params& p) {
  RendererOptions o;
  o.composite.shadow = p.get_bool("shadow");
  o.composite.shadow_strength = p.get_double("shadow_strength");
  o.composite.harmonize_luma = p.get_double("harmonize_luma");
  o.composite.harmonize_chroma = p.get_double("harmonize_chroma");
  o.composite.exposure_smoothing = p.get_double("exposure_smoothing");
  o.composite.feather_px = p.get_double("feather_px");
  o.composite.grain = p.get_bool("grain");
  o.composite.exposure_s = p.get_double("exposure_s");
  o.composite.match_sharpness = p.get_double("match_sharpness");
  o.composite.clip_to_box = p.get_bool("clip_to_box");
  o.ego.mode = parse_ego_motion_mode(p.get_string("ego_motion"));
  o.ego.speed_mps = p.get_double("ego_speed_mps");
  o.max_view_error_deg = p.get_double("max_view_error_deg");
  o.occlusion = p.get_bool("occlusion");
  o.occluder_min_score = p.get_double("occluder_min_score");
  o.ego_front_m = p.get_double("ego_front_m");
  o.corridor = Corridor::from(p);
  o.realism.enabled = p.get_bool("realism");
  o.realism.references = static_cast<int>(p.get_int("realism_references"));
  o.realism.reference_every = static_cast<int>(p.get_int("realism_reference_every"));
  o.realism.min_score = p.get_double("realism_min_score");
  o.realism.annotations = p.get_bool("realism_annotations");
  o.realism.max_occlusion = p.get_double("realism_max_occlusion");
  o.scene_light = p.get_bool("scene_light");
  o.footage = p.get_bool("footage_appearances");
  o.footage_harvest.min_height_px = p.get_double("footage_min_height_px");
  o.footage_max_upscale = p.get_double("footage_max_upscale");
  o.footage_bank = p.get_path("footage_assets_dir");
  o.footage_harmonize = p.get_double("footage_harmonize");
  if (o.scene_light || o.footage) o.vehicle_sizes = ClassPriors::load(share_dir() + "/class_sizes.yaml");
  return o;
}

std::filesystem::path photo_assets_dir() {
#ifdef HF_PHOTO_ASSETS_DIR
  const fs::path dir = HF_PHOTO_ASSETS_DIR;
  if (fs::exists(dir / kAssetIndexFile)) return dir;
#endif
  return {};
}

std::shared_ptr<const AssetLibrary> load_assets(const Params& p) {
  const fs::path defaults = fs::path(share_dir()) / "assets";
  const fs::path photo = p.get_bool("photo_assets") ? photo_assets_dir() : fs::path();
  fs::path dir = p.get_path("assets_dir");
  if (dir.empty()) dir = photo.empty() ? defaults : photo;
  if (!fs::is_directory(dir)) throw Error("assets_dir '" + dir.string() + "' is not a folder");
  std::vector<fs::path> fallbacks;
  if (p.get_bool("fallback_assets")) fallbacks = {photo, defaults};
  return std::make_shared<const AssetLibrary>(AssetLibrary::load(dir, fallbacks));
}

std::string describe_light(const SceneLight& l) {
  char msg[256];
  if (!l.measured())
    std::snprintf(msg, sizeof msg, "not measured (no whole vehicle seen yet): contact shadow only");
  else if (l.directional)
    std::snprintf(
        msg, sizeof msg,
        "sun shadows pointing %.0f deg (world frame), %.2f m per m of height, darkness %.2f, from %d of %d "
        "vehicle views (consistency %.2f): the hazard casts one alike",
        l.azimuth * 180.0 / CV_PI, l.length_per_height, l.darkness, l.directional_samples, l.samples,
        l.consistency);
  else
    std::snprintf(
        msg, sizeof msg,
        "diffuse (%d of %d vehicle views with one darker side, consistency %.2f; the road beside them "
        "%.2f darker): contact shadow only",
        l.directional_samples, l.samples, l.consistency, l.darkness);
  return msg;
}

void ArRenderer::finish(StageContext& ctx, Outputs& /*out*/) {
  if (renderer_ && light_logged_)
    ctx.log(LogLevel::kInfo, "scene light over the clip: " + describe_light(renderer_->light()));
  if (const FootageHarvest* h = renderer_ ? renderer_->harvest() : nullptr) {
    const std::filesystem::path dir = ctx.output_dir() / kFootageFolder;
    const int n = h->save(dir);
    ctx.log(LogLevel::kInfo, "footage harvest: " + h->summary() +
                                 (n > 0 ? "; written to " + dir.string() : std::string()));
  }
}

void ArRenderer::open(StageContext& ctx) {
  RendererOptions o = renderer_options(ctx.params());
  o.footage_dir = ctx.output_dir() / kFootageFolder;
  renderer_ = std::make_unique<HazardRenderer>(o, load_assets(ctx.params()));
  emit_visible_ = ctx.params().get_bool("visible_frames");
}

std::vector<OccluderCandidate> merge_occluders(const ObjectStates* states, const Tracks* tracks,
                                               const Detections* detections) {
  std::vector<OccluderCandidate> occ;
  if (states)
    for (const auto& o : states->objects)
      occ.push_back({o.box, o.score, o.distance_m + states->distance_origin_x, o.label, o.truncated, o.misses,
                     o.track_id, o.lateral_m});
  auto known = [&](const cv::Rect2f& box, int64_t id) {
    for (const auto& o : occ)
      if ((id >= 0 && o.track_id == id) || hf::box_iou(o.box, box) >= 0.5) return true;
    return false;
  };
  if (tracks)
    for (const auto& o : tracks->items)
      if (!known(o.box, o.id))
        occ.push_back({o.box, o.score, std::nullopt, o.label, o.truncated, o.misses, o.id, std::nullopt});
  if (detections)
    for (const auto& o : detections->items)
      if (!known(o.box, -1))
        occ.push_back({o.box, o.score, std::nullopt, o.label, o.truncated, 0, -1, std::nullopt});
  return occ;
}

void ArRenderer::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  const Frame& f = in.require<Frame>("frames");
  std::shared_ptr<const HazardTrajectory> traj;
  if (const Packet* p = in.packet("trajectory"); p && !p->empty()) traj = p->share<HazardTrajectory>();
  if (const double s = renderer_->observe(f, in.get<ObjectStates>("states"), in.get<Tracks>("tracks")); s > 0)
    ctx.record_timing("footage_harvest", s);
  HazardRenderer::Result r =
      renderer_->render(f, traj,
                        merge_occluders(in.get<ObjectStates>("states"), in.get<Tracks>("tracks"),
                                        in.get<Detections>("detections")));
  for (const auto& w : renderer_->take_warnings()) ctx.log(LogLevel::kWarning, w);
  for (const auto& n : renderer_->take_notes()) ctx.log(LogLevel::kInfo, n);
  ctx.record_timing("ego_motion", r.ego_seconds);
  if (r.prepare_seconds > 0) ctx.record_timing("asset_prepare", r.prepare_seconds);
  if (r.hazard.visible || r.composite_seconds > 0) ctx.record_timing("composite", r.composite_seconds);
  if (r.realism_seconds > 0) ctx.record_timing("realism", r.realism_seconds);
  if (r.takeover_seconds > 0) ctx.record_timing("takeover", r.takeover_seconds);
  if (r.light_seconds > 0) ctx.record_timing("scene_light", r.light_seconds);
  if (r.hazard.visible && !light_logged_) {
    light_logged_ = true;
    ctx.log(LogLevel::kInfo, "scene light when the hazard appeared: " + describe_light(renderer_->light()));
  }
  if (emit_visible_ && r.hazard.visible) out.emit("visible_frames", r.frame);
  out.emit("frames", std::move(r.frame));
  out.emit("hazard", std::move(r.hazard));
}

}  // namespace hf::render
