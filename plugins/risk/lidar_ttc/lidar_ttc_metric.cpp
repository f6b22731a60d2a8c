// LidarTtcMetric: per frame, project the scan, range every box, pick the lead and update the TTC histories.
#include "lidar_ttc_metric.hpp"

#include <cmath>
#include <cstdio>

namespace hf {

namespace fs = std::filesystem;

namespace {

Json num_or_null(double v) {
  return std::isnan(v) ? Json() : std::isinf(v) ? Json(v > 0 ? "inf" : "-inf") : Json(v);
}

}  // namespace

ComponentInfo LidarTtcMetric::describe() {
  ComponentInfo i;
  i.name = "lidar_ttc";
  i.kind = kind::kRiskMetric;
  i.summary = "lead-vehicle range from Velodyne points in its camera box and constant-velocity TTC (s)";
  i.doc =
      "KITTI raw: Velodyne points above ground_z are projected into image_02 with P2 R0_rect Tr_velo_to_cam; "
      "a point inside exactly one box (shrunk by box_shrink) belongs to it; a box's range is the median of "
      "its k_closest nearest points (range_statistic closest_median) or the percentile-th percentile, when "
      "it "
      "has min_points points. Range along camera 2's optical axis (range_axis camera) or Velodyne x (lidar). "
      "The lead is the in-path box with the smallest range: the corridor test on its range and its points' "
      "median lateral offset, object width 0 (default 1.0 + 0.5 = within 1.5 m; corridor_path ego_path "
      "follows "
      "the frame's ego speed and yaw rate when it has them, else straight). TTC per object from its range "
      "history, constant closing speed fitted over the last "
      "`window` "
      "ranges (2 = TTC = d_t dt / (d_{t-1} - d_t)); infinite when not closing faster than min_closing_mps, "
      "unknown before two ranges. Scene value = the lead's TTC (unknown without a lead). One risk packet and "
      "one lidar_range record per frame, stamped with the frame's time. See docs/evaluation.md.";
  i.inputs = {port<Frame>("frames", "KITTI raw frames (the image name or the dataset frame number names the scan)"),
              optional(port<ObjectStates>("states", "tracked boxes (per-track TTC, lead = a track)")),
              optional(port<Detections>("detections", "detected boxes (TTC of the lead only)"))};
  i.outputs = {
      port<RiskAssessment>("risk", "lidar TTC per box; scene value = the lead's TTC"),
      port<Record>("range", "record 'lidar_range': every box's range and points, the lead, its TTC")};
  i.params = {
      ParamSpec::path("velodyne_dir", "").describe("folder of <frame>.bin Velodyne scans"),
      ParamSpec::path("velodyne_archive", "")
          .describe(
              "tar(.xz) of the scans, extracted once into <run folder>/velodyne (instead of velodyne_dir)"),
      ParamSpec::path("calib", "")
          .describe("calibration with P2, R0_rect, Tr_velo_to_cam (KITTI tracking format)"),
      ParamSpec::number("box_shrink", 0.10)
          .range(0, 0.9)
          .describe("fraction of the box width and height removed (half on each side) to reject background"),
      ParamSpec::number("ground_z", -1.5)
          .range(-10, 10)
          .describe("Velodyne z (m, up; sensor ~1.73 m above the road) below which points are road"),
      ParamSpec::string("range_axis", "camera")
          .one_of({"camera", "lidar"})
          .describe("camera = depth along camera 2's optical axis; lidar = Velodyne x"),
      ParamSpec::string("range_statistic", "closest_median")
          .one_of({"closest_median", "percentile"})
          .describe("closest_median = median of the k_closest nearest points; percentile = of all points"),
      ParamSpec::integer("k_closest", 20).range(1, 100000).describe("points in the closest-points median"),
      ParamSpec::number("percentile", 10.0).range(0, 100).describe("percentile of the box's ranges"),
      ParamSpec::integer("min_points", 10).range(1, 100000).describe("fewer points in a box = no range"),
      ParamSpec::integer("window", 2)
          .range(2, 1000)
          .describe("ranges in the least-squares closing-speed fit (2 = the plain two-frame formula)"),
      ParamSpec::number("min_closing_mps", 0.1)
          .range(0, 100)
          .describe("closing speeds at or below this (m/s) give an infinite TTC"),
      ParamSpec::number("max_range_jump_m", 2.0)
          .range(0, 1000)
          .describe("a range change larger than this between samples restarts the history (another object)"),
      ParamSpec::number("max_gap_s", 0.25)
          .range(0, 1000)
          .describe("a gap longer than this since the last range restarts the history (s)"),
      ParamSpec::number("threshold", 1.5).range(0, 1000).describe("Unsafe when the lead's TTC is below (s)"),
  };
  for (ParamSpec& p : Corridor::params()) i.params.push_back(std::move(p));
  return i;
}

void LidarTtcMetric::open(StageContext& ctx) {
  const Params& p = ctx.params();
  const fs::path dir = p.get_path("velodyne_dir"), archive = p.get_path("velodyne_archive");
  if (dir.empty() == archive.empty())
    throw Error("lidar_ttc: give exactly one of 'velodyne_dir' and 'velodyne_archive'");
  if (!dir.empty()) {
    if (!fs::is_directory(dir)) throw Error("lidar_ttc: velodyne_dir '" + dir.string() + "' is not a folder");
    velodyne_dir_ = dir;
  } else {
    velodyne_dir_ = lidar::extract_scans(archive, ctx.output_dir() / "velodyne");
    ctx.record_resource(archive);
    ctx.log(LogLevel::kInfo, "Velodyne scans from " + archive.string() + " in " + velodyne_dir_.string());
  }
  const fs::path calib = p.get_path("calib");
  if (calib.empty()) throw Error("lidar_ttc: 'calib' is required (P2, R0_rect, Tr_velo_to_cam)");
  calib_ = lidar::read_lidar_calibration(calib);
  ctx.record_resource(calib);
  range_.box_shrink = p.get_double("box_shrink");
  range_.ground_z = p.get_double("ground_z");
  range_.axis = p.get_string("range_axis") == "lidar" ? lidar::RangeAxis::kLidar : lidar::RangeAxis::kCamera;
  range_.statistic = p.get_string("range_statistic") == "percentile" ? lidar::RangeStatistic::kPercentile
                                                                     : lidar::RangeStatistic::kClosestMedian;
  range_.k_closest = static_cast<int>(p.get_int("k_closest"));
  range_.percentile = p.get_double("percentile");
  range_.min_points = static_cast<int>(p.get_int("min_points"));
  corridor_ = Corridor::from(p);
  window_ = static_cast<int>(p.get_int("window"));
  min_closing_ = p.get_double("min_closing_mps");
  max_jump_ = p.get_double("max_range_jump_m");
  max_gap_ = p.get_double("max_gap_s");
  threshold_ = p.get_double("threshold");
  tracks_.clear();
  lead_.clear();
}

fs::path LidarTtcMetric::scan_file(const Frame& f) const {
  if (!f.source_id.empty()) {
    const fs::path by_name = velodyne_dir_ / (fs::path(f.source_id).stem().string() + ".bin");
    if (fs::exists(by_name)) return by_name;
  }
  if (f.origin.dataset_frame) {
    char name[32];
    std::snprintf(name, sizeof name, "%010lld.bin", static_cast<long long>(*f.origin.dataset_frame));
    if (fs::exists(velodyne_dir_ / name)) return velodyne_dir_ / name;
  }
  throw Error("lidar_ttc: frame " + std::to_string(f.index) + " (" + f.source_id +
              "): no Velodyne scan in '" + velodyne_dir_.string() +
              "' (looked for <image name>.bin and the frame's 10-digit dataset number)");
}

lidar::CvTtc LidarTtcMetric::update(std::map<int64_t, History>& hist, int64_t id, double t, double range) {
  History& h = hist[id];
  if (!h.samples.empty() &&
      (t - h.samples.back().first > max_gap_ + 1e-9 || std::abs(range - h.samples.back().second) > max_jump_))
    h.samples.clear();
  h.samples.emplace_back(t, range);
  if (h.samples.size() > static_cast<size_t>(window_)) h.samples.erase(h.samples.begin());
  return lidar::constant_velocity_ttc(h.samples, window_, min_closing_);
}

void LidarTtcMetric::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  const Frame& f = in.require<Frame>("frames");
  const ObjectStates* states = in.get<ObjectStates>("states");
  const Detections* dets = in.get<Detections>("detections");
  const std::string what = "lidar_ttc: frame " + std::to_string(f.index) + " (" + f.source_id + ")";
  if (states && dets) throw Error(what + ": both 'states' and 'detections' carry boxes; connect only one");
  if (!states && !dets) throw Error(what + ": neither 'states' nor 'detections' has a packet; connect one");

