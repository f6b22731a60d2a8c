// Keypoint scale change: KLT-tracked corners inside each box, median pairwise-distance ratio.
#include "hazardforge/estimation/keypoint_scale.hpp"

#include <algorithm>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace hf::estimation {

namespace {
double median_of(std::vector<double> v) {
  const size_t n = v.size();
  std::nth_element(v.begin(), v.begin() + n / 2, v.end());
  const double hi = v[n / 2];
  if (n % 2) return hi;
  return 0.5 * (hi + *std::max_element(v.begin(), v.begin() + n / 2));
}
}  // namespace

ScaleRatio scale_from_matches(const std::vector<cv::Point2f>& before, const std::vector<cv::Point2f>& now,
                              double min_pair_px, int min_points) {
  ScaleRatio r;
  const size_t n = std::min(before.size(), now.size());
  r.points = static_cast<int>(n);
  if (static_cast<int>(n) < min_points) return r;
  std::vector<double> logs;
  logs.reserve(n * (n - 1) / 2);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      const double d0 = cv::norm(before[i] - before[j]);
      if (d0 < min_pair_px) continue;
      const double d1 = cv::norm(now[i] - now[j]);
      if (d1 <= 1e-6) continue;
      logs.push_back(std::log(d1 / d0));
    }
  if (logs.size() < 3) return r;
  // Work in log ratios: symmetric for growth and shrinkage, and the spread is a relative error.
  const double m0 = median_of(logs);
  std::vector<double> dev(logs.size());
  for (size_t k = 0; k < logs.size(); ++k) dev[k] = std::abs(logs[k] - m0);
  const double mad0 = 1.4826 * median_of(dev);
  const double cut = std::max(3.0 * mad0, 1e-4);
  std::vector<double> kept;
  kept.reserve(logs.size());
  for (double l : logs)
    if (std::abs(l - m0) <= cut) kept.push_back(l);
  if (kept.size() < 3) return r;
  const double m = median_of(kept);
  for (size_t k = 0; k < kept.size(); ++k) dev[k] = std::abs(kept[k] - m);
  dev.resize(kept.size());
  const double mad = 1.4826 * median_of(dev);
  r.ratio = std::exp(m);
  r.pairs = static_cast<int>(kept.size());
  // Pairs share points, so they are not independent: the effective sample is the point count. The median's
  // standard error is ~1.25 sigma / sqrt(n); a floor keeps a perfect synthetic match from claiming certainty.
  r.log_sigma = std::max(1.2533 * mad / std::sqrt(static_cast<double>(n)), 1e-4);
  return r;
}

