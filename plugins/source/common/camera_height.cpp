// Camera height from the lane-line spacing seen in a bird's-eye view of the road.
#include "hazardforge/footage/camera_height.hpp"

#include "gray.hpp"
#include "median.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/imgproc.hpp>
#include "hazardforge/angles.hpp"

namespace hf::footage {

namespace {

constexpr int kWorkWidth = 960;

}  // namespace

CameraModel with_height(const CameraModel& camera, double height_m) {
  CameraModel c = camera;
  c.t_ego_cam[2] = height_m;
  return c;
}

struct CameraHeightEstimator::Impl {
  CameraModel cam;
  HeightOptions opt;
  double scale = 1.0;
  cv::Mat map_x, map_y, valid;
  std::vector<double> widths;
  std::optional<double> last;
  int seen = 0;
  // Lane markings: per side (0 = left, 1 = right), the frames in which the ego lane's line was found, its
  // fill per frame, the frames that saw it yellow and those that saw a further dashed line a lane width
  // beyond.
  struct SideVotes {
    int found = 0, yellow = 0, further = 0;
    std::vector<double> fills;
  };
  SideVotes sides[2];
  // One lane line of one frame: lateral position (bins of the heading-corrected profile), the share of the
  // visible view's rows it covers, and whether its paint is yellow.
  struct Line {
    double pos = 0, fill = 0;
    bool yellow = false;
  };

  Impl(const CameraModel& c, const HeightOptions& o) : cam(c), opt(o) {
    scale = cam.width > kWorkWidth ? static_cast<double>(kWorkWidth) / cam.width : 1.0;
    const double res = opt.resolution_m;
    const int rows = static_cast<int>(std::ceil((opt.far_m - opt.near_m) / res));
    const int cols = static_cast<int>(std::ceil(2 * opt.half_width_m / res));
    map_x.create(rows, cols, CV_32F);
    map_y.create(rows, cols, CV_32F);
    valid = cv::Mat::zeros(rows, cols, CV_8U);
    const double hcam = cam.height_above_ground();
    const double bottom = cam.height * (1.0 - opt.bonnet_fraction);
    for (int r = 0; r < rows; ++r) {
      const double fwd = opt.far_m - (r + 0.5) * res;
      for (int c = 0; c < cols; ++c) {
        const double lat = opt.half_width_m - (c + 0.5) * res;
        const auto px = cam.project_ego(cv::Vec3d(cam.t_ego_cam[0] + fwd, cam.t_ego_cam[1] + lat, 0.0));
        float mx = -1, my = -1;
        if (px && px->x >= 1 && px->x < cam.width - 2 && px->y >= 1 && px->y < bottom &&
            std::atan2(hcam, std::hypot(fwd, lat)) > opt.horizon_margin_deg * kRadPerDeg) {
          mx = static_cast<float>(px->x * scale);
          my = static_cast<float>(px->y * scale);
          valid.at<uchar>(r, c) = 255;
        }
        map_x.at<float>(r, c) = mx;
        map_y.at<float>(r, c) = my;
      }
    }
  }