  std::vector<int64_t> ids;
  std::vector<cv::Rect2d> boxes;
  if (states)
    for (const ObjectState& s : states->objects) {
      ids.push_back(s.track_id);
      boxes.emplace_back(s.box);
    }
  else
    for (size_t k = 0; k < dets->items.size(); ++k) {
      ids.push_back(static_cast<int64_t>(k));
      boxes.emplace_back(dets->items[k].box);
    }

  const fs::path scan = scan_file(f);
  const std::vector<lidar::ImagePoint> pts = lidar::project_points(lidar::read_scan(scan), calib_, range_);
  const std::vector<lidar::BoxRange> ranges = lidar::box_ranges(pts, boxes, range_);

  // The points' median offset stands for the object's centre line, so the box counts with width 0.
  const EgoPath path = corridor_.path_for(f.ego.speed_mps, f.ego.yaw_rate);
  std::vector<bool> in_lane(ranges.size());
  for (size_t k = 0; k < ranges.size(); ++k)
    in_lane[k] = !std::isnan(ranges[k].range) && !std::isnan(ranges[k].lateral) &&
                 corridor_.contains(ranges[k].range, ranges[k].lateral, 0.0, path);
  int lead = -1;
  for (size_t k = 0; k < ranges.size(); ++k) {
    const auto& r = ranges[k];
    if (!in_lane[k]) continue;
    if (lead < 0 || r.range < ranges[static_cast<size_t>(lead)].range) lead = static_cast<int>(k);
  }