std::map<int64_t, ScaleRatio> KeypointScaleTracker::update(const cv::Mat& image, double t,
                                                           const std::map<int64_t, cv::Rect2f>& boxes) {
  cv::Mat grey;
  if (image.channels() == 3)
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else
    grey = image;
  const cv::Size win(cfg_.window_px, cfg_.window_px);
  std::vector<cv::Mat> pyramid;
  // No derivative images: Scharr over three whole 1600x900 levels costs more than LK computing them on the
  // few patches it tracks.
  cv::buildOpticalFlowPyramid(grey, pyramid, win, cfg_.pyramid_levels, false);
  const cv::Rect2f frame(0.f, 0.f, static_cast<float>(grey.cols), static_cast<float>(grey.rows));

  std::map<int64_t, ScaleRatio> out;
  // Points of every box with a memory, grouped by the frame they were found in (the previous call, or an
  // earlier one for a box that was missing): one forward and one backward call per group.
  std::map<const std::vector<cv::Mat>*, std::vector<int64_t>> groups;
  for (const auto& [id, box] : boxes) {
    auto it = memory_.find(id);
    if (it == memory_.end() || it->second.points.empty() || !(t > it->second.t)) continue;
    if (it->second.missed && t - it->second.t > cfg_.max_bridge_s + 1e-9) continue;
    groups[it->second.pyramid.get()].push_back(id);
  }
  const cv::TermCriteria crit(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  for (const auto& [before, ids] : groups) {
    std::vector<cv::Point2f> p0, guess;
    std::vector<std::pair<int64_t, std::pair<size_t, size_t>>> spans;
    for (int64_t id : ids) {
      const Memory& m = memory_.at(id);
      const cv::Rect2f& box = boxes.at(id);
      // The box's own motion (scale about its centre plus translation) is the initial guess of each point.
      const float sx = m.box.width > 0 ? box.width / m.box.width : 1.f;
      const float sy = m.box.height > 0 ? box.height / m.box.height : 1.f;
      const size_t first = p0.size();
      for (const cv::Point2f& q : m.points) {
        p0.push_back(q);
        guess.emplace_back(box.x + (q.x - m.box.x) * sx, box.y + (q.y - m.box.y) * sy);
      }
      spans.push_back({id, {first, p0.size()}});
    }
    std::vector<cv::Point2f> p1 = guess, back = p0;
    std::vector<uchar> st1, st2;
    std::vector<float> err;
    cv::calcOpticalFlowPyrLK(*before, pyramid, p0, p1, st1, err, win, cfg_.pyramid_levels, crit,
                             cv::OPTFLOW_USE_INITIAL_FLOW);
    cv::calcOpticalFlowPyrLK(pyramid, *before, p1, back, st2, err, win, cfg_.pyramid_levels, crit,
                             cv::OPTFLOW_USE_INITIAL_FLOW);
    for (const auto& [id, span] : spans) {
      const cv::Rect2f& box = boxes.at(id);
      // Points may move a little outside a jittery box, never far.
      const cv::Rect2f keep(box.x - 0.1f * box.width, box.y - 0.1f * box.height, 1.2f * box.width,
                            1.2f * box.height);
      const double off_box_px = cfg_.max_off_box_fraction * std::max(box.width, box.height);
      std::vector<cv::Point2f> a, b;
      int off_box = 0;
      for (size_t k = span.first; k < span.second; ++k) {
        if (!st1[k] || !st2[k]) continue;
        if (cv::norm(back[k] - p0[k]) > cfg_.max_fb_error_px) continue;
        if (!keep.contains(p1[k])) continue;
        // guess[k] is where the box's motion carries the point.
        if (cv::norm(p1[k] - guess[k]) > off_box_px) {
          ++off_box;
          continue;
        }
        a.push_back(p0[k]);
        b.push_back(p1[k]);
      }
      ScaleRatio r = scale_from_matches(a, b, cfg_.min_pair_px, cfg_.min_points);
      r.dt = t - memory_.at(id).t;
      r.off_box = off_box;
      out[id] = r;
    }
  }

  // Fresh corners for the next frame, inside the trimmed box.
  const auto shared = std::make_shared<const std::vector<cv::Mat>>(std::move(pyramid));
  std::map<int64_t, Memory> next;
  // A box missing this time keeps its points while they could still be bridged.
  for (auto& [id, m] : memory_)
    if (!boxes.count(id) && !m.points.empty() && t - m.t < cfg_.max_bridge_s - 1e-9) {
      m.missed = true;
      next[id] = std::move(m);
    }
  for (const auto& [id, box] : boxes) {
    Memory m;
    m.box = box;
    m.pyramid = shared;
    m.t = t;
    if (box.width >= cfg_.min_box_px && box.height >= cfg_.min_box_px) {
      const float fx = static_cast<float>(cfg_.inner_fraction) * box.width;
      const float fy = static_cast<float>(cfg_.inner_fraction) * box.height;
      const cv::Rect2f inner =
          cv::Rect2f(box.x + fx, box.y + fy, box.width - 2 * fx, box.height - 2 * fy) & frame;
      const cv::Rect roi(
          cv::Point(static_cast<int>(std::ceil(inner.x)), static_cast<int>(std::ceil(inner.y))),
          cv::Point(static_cast<int>(inner.x + inner.width), static_cast<int>(inner.y + inner.height)));
      if (roi.width >= 4 && roi.height >= 4) {
        // Corners of a large box are sought on a coarser pyramid level (at most ~96 px tall there): the search
        // costs with the box's area, and LK refines every point on the full image anyway.
        int level = 0;
        while (level < static_cast<int>(shared->size()) - 1 && (roi.height >> level) > 96) ++level;
        const int f = 1 << level;
        const cv::Rect r(roi.x / f, roi.y / f, roi.width / f, roi.height / f);
        const cv::Mat& img = (*shared)[static_cast<size_t>(level)];
        const cv::Rect in = r & cv::Rect(0, 0, img.cols, img.rows);
        std::vector<cv::Point2f> corners;
        if (in.width >= 4 && in.height >= 4)
          cv::goodFeaturesToTrack(img(in), corners, cfg_.max_points, cfg_.quality,
                                  std::max(1.0, cfg_.min_corner_px / f));
        for (cv::Point2f& c : corners) m.points.emplace_back((c.x + in.x) * f, (c.y + in.y) * f);
      }
    }
    next[id] = std::move(m);
  }
  memory_ = std::move(next);
  return out;
}

}  // namespace hf::estimation
