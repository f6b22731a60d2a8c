// Nearest-centroid tracker: gated distance association (greedy or Hungarian), disappearance, persistent ids.
#include "centroid_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "hazardforge/angles.hpp"
#include "hazardforge/tracking/hungarian.hpp"

namespace hf {

ComponentInfo CentroidTracker::describe() {
  ComponentInfo i = Tracker::base_info("centroid", "nearest-centroid tracker with disappearance handling");
  i.doc =
      "Matches each detection to the track whose centre is nearest (optionally the centre predicted from the "
      "track's velocity), within a pixel gate and optionally the same class. Unmatched tracks are kept with "
      "their last box for max_disappeared frames (misses counts up), then dropped; ids are never reused. "
      "Emits one Tracks packet per frame with every live track, stamped with the frame's timestamp.";
  i.params = {
      ParamSpec::number("max_distance", 0.0)
          .range(0, 100000)
          .describe(
              "association gate in px between a track's centre and a detection's; 0 = 0.1 x image diagonal"),
      ParamSpec::integer("max_disappeared", 10)
          .range(0, 100000)
          .describe("frames a track survives unmatched (box held, misses counting) before it is dropped"),
      ParamSpec::boolean("match_class", true)
          .describe("only match detections whose label equals the track's (or shares a class group with it)"),
      ParamSpec::string_list("class_groups", tracking::default_class_groups())
          .describe(
              "comma-separated labels that match_class treats as one class (detectors flicker between them)"),
      ParamSpec::string("association", "greedy")
          .one_of({"greedy", "hungarian"})
          .describe(
              "greedy: smallest distances first (the original method); hungarian: minimum total distance"),
      ParamSpec::boolean("predict", true)
          .describe(
              "compare detections with the centre extrapolated by the track's velocity, not its last one"),
      ParamSpec::boolean("compensate_turn", false)
          .describe(
              "before matching, move every track with the picture by the ego's heading change since the "
              "last frame (dataset poses, else the frame's yaw rate): between 2 Hz keyframes in a bend "
              "the scene sweeps by 200 px and more"),
      ParamSpec::number("velocity_smoothing", 0.5)
          .range(0.01, 1)
          .describe("weight of the newest displacement in the exponentially smoothed velocity_px (1 = none)"),
  };
  return i;
}

void CentroidTracker::open(StageContext& ctx) {
  const Params& p = ctx.params();
  Config c;
  c.max_distance = p.get_double("max_distance");
  c.max_disappeared = static_cast<int>(p.get_int("max_disappeared"));
  c.match_class = p.get_bool("match_class");
  c.class_groups = p.get_strings("class_groups");
  c.hungarian = p.get_string("association") == "hungarian";
  c.predict = p.get_bool("predict");
  c.velocity_smoothing = p.get_double("velocity_smoothing");
  c.compensate_turn = p.get_bool("compensate_turn");
  configure(c);
}

Tracks CentroidTracker::update(StageContext& /*ctx*/, const Detections& dets, const Frame& frame) {
  return step(dets, frame);
}

namespace {
cv::Size image_size_of(const Detections& dets, const Frame& frame) {
  if (!frame.image.empty()) return frame.image.size();
  if (dets.image_size.area() > 0) return dets.image_size;
  if (frame.camera.valid()) return {frame.camera.width, frame.camera.height};
  return {};
}
}  // namespace

Tracks CentroidTracker::step(const Detections& dets, const Frame& frame) {
  const double t = frame.timestamp;
  if (have_time_ && !(t > last_time_))
    throw Error("centroid tracker: frame " + std::to_string(frame.index) + " has timestamp " +
                std::to_string(t) + " s, not after frame " + std::to_string(last_frame_) + " at " +
                std::to_string(last_time_) + " s");
  const double prev_t = have_time_ ? last_time_ : t;
  have_time_ = true;
  last_time_ = t;
  last_frame_ = frame.index;

  // The ego's heading, and the picture's sweep since the last frame: a fixed point's bearing grows by the
  // turn.
  std::optional<double> heading;
  if (frame.ego.T_world_ego) {
    const cv::Matx44d& T = *frame.ego.T_world_ego;
    heading = std::atan2(T(1, 0), T(0, 0));
  } else if (frame.ego.yaw_rate && heading_) {
    heading = *heading_ + *frame.ego.yaw_rate * (t - prev_t);
  } else if (frame.ego.yaw_rate) {
    heading = 0.0;
  }
  if (cfg_.compensate_turn && heading && heading_ && frame.camera.valid()) {
    const double turn = angle_diff(*heading, *heading_);
    const cv::Size sz = image_size_of(dets, frame);
    const CameraModel cam =
        sz.area() > 0 && (sz.width != frame.camera.width || sz.height != frame.camera.height)
            ? frame.camera.scaled_to(sz.width, sz.height)
            : frame.camera;
    auto sweep = [&](float x) {
      const double bearing = std::atan((x - cam.cx) / cam.fx) + turn;
      if (std::abs(bearing) >= 1.5) return 0.0f;
      return static_cast<float>(cam.cx + cam.fx * std::tan(bearing) - x);
    };
    for (Entry& e : tracks_) {
      const float dx = sweep(tracking::centre(e.box).x);
      e.box.x += dx;
      e.velocity.shift_last({dx, 0.0f});
    }
  }
  heading_ = heading;

  double gate = cfg_.max_distance;
  if (gate <= 0.0) {
    const cv::Size sz = image_size_of(dets, frame);
    if (sz.area() <= 0)
      throw Error(
          "centroid tracker: frame " + std::to_string(frame.index) +
          " has no image size (empty image, no camera, no detections size) to derive max_distance from");
    gate = kAutoGateFraction * std::hypot(double(sz.width), double(sz.height));
  }

  const size_t nt = tracks_.size(), nd = dets.items.size();
  const double inf = std::numeric_limits<double>::infinity();
  tracking::CostMatrix cost(nt, std::vector<double>(nd, inf));
  for (size_t i = 0; i < nt; ++i) {
    const Entry& e = tracks_[i];
    const cv::Point2f ref = cfg_.predict ? e.velocity.predict(t) : tracking::centre(e.box);
    const std::string label = e.vote.label();
    for (size_t j = 0; j < nd; ++j) {
      const Detection& d = dets.items[j];
      if (cfg_.match_class && !groups_.same(d.label, label)) continue;
      const cv::Point2f c = tracking::centre(d.box);
      const double dist = std::hypot(double(c.x - ref.x), double(c.y - ref.y));
      if (dist <= gate) cost[i][j] = dist;
    }
  }

  std::vector<std::pair<int, int>> matches;
  if (cfg_.hungarian) {
    matches = tracking::hungarian(cost);
  } else {
    std::vector<std::tuple<double, int, int>> pairs;
    for (size_t i = 0; i < nt; ++i)
      for (size_t j = 0; j < nd; ++j)
        if (std::isfinite(cost[i][j])) pairs.emplace_back(cost[i][j], int(i), int(j));
    std::sort(pairs.begin(), pairs.end());
    std::vector<char> row_used(nt, 0), col_used(nd, 0);
    for (const auto& [dist, i, j] : pairs) {
      if (row_used[i] || col_used[j]) continue;
      row_used[i] = col_used[j] = 1;
      matches.emplace_back(i, j);
    }
  }

  std::vector<int> det_of_track(nt, -1);
  std::vector<char> det_used(nd, 0);
  for (const auto& [i, j] : matches) {
    det_of_track[i] = j;
    det_used[j] = 1;
  }

  std::vector<Entry> kept;
  kept.reserve(nt + nd);
  for (size_t i = 0; i < nt; ++i) {
    Entry& e = tracks_[i];
    ++e.age;
    const int j = det_of_track[i];
    if (j >= 0) {
      const Detection& d = dets.items[j];
      e.box = d.box;
      e.velocity.observe(tracking::centre(d.box), t);
      e.vote.add(d.label);
      e.score = d.score;
      ++e.hits;
      e.misses = 0;
      e.detection_index = j;
      e.annotation_index = d.annotation_index;
      e.truncated = d.truncated;
    } else {
      ++e.misses;
      e.detection_index = -1;
      e.annotation_index = -1;
      if (e.misses > cfg_.max_disappeared) continue;
    }
    kept.push_back(std::move(e));
  }
  for (size_t j = 0; j < nd; ++j) {
    if (det_used[j]) continue;
    const Detection& d = dets.items[j];
    Entry e;
    e.id = next_id_++;
    e.box = d.box;
    e.velocity = tracking::VelocityEstimator(cfg_.velocity_smoothing);
    e.velocity.observe(tracking::centre(d.box), t);
    e.vote.add(d.label);
    e.score = d.score;
    e.hits = 1;
    e.detection_index = int(j);
    e.annotation_index = d.annotation_index;
    e.truncated = d.truncated;
    kept.push_back(std::move(e));
  }
  tracks_ = std::move(kept);

  Tracks out;
  out.frame_index = frame.index;
  out.tracker = "centroid";
  for (const Entry& e : tracks_) {
    Track tr;
    tr.id = e.id;
    tr.box = e.box;
    tr.label = e.vote.label();
    tr.score = e.score;
    tr.age = e.age;
    tr.hits = e.hits;
    tr.misses = e.misses;
    tr.velocity_px = e.velocity.velocity();
    tr.detection_index = e.detection_index;
    tr.annotation_index = e.annotation_index;
    tr.truncated = e.truncated;
    out.items.push_back(tr);
  }
  std::sort(out.items.begin(), out.items.end(), [](const Track& a, const Track& b) { return a.id < b.id; });
  return out;
}

}  // namespace hf