  const double t = f.timestamp;
  std::vector<lidar::CvTtc> ttc(boxes.size());
  if (states) {
    std::map<int64_t, History> alive;
    for (size_t k = 0; k < boxes.size(); ++k) {
      if (std::isnan(ranges[k].range)) {
        // No range this frame: keep the history (a gap up to max_gap_s is bridged).
        if (auto it = tracks_.find(ids[k]); it != tracks_.end()) alive[ids[k]] = it->second;
        continue;
      }
      ttc[k] = update(tracks_, ids[k], t, ranges[k].range);
      alive[ids[k]] = tracks_[ids[k]];
    }
    tracks_ = std::move(alive);  // tracks gone from the tracker lose their history
  } else if (lead >= 0) {
    ttc[static_cast<size_t>(lead)] = update(lead_, 0, t, ranges[static_cast<size_t>(lead)].range);
  }

  RiskAssessment r;
  r.frame_index = f.index;
  r.metric = ctx.node_id();
  r.stage = "lidar_ttc";
  r.unit = "s";
  r.lower_is_riskier = true;
  r.threshold = threshold_;
  r.scene_value = NAN;
  Json box_rows = Json::array();
  for (size_t k = 0; k < boxes.size(); ++k) {
    r.objects.push_back({ids[k], ttc[k].ttc, in_lane[k]});
    box_rows.push_back({{"id", ids[k]},
                        {"box", {boxes[k].x, boxes[k].y, boxes[k].width, boxes[k].height}},
                        {"points", ranges[k].points},
                        {"range_m", num_or_null(ranges[k].range)},
                        {"nearest_m", num_or_null(ranges[k].nearest)},
                        {"lateral_m", num_or_null(ranges[k].lateral)},
                        {"in_lane", static_cast<bool>(in_lane[k])},
                        {"closing_mps", num_or_null(ttc[k].closing)},
                        {"ttc_s", num_or_null(ttc[k].ttc)}});
  }
  Record rec;
  rec.kind = "lidar_range";
  rec.data = {
      {"frame", f.index}, {"scan", scan.filename().string()}, {"points", pts.size()}, {"boxes", box_rows}};
  if (lead >= 0) {
    const auto k = static_cast<size_t>(lead);
    r.critical_track = ids[k];
    r.scene_value = ttc[k].ttc;
    rec.data["lead"] = {{"id", ids[k]},
                        {"range_m", ranges[k].range},
                        {"points", ranges[k].points},
                        {"lateral_m", ranges[k].lateral},
                        {"closing_mps", num_or_null(ttc[k].closing)},
                        {"ttc_s", num_or_null(ttc[k].ttc)}};
  } else {
    rec.data["lead"] = Json();
  }
  r.label = r.scene_value < threshold_ ? SafetyLabel::kUnsafe : SafetyLabel::kSafe;
  out.emit("risk", std::move(r));
  out.emit("range", std::move(rec));
}

}  // namespace hf
