// SORT tracker: per-track cv::KalmanFilter and IoU assignment with the shared Hungarian solver.
#include "sort_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hazardforge/tracking/hungarian.hpp"

namespace hf {

ComponentInfo SortTracker::describe() {
  ComponentInfo i = Tracker::base_info("sort", "SORT: Kalman box filter with IoU Hungarian assignment");
  i.doc =
      "Bewley et al. 2016. State [cx, cy, s, r, vcx, vcy, vs] with the reference implementation's noise "
      "settings (R = diag(1,1,10,10), P0 = 10 / 1e4 for velocities, Q = 1 / 0.01 / 1e-4). Emits one Tracks "
      "packet per frame with the confirmed tracks, stamped with the frame's timestamp.";
  i.params = {
      ParamSpec::number("iou_threshold", 0.3)
          .range(0, 1)
          .describe("minimum IoU between prediction and detection"),
      ParamSpec::integer("min_hits", 3)
          .range(0, 1000)
          .describe(
              "consecutive matches before a track is emitted (waived during the first min_hits frames)"),
      ParamSpec::integer("max_age", 1).range(1, 100000).describe("frames a track survives unmatched"),
      ParamSpec::boolean("match_class", false)
          .describe("only match detections whose label equals the track's (or shares a class group with it)"),
      ParamSpec::string_list("class_groups", tracking::default_class_groups())
          .describe(
              "comma-separated labels that match_class treats as one class (detectors flicker between them)"),
      ParamSpec::boolean("emit_unmatched", false)
          .describe("also emit confirmed tracks missed this frame, with their predicted box (SORT itself "
                    "does not)"),
      ParamSpec::number("velocity_smoothing", 0.5)
          .range(0.01, 1)
          .describe("weight of the newest displacement in the exponentially smoothed velocity_px (1 = none)"),
  };
  return i;
}

void SortTracker::open(StageContext& ctx) {
  const Params& p = ctx.params();
  Config c;
  c.iou_threshold = p.get_double("iou_threshold");
  c.min_hits = static_cast<int>(p.get_int("min_hits"));
  c.max_age = static_cast<int>(p.get_int("max_age"));
  c.match_class = p.get_bool("match_class");
  c.class_groups = p.get_strings("class_groups");
  c.emit_unmatched = p.get_bool("emit_unmatched");
  c.velocity_smoothing = p.get_double("velocity_smoothing");
  configure(c);
}

Tracks SortTracker::update(StageContext& /*ctx*/, const Detections& dets, const Frame& frame) {
  return step(dets, frame);
}

namespace {
cv::Mat measurement(const cv::Rect2f& b) {
  const float s = b.width * b.height;
  const float r = b.height > 0 ? b.width / b.height : 1.f;
  return (cv::Mat_<float>(4, 1) << b.x + b.width / 2, b.y + b.height / 2, s, r);
}
}  // namespace

cv::Rect2f SortTracker::Entry::box() const {
  const cv::Mat& x = kf.statePost;
  const float s = std::max(x.at<float>(2), 0.f), r = std::max(x.at<float>(3), 0.f);
  const float w = std::sqrt(s * r);
  const float h = w > 0 ? s / w : 0.f;
  return {x.at<float>(0) - w / 2, x.at<float>(1) - h / 2, w, h};
}

SortTracker::Entry SortTracker::make_entry(const Detection& d, int index, double t) {
  Entry e;
  e.id = next_id_++;
  e.kf.init(7, 4, 0, CV_32F);
  cv::setIdentity(e.kf.transitionMatrix);
  for (int k = 0; k < 3; ++k) e.kf.transitionMatrix.at<float>(k, k + 4) = 1.f;
  e.kf.measurementMatrix = cv::Mat::zeros(4, 7, CV_32F);
  for (int k = 0; k < 4; ++k) e.kf.measurementMatrix.at<float>(k, k) = 1.f;
  e.kf.measurementNoiseCov = cv::Mat::diag((cv::Mat_<float>(4, 1) << 1, 1, 10, 10));
  e.kf.errorCovPost = cv::Mat::diag((cv::Mat_<float>(7, 1) << 10, 10, 10, 10, 1e4f, 1e4f, 1e4f));
  e.kf.processNoiseCov = cv::Mat::diag((cv::Mat_<float>(7, 1) << 1, 1, 1, 1, 0.01f, 0.01f, 1e-4f));
  e.kf.statePost = cv::Mat::zeros(7, 1, CV_32F);
  measurement(d.box).copyTo(e.kf.statePost.rowRange(0, 4));
  e.velocity = tracking::VelocityEstimator(cfg_.velocity_smoothing);
  e.velocity.observe(tracking::centre(d.box), t);
  e.vote.add(d.label);
  e.score = d.score;
  e.hits = 1;
  e.hit_streak = 1;
  e.detection_index = index;
  e.annotation_index = d.annotation_index;
  e.truncated = d.truncated;
  return e;
}

void SortTracker::predict(Entry& e) {
  // A shrinking box must not reach a negative area within one step.
  if (e.kf.statePost.at<float>(6) + e.kf.statePost.at<float>(2) <= 0) e.kf.statePost.at<float>(6) = 0;
  e.kf.predict();  // OpenCV copies the prediction into statePost, so successive predictions compound
  ++e.age;
  if (e.misses > 0) e.hit_streak = 0;
  ++e.misses;
}

Tracks SortTracker::step(const Detections& dets, const Frame& frame) {
  const double t = frame.timestamp;
  if (have_time_ && !(t > last_time_))
    throw Error("sort tracker: frame " + std::to_string(frame.index) + " has timestamp " + std::to_string(t) +
                " s, not after frame " + std::to_string(last_frame_) + " at " + std::to_string(last_time_) +
                " s");
  have_time_ = true;
  last_time_ = t;
  last_frame_ = frame.index;
  ++frame_count_;

  // Predict; drop filters whose state went non-finite (as the reference implementation does).
  std::vector<Entry> live;
  live.reserve(tracks_.size());
  for (Entry& e : tracks_) {
    predict(e);
    const cv::Rect2f b = e.box();
    if (std::isfinite(b.x) && std::isfinite(b.y) && std::isfinite(b.width) && std::isfinite(b.height))
      live.push_back(std::move(e));
  }
  tracks_ = std::move(live);

  const size_t nt = tracks_.size(), nd = dets.items.size();
  const double inf = std::numeric_limits<double>::infinity();
  tracking::CostMatrix cost(nt, std::vector<double>(nd, inf));
  for (size_t i = 0; i < nt; ++i) {
    const cv::Rect2f pb = tracks_[i].box();
    const std::string label = tracks_[i].vote.label();
    for (size_t j = 0; j < nd; ++j) {
      if (cfg_.match_class && !groups_.same(dets.items[j].label, label)) continue;
      const double o = box_iou(pb, dets.items[j].box);
      if (o >= cfg_.iou_threshold && o > 0.0) cost[i][j] = -o;
    }
  }
  std::vector<int> det_of_track(nt, -1);
  std::vector<char> det_used(nd, 0);
  for (const auto& [i, j] : tracking::hungarian(cost)) {
    det_of_track[i] = j;
    det_used[j] = 1;
  }

  for (size_t i = 0; i < nt; ++i) {
    Entry& e = tracks_[i];
    const int j = det_of_track[i];
    if (j < 0) {
      e.detection_index = -1;
      e.annotation_index = -1;
      continue;
    }
    const Detection& d = dets.items[j];
    e.misses = 0;
    ++e.hits;
    ++e.hit_streak;
    e.kf.correct(measurement(d.box));
    e.velocity.observe(tracking::centre(d.box), t);
    e.vote.add(d.label);
    e.score = d.score;
    e.detection_index = j;
    e.annotation_index = d.annotation_index;
    e.truncated = d.truncated;
  }
  for (size_t j = 0; j < nd; ++j)
    if (!det_used[j]) tracks_.push_back(make_entry(dets.items[j], int(j), t));

  Tracks out;
  out.frame_index = frame.index;
  out.tracker = "sort";
  std::vector<Entry> kept;
  kept.reserve(tracks_.size());
  for (Entry& e : tracks_) {
    if (e.misses > cfg_.max_age) continue;
    const bool warming_up = frame_count_ <= cfg_.min_hits;
    const bool streak = e.misses == 0 && (e.hit_streak >= cfg_.min_hits || warming_up);
    // SORT hides a track again after a miss until it rebuilds its streak; with emit_unmatched a confirmed
    // track stays visible (predicted while missed) until it dies.
    const bool emit = streak || (cfg_.emit_unmatched && e.confirmed);
    if (streak) e.confirmed = true;
    if (emit) {
      Track tr;
      tr.id = e.id;
      tr.box = e.box();
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
    kept.push_back(std::move(e));
  }
  tracks_ = std::move(kept);
  std::sort(out.items.begin(), out.items.end(), [](const Track& a, const Track& b) { return a.id < b.id; });
  return out;
}

}  // namespace hf
