// Keypoint-scale TTC: TTC = T / (R - 1) over the scale ratios of the last window.
#include "ttc_keypoints_metric.hpp"

#include <cmath>
#include <set>

#include "hazardforge/risk/closing_speed.hpp"

namespace hf {

ComponentInfo TtcKeypointsMetric::describe() {
  ComponentInfo i = RiskMetric::base_info(
      "ttc_keypoints", "time-to-collision from the scale change of keypoints inside the box (s)");
  i.doc =
      "Per matched box: KLT corners from the previous frame (seeded by the box's motion, forward-backward "
      "checked), median ratio r of pairwise point distances with MAD outlier rejection. Over the frame pairs "
      "of "
      "the last window_s seconds (at least one), R = prod r, T = sum dt; TTC = T / (R - 1); infinite when "
      "(R - 1) / T <= min_scale_rate. The ~90 % interval comes from the ratios' standard errors. Unknown "
      "(null) "
      "on a track's first frame and whenever its keypoints fail (texture-less or tiny boxes). Needs the "
      "frames "
      "input (the image).";
  i.params.push_back(ParamSpec::number("window_s", 0.5)
                         .range(0, 100)
                         .describe("scale ratios of the last window_s seconds are combined (at least one)"));
  i.params.push_back(ParamSpec::number("min_scale_rate", 0.01)
                         .range(0, 100)
                         .describe("(R - 1) / T at or below this (1/s) gives an infinite TTC"));
  i.params.push_back(ParamSpec::integer("max_points", 40).range(6, 1000).describe("corners sought per box"));
  return i;
}

void TtcKeypointsMetric::open(StageContext& ctx) {
  const Params& p = ctx.params();
  window_s_ = p.get_double("window_s");
  min_rate_ = p.get_double("min_scale_rate");
  estimation::KeypointScaleConfig c;
  c.max_points = static_cast<int>(p.get_int("max_points"));
  tracker_ = estimation::KeypointScaleTracker(c);
  history_.clear();
}

RiskAssessment TtcKeypointsMetric::assess(StageContext& /*ctx*/, const ObjectStates& states,
                                          const Frame* frame) {
  if (!frame || frame->image.empty())
    throw Error("ttc_keypoints: frame " + std::to_string(states.frame_index) +
                " has no image; connect the 'frames' input to the source's frames");
  RiskAssessment r;
  r.stage = "ttc_keypoints";
  r.unit = "s";
  r.lower_is_riskier = true;
  std::map<int64_t, cv::Rect2f> boxes;
  for (const ObjectState& s : states.objects)
    if (s.misses == 0) boxes[s.track_id] = s.box;
  const auto ratios = tracker_.update(frame->image, frame->timestamp, boxes);

  for (auto it = history_.begin(); it != history_.end();)
    it = boxes.count(it->first) ? std::next(it) : history_.erase(it);
  for (const ObjectState& s : states.objects) {
    ObjectRisk o{s.track_id, std::nan(""), false};
    auto q = ratios.find(s.track_id);
    std::deque<Pair>& h = history_[s.track_id];
    if (q == ratios.end() || !q->second.valid()) {
      h.clear();  // a broken chain: the next window starts afresh
      r.objects.push_back(o);
      continue;
    }
    h.push_back({frame->timestamp, q->second.dt, std::log(q->second.ratio),
                 q->second.log_sigma * q->second.log_sigma});
    while (h.size() > 1 && frame->timestamp - (h.front().t - h.front().dt) > window_s_ + 1e-9) h.pop_front();
    double L = 0, T = 0, V = 0;
    for (const Pair& p : h) {
      L += p.log_ratio;
      T += p.dt;
      V += p.var;
    }
    const double R = std::exp(L);
    const double g = (R - 1.0) / T;
    o.value = g <= min_rate_ ? kInf : 1.0 / g;
    // d g / d L = R / T.
    const auto iv = risk::ttc_interval_from_inverse(g, R * std::sqrt(V) / T);
    o.low = iv.low;
    o.high = iv.high;
    r.objects.push_back(o);
  }
  return r;
}

}  // namespace hf