  // Ego-lane width (m at the stated height) in one frame, or nullopt; the lines bounding the ego lane (and a
  // further one beyond each) go to `left_lines` / `right_lines`, nearest first.
  std::optional<double> measure(const cv::Mat& bgr, std::vector<Line>* left_lines = nullptr,
                                std::vector<Line>* right_lines = nullptr) const {
    if (bgr.empty()) return std::nullopt;
    cv::Mat small = bgr;
    if (small.cols != cam.width || small.rows != cam.height)
      cv::resize(small, small, cv::Size(cam.width, cam.height));
    if (scale < 1.0) cv::resize(small, small, cv::Size(), scale, scale, cv::INTER_AREA);
    cv::Mat gray = detail::gray8(small);
    cv::Mat bev, bev_hsv;
    cv::remap(gray, bev, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
    if (small.channels() == 3) {
      cv::Mat bev_bgr;
      cv::remap(small, bev_bgr, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0, 0, 0));
      cv::cvtColor(bev_bgr, bev_hsv, cv::COLOR_BGR2HSV);
    }
    cv::GaussianBlur(bev, bev, cv::Size(3, 3), 0.8);
    const double res = opt.resolution_m;
    const int k = std::max(2, static_cast<int>(std::lround(opt.ridge_offset_m / res)));
    const int rows = bev.rows, cols = bev.cols;
    // Ridge pixels: brighter than both sides (lateral offset k) by min_contrast.
    std::vector<cv::Point> ridge;
    for (int r = 0; r < rows; ++r) {
      const uchar* b = bev.ptr<uchar>(r);
      const uchar* v = valid.ptr<uchar>(r);
      for (int c = k; c < cols - k; ++c) {
        if (!v[c] || !v[c - k] || !v[c + k]) continue;
        const int d = std::min(b[c] - b[c - k], b[c] - b[c + k]);
        if (d >= opt.min_contrast) ridge.emplace_back(c, r);
      }
    }
    if (ridge.size() < 20) return std::nullopt;
    // Lines are parallel in the bird's-eye view (for a correct pitch and a straight road): the heading whose
    // lateral profile of ridge pixels is most concentrated is the lanes' heading.
    const int pad = rows;  // |tan| <= ~0.2 keeps the shift within +- rows / 4
    const int bins = cols + 2 * pad;
    double best_score = -1, best_tan = 0;
    std::vector<double> best_prof;
    for (double hd = -opt.max_heading_deg; hd <= opt.max_heading_deg + 1e-9; hd += 0.5) {
      const double tn = std::tan(hd * kRadPerDeg);
      std::vector<double> prof(static_cast<size_t>(bins), 0.0);
      // Lateral offset measured along the row at the camera (row index of the camera = far_m / res).
      const double r_cam = opt.far_m / res;
      for (const cv::Point& p : ridge) {
        const int b = static_cast<int>(std::lround(p.x - (r_cam - p.y) * tn)) + pad;
        if (b >= 0 && b < bins) prof[static_cast<size_t>(b)] += 1.0;
      }
      std::vector<double> sm(prof.size(), 0.0);
      for (size_t i = 1; i + 1 < prof.size(); ++i)
        sm[i] = 0.25 * prof[i - 1] + 0.5 * prof[i] + 0.25 * prof[i + 1];
      double score = 0;
      for (double x : sm) score += x * x;
      if (score > best_score) {
        best_score = score;
        best_tan = tn;
        best_prof = sm;
      }
    }
    // Near support: a vehicle ahead leaves bright streaks in a bird's-eye view too, but they start at its
    // wheels; the road just in front of the camera is nearly always road, so a lane line must show in the
    // nearest near_support_m of the visible view.
    int r_bottom = -1;
    for (int r = rows - 1; r >= 0 && r_bottom < 0; --r)
      if (cv::countNonZero(valid.row(r)) > cols / 4) r_bottom = r;
    const int r_near = r_bottom - static_cast<int>(std::lround(opt.near_support_m / res));
    std::vector<double> near_prof(static_cast<size_t>(bins), 0.0);
    {
      const double r_cam = opt.far_m / res;
      for (const cv::Point& p : ridge) {
        if (p.y < r_near) continue;
        const int b = static_cast<int>(std::lround(p.x - (r_cam - p.y) * best_tan)) + pad;
        if (b >= 0 && b < bins) near_prof[static_cast<size_t>(b)] += 1.0;
      }
    }
    const double min_near = opt.min_near_support_m / res * 2.0;
    auto near_support = [&](int i) {
      double n = 0;
      for (int j = std::max(0, i - 2); j <= std::min(bins - 1, i + 2); ++j)
        n += near_prof[static_cast<size_t>(j)];
      return n;
    };
    // Peaks: local maxima over +- 0.4 m, covering min_line_fill of the searched length.
    const double cosh = 1.0 / std::sqrt(1.0 + best_tan * best_tan);
    const double min_count = opt.min_line_fill * (opt.far_m - opt.near_m) / res * 2.0;  // ~2 ridge px per row
    const int win = std::max(3, static_cast<int>(std::lround(0.4 / res)));
    const double cam_col = opt.half_width_m / res - 0.5 + pad;  // lateral 0 (the camera) in profile bins
    std::optional<double> left, right;  // nearest line on each side, in bins (sub-bin)
    std::vector<double> peaks;          // every line found (bins)
    for (int i = win; i < bins - win; ++i) {
      const double v = best_prof[static_cast<size_t>(i)];
      if (v < min_count) continue;
      bool is_max = true;
      for (int j = i - win; j <= i + win && is_max; ++j)
        if (best_prof[static_cast<size_t>(j)] > v || (best_prof[static_cast<size_t>(j)] == v && j < i))
          is_max = false;
      if (!is_max) continue;
      const double a = best_prof[static_cast<size_t>(i - 1)], c = best_prof[static_cast<size_t>(i + 1)];
      const double den = a - 2 * v + c;
      const double pos = i + (std::abs(den) > 1e-9 ? 0.5 * (a - c) / den : 0.0);
      peaks.push_back(pos);
      if (near_support(i) < min_near) continue;
      if (pos < cam_col) {  // smaller column = left of the camera
        if (!left || pos > *left) left = pos;
      } else {
        if (!right || pos < *right) right = pos;
      }
    }
    // A line's fill (rows of the visible view with ridge pixels on it: a solid line fills nearly all of them,
    // a dashed one a quarter to a half) and its paint (yellow when most of its ridge pixels are).
    auto describe = [&](double pos) {
      Line l;
      l.pos = pos;
      const double r_cam = opt.far_m / res;
      std::vector<char> hit(static_cast<size_t>(rows), 0);
      int yellow = 0, painted = 0;
      for (const cv::Point& p : ridge) {
        const double b = p.x - (r_cam - p.y) * best_tan + pad;
        if (std::abs(b - pos) > 2.0) continue;
        hit[static_cast<size_t>(p.y)] = 1;
        if (!bev_hsv.empty()) {
          const cv::Vec3b h = bev_hsv.at<cv::Vec3b>(p.y, p.x);
          ++painted;
          yellow += (h[0] >= 12 && h[0] <= 38 && h[1] >= 60) ? 1 : 0;  // OpenCV hue 0-180: 24-76 deg
        }
      }
      int visible = 0, covered = 0;
      for (int r = 0; r < rows; ++r) {
        const int c = static_cast<int>(std::lround(pos - pad + (r_cam - r) * best_tan));
        if (c < 0 || c >= cols || !valid.at<uchar>(r, c)) continue;
        ++visible;
        covered += hit[static_cast<size_t>(r)] ? 1 : 0;
      }
      l.fill = visible > 0 ? static_cast<double>(covered) / visible : 0.0;
      l.yellow = painted > 0 && yellow > painted / 2;
      return l;
    };
    std::optional<double> w;
    if (left && right) {
      const double width = (*right - *left) * res * cosh;
      if (width >= opt.lane_width_m / opt.max_ratio && width <= opt.lane_width_m * opt.max_ratio) w = width;
    }
    // The markings: on each side the nearest line within 0.9 assumed lane widths of the camera bounds the ego
    // lane (a dashed line need not show in the nearest metres, where a gap may fall), and the nearest further
    // line about a lane width (the ego lane's, else the assumed one) beyond it. Lines further than that from
    // the camera are another lane's, not the ego lane's.
    const double lane_bins = (w ? *w : opt.lane_width_m) / (res * cosh);
    const double reach_bins = 0.9 * opt.lane_width_m / (res * cosh);
    auto collect = [&](int dir, std::vector<Line>* out) {
      if (!out) return;
      std::optional<double> first;
      for (double q : peaks) {
        const double d = (q - cam_col) * dir;
        if (d > 0 && d <= reach_bins && (!first || d < (*first - cam_col) * dir)) first = q;
      }
      if (!first) return;
      out->push_back(describe(*first));
      for (double q : peaks) {
        const double d = (q - *first) * dir;
        if (d > 0.7 * lane_bins && d < 1.3 * lane_bins) {
          out->push_back(describe(q));
          break;
        }
      }
    };
    collect(-1, left_lines);
    collect(+1, right_lines);
    return w;
  }
};

CameraHeightEstimator::CameraHeightEstimator(const CameraModel& camera, HeightOptions opt)
    : impl_(std::make_unique<Impl>(camera, opt)) {}
CameraHeightEstimator::~CameraHeightEstimator() = default;
CameraHeightEstimator::CameraHeightEstimator(CameraHeightEstimator&&) noexcept = default;
CameraHeightEstimator& CameraHeightEstimator::operator=(CameraHeightEstimator&&) noexcept = default;

void CameraHeightEstimator::add(const cv::Mat& bgr) {
  Impl& s = *impl_;
  ++s.seen;
  std::vector<Impl::Line> lines[2];
  s.last = s.measure(bgr, &lines[0], &lines[1]);
  if (s.last) s.widths.push_back(*s.last);
  for (int side = 0; side < 2; ++side) {
    if (lines[side].empty()) continue;
    Impl::SideVotes& v = s.sides[side];
    ++v.found;
    v.fills.push_back(lines[side][0].fill);
    v.yellow += lines[side][0].yellow ? 1 : 0;
    v.further +=
        lines[side].size() > 1 && !lines[side][1].yellow && lines[side][1].fill < s.opt.max_dashed_fill ? 1
                                                                                                        : 0;
  }
}

std::optional<RoadMarkings> CameraHeightEstimator::markings() const {
  const Impl& s = *impl_;
  if (s.seen == 0) return std::nullopt;
  RoadMarkings m;
  m.source = "video";
  m.frames = s.seen;
  std::ostringstream note;
  note.precision(2);
  for (int side = 0; side < 2; ++side) {
    const Impl::SideVotes& v = s.sides[side];
    LaneMarkingSide& out = side == 0 ? m.left : m.right;
    out.seen_share = static_cast<double>(v.found) / s.seen;
    note << (side == 0 ? "left: " : "; right: ");
    if (v.found < s.opt.min_frames || out.seen_share < s.opt.min_marking_share) {
      out.boundary = v.found == 0 ? "none" : "";
      note << "line in " << v.found << " of " << s.seen << " frames (too few to say)";
      continue;
    }
    const double fill = detail::upper_median(v.fills);
    out.colour = v.yellow * 2 > v.found ? "yellow" : "white";
    if (fill >= s.opt.min_solid_fill) {
      out.boundary = "solid";
      out.lanes = 0;
    } else if (fill <= s.opt.max_dashed_fill) {
      out.boundary = "dashed";
      out.lanes = 1 + (v.further >= s.opt.min_marking_share * v.found ? 1 : 0);
    } else {
      out.boundary = "";  // between the two: neither a clear dash pattern nor an unbroken line
    }
    note << (out.boundary.empty() ? "unclear" : out.boundary) << " " << out.colour << " line in " << v.found
         << " of " << s.seen << " frames (median fill " << fill << ")";
    if (out.boundary == "dashed") note << ", a further dashed line beyond in " << v.further;
  }
  m.note = note.str();
  return m;
}

std::optional<double> CameraHeightEstimator::last_lane_width() const {
  return impl_->last;
}

std::optional<HeightEstimate> CameraHeightEstimator::result() const {
  const Impl& s = *impl_;
  const int n = static_cast<int>(s.widths.size());
  if (n < s.opt.min_frames) return std::nullopt;
  const double med = detail::upper_median(s.widths);
  std::vector<double> dev;
  for (double w : s.widths) dev.push_back(std::abs(w - med));
  const double spread = 1.4826 * detail::upper_median(dev) / med;
  if (spread > s.opt.max_frame_spread) return std::nullopt;
  HeightEstimate e;
  const double h0 = s.cam.height_above_ground();
  e.height_m = h0 * s.opt.lane_width_m / med;
  const double rel_assume = s.opt.lane_width_sigma_m / s.opt.lane_width_m;
  const double rel_meas = spread / std::sqrt(static_cast<double>(n));
  e.sigma_m = e.height_m * std::sqrt(rel_assume * rel_assume + rel_meas * rel_meas);
  e.frames_used = n;
  e.frames_seen = s.seen;
  e.lane_width_at_assumed_height_m = med;
  e.frame_spread = spread;
  e.confidence = std::min(1.0, static_cast<double>(n) / s.opt.full_confidence_frames) *
                 std::exp(-0.5 * std::pow(spread / 0.05, 2));
  std::ostringstream note;
  note.precision(3);
  note << "lane lines " << med << " m apart at " << h0 << " m in " << n << " of " << s.seen
       << " frames (spread " << 100 * spread << " %), assumed lane width " << s.opt.lane_width_m << " +- "
       << s.opt.lane_width_sigma_m << " m";
  e.note = note.str();
  return e;
}

std::optional<HeightEstimate> estimate_camera_height(const std::vector<cv::Mat>& frames,
                                                     const CameraModel& camera, HeightOptions opt) {
  CameraHeightEstimator est(camera, opt);
  for (const cv::Mat& f : frames) est.add(f);
  return est.result();
}

}  // namespace hf::footage
