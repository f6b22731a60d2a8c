// Overlay drawing for the annotated video: class-coloured boxes with labels and one banner per metric.
#include "overlay.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <opencv2/imgproc.hpp>

namespace hf::sink {

cv::Scalar class_color(const std::string& label) {
  static const std::map<std::string, cv::Scalar> kColors = {
      {"car", {255, 140, 0}},    {"truck", {0, 165, 255}}, {"bus", {0, 220, 220}},
      {"person", {255, 0, 255}}, {"bicycle", {0, 255, 0}}, {"motorcycle", {255, 255, 0}},
  };
  auto it = kColors.find(label);
  return it == kColors.end() ? cv::Scalar(200, 200, 200) : it->second;
}

std::string format_value(double v, const std::string& unit) {
  if (!std::isfinite(v)) return "inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return unit.empty() ? std::string(buf) : std::string(buf) + " " + unit;
}

namespace {

// Text with a filled background so it stays readable on any image.
void label_box(cv::Mat& img, const std::string& text, cv::Point org, double scale, const cv::Scalar& bg,
               const cv::Scalar& fg = cv::Scalar(255, 255, 255)) {
  int base = 0;
  const int th = std::max(1, static_cast<int>(std::lround(scale * 2)));
  const cv::Size ts = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, th, &base);
  // Keep the whole label on screen: boxes at the right or top edge would otherwise cut it off.
  org.x = std::max(0, std::min(org.x, img.cols - ts.width - 4));
  org.y = std::max(org.y, ts.height + base);
  cv::Rect r(org.x, org.y - ts.height - base, ts.width + 4, ts.height + base + 4);
  r &= cv::Rect(0, 0, img.cols, img.rows);
  cv::rectangle(img, r, bg, cv::FILLED);
  cv::putText(img, text, cv::Point(org.x + 2, org.y - base / 2 + 1), cv::FONT_HERSHEY_SIMPLEX, scale, fg, th,
              cv::LINE_AA);
}

}  // namespace

void draw_overlay(cv::Mat& img, int64_t frame_index, double timestamp, const OverlayInputs& in,
                  int thickness, double box_scale) {
  auto scaled = [box_scale](const cv::Rect2f& b) {
    return cv::Rect(cv::Rect2d(b.x * box_scale, b.y * box_scale, b.width * box_scale, b.height * box_scale));
  };
  const double scale = std::max(0.35, img.rows / 720.0 * 0.55);
  const int line_h = static_cast<int>(std::lround(28 * scale / 0.55));

  // Raw detections: thin boxes, so tracked objects (thick) stand out.
  if (in.detections)
    for (const Detection& d : in.detections->items)
      cv::rectangle(img, scaled(d.box), class_color(d.label), 1, cv::LINE_AA);

  std::map<int64_t, const ObjectState*> state_of;
  if (in.states)
    for (const ObjectState& s : in.states->objects) state_of[s.track_id] = &s;

  auto object_text = [&](int64_t id, const std::string& label) {
    std::string t = "#" + std::to_string(id) + " " + label;
    if (auto it = state_of.find(id); it != state_of.end() && std::isfinite(it->second->distance_m)) {
      char buf[32];
      std::snprintf(buf, sizeof buf, " %.1f m", it->second->distance_m);
      t += buf;
    }
    for (const auto& [name, r] : in.risks)
      for (const ObjectRisk& o : r->objects)
        if (o.track_id == id && (std::isfinite(o.value) || o.in_path))
          t += " " + name + " " + format_value(o.value, r->unit);
    return t;
  };
  auto draw_object = [&](const cv::Rect2f& box, int64_t id, const std::string& label, bool predicted) {
    const cv::Scalar c = class_color(label);
    const cv::Rect r = scaled(box);
    cv::rectangle(img, r, c, predicted ? 1 : thickness, cv::LINE_AA);
    label_box(img, object_text(id, label), r.tl(),
              scale * 0.8, c, cv::Scalar(0, 0, 0));
  };
  if (in.tracks) {
    for (const Track& t : in.tracks->items) draw_object(t.box, t.id, t.label, t.misses > 0);
  } else if (in.states) {
    for (const ObjectState& s : in.states->objects) draw_object(s.box, s.track_id, s.label, false);
  }

  // One banner per metric, top left.
  int y = line_h;
  for (const auto& [name, r] : in.risks) {
    const bool unsafe = r->label == SafetyLabel::kUnsafe;
    std::string text = name + ": " + to_string(r->label) + "  " + format_value(r->scene_value, r->unit);
    if (r->critical_track >= 0) text += "  (#" + std::to_string(r->critical_track) + ")";
    label_box(img, text, cv::Point(8, y), scale, unsafe ? kUnsafeColor : kSafeColor);
    y += line_h;
  }
  char buf[64];
  std::snprintf(buf, sizeof buf, "frame %lld  t=%.2f s", static_cast<long long>(frame_index), timestamp);
  label_box(img, buf, cv::Point(8, img.rows - 8), scale * 0.8, cv::Scalar(40, 40, 40));
}

}  // namespace hf::sink
