// xosc sink: gathers the scene's road, the ego path and the coordinates; writes scenario, road and catalog.
#include "xosc_sink.hpp"

#include <filesystem>

#include <hazardforge/atomic_file.hpp>
#include <hazardforge/number_text.hpp>
#include <hazardforge/output_path.hpp>
#include "hazardforge/geometry.hpp"
#include "hazardforge/hazard/template_base.hpp"
#include "xosc_writer.hpp"

namespace hf {

namespace {

// The road the spec was designed on (HazardSpec::road, the generator's); specs without one get the road the
// templates assume by default.
road::LaneLayout scene_lanes(const HazardSpec& spec, double* kerb_offset) {
  const RoadLayout r = spec.road.value_or(RoadLayout{});
  road::LaneLayout l;
  l.lane_width = r.lane_width_m;
  l.lanes_left = r.lanes_left;
  l.lanes_right = r.lanes_right;
  *kerb_offset = r.kerb_offset_m;
  if (!spec.road) return l;
  l.edge_width = r.sidewalk_width_m;
  l.oncoming_lanes = r.oncoming_lanes;
  l.left_hand_traffic = r.driving_side == "left";
  l.edge_type = r.sidewalks ? "sidewalk" : r.pedestrians_without_sidewalks ? "shoulder" : "";
  if (l.edge_width < 0.1) l.edge_type.clear();  // no room beside the road: no lane there
  return l;
}

std::filesystem::path with_suffix(const std::string& file, int n, const std::string& ext) {
  const std::filesystem::path f(file);
  const std::string stem = f.stem().string() + (n > 1 ? "_" + std::to_string(n) : "");
  return f.parent_path() / (stem + ext);
}

}  // namespace

ComponentInfo XoscSink::describe() {
  ComponentInfo i;
  i.name = "xosc";
  i.kind = kind::kSink;
  i.summary =
      "writes each planned hazard as an ASAM OpenSCENARIO 1.2 (.xosc) scenario with an OpenDRIVE road";
  i.doc =
      "The road (.xodr beside the .xosc) is fitted to the ego's path, with the scene's lanes, driving side "
      "and "
      "sidewalks from the spec's road (HazardSpec::road). The ego starts in its lane at its recorded speed "
      "(controlled "
      "by the player or a system under test; 'replay' adds its recorded speed profile). The hazard starts "
      "relative to the ego and its manoeuvre (lane change, speed change, walk) is started by a condition on "
      "the "
      "ego, after a lead-in; the story ends when the ego has driven after_s (at its planned speed) past the "
      "plan's "
      "critical moment, at a collision, or at twice the critical moment plus after_s. "
      "Parameters for the hazard's speed, start gap, deceleration and trigger value can be swept.";
  i.inputs = {sticky(port<HazardTrajectory>("trajectory", "the planned hazard")),
              optional(port<Frame>("frames", "the anchor frame's ego pose, for world coordinates"))};
  i.params = {
      ParamSpec::string("file", "scenario.xosc").describe("file written below the run's output folder"),
      ParamSpec::string("catalog", "hazard_maneuvers.xosc")
          .describe("hazard maneuver catalog written once per run below the output folder (empty: none)"),
      ParamSpec::string("ego", "controlled")
          .one_of({"controlled", "replay"})
          .describe("controlled: the ego gets its lane and initial speed only; replay: it also follows its "
                    "recorded speed profile"),
      ParamSpec::number("lead_in_s", 3.0)
          .range(0, 60)
          .describe("seconds before the hazard's manoeuvre starts"),
      ParamSpec::number("after_s", 3.0)
          .range(0, 60)
          .describe("seconds after the plan's critical moment (driven at the ego's planned speed) before the "
                    "story ends"),
      ParamSpec::string("author", "HazardForge").describe("FileHeader author"),
      ParamSpec::string("description", "")
          .describe("FileHeader description (empty: kind, class and rationale)"),
      ParamSpec::string("coordinates", "auto")
          .one_of({"auto", "anchor", "world"})
          .describe(
              "anchor: the plan's anchor frame; world: the dataset's frame (needs the ego pose); auto: world "
              "when the pose is known"),
      ParamSpec::string("ego_name", "Ego").describe("entity name of the ego"),
      ParamSpec::string("hazard_name", "Hazard").describe("entity name of the hazard"),
      ParamSpec::number("ego_front_m", 3.4)
          .range(0, 20)
          .describe("ego rear axle to front bumper (m), for its box"),
      ParamSpec::path("limits", "")
          .describe("kinematic limits per class (default: share/hazard_limits.yaml)"),
      ParamSpec::path("class_sizes", "")
          .describe("object sizes per class, for the ego car (default: share/class_sizes.yaml)"),
  };
  return i;
}

void XoscSink::open(StageContext& ctx) {
  const Params& p = ctx.params();
  file_ = p.get_string("file");
  output_param_path(ctx, "file");  // refused at open when it would leave the run folder
  if (file_.empty()) throw Error("node '" + ctx.node_id() + "': parameter 'file' is empty");
  catalog_ = p.get_string("catalog");
  // Refused before the first frame when a name would leave the run folder.
  output_param_path(ctx, "file");
  if (!catalog_.empty()) output_param_path(ctx, "catalog");
  ego_mode_ = p.get_string("ego");
  lead_in_ = p.get_double("lead_in_s");
  after_ = p.get_double("after_s");
  author_ = p.get_string("author");
  description_ = p.get_string("description");
  coordinates_ = p.get_string("coordinates");
  ego_name_ = p.get_string("ego_name");
  hazard_name_ = p.get_string("hazard_name");
  ego_front_ = p.get_double("ego_front_m");
  if (ego_name_.empty() || hazard_name_.empty() || ego_name_ == hazard_name_)
    throw Error("node '" + ctx.node_id() + "': ego_name and hazard_name must be non-empty and differ");
  const std::string limits = p.get_path("limits").string();
  limits_ = LimitsTable::load(limits.empty() ? LimitsTable::default_path() : limits);
  const std::string sizes = p.get_path("class_sizes").string();
  const ClassSize car =
      ClassPriors::load(sizes.empty() ? share_dir() + "/class_sizes.yaml" : sizes).at("car");
  ego_size_ = cv::Vec3d(car.length, car.width, car.height);
}

void XoscSink::process(StageContext& ctx, const Inputs& in, Outputs& /*out*/) {
  const Packet* packet = in.packet("trajectory");
  if (!packet || packet->empty()) return;
  const auto traj = packet->share<HazardTrajectory>();
  if (traj.get() == last_) return;
  last_ = traj.get();

  XoscOptions opt;
  opt.author = author_;
  opt.description = description_;
  opt.ego_name = ego_name_;
  opt.hazard_name = hazard_name_;
  opt.ego_limits = limits_.at("car");
  if (limits_.has(traj->object_class))
    opt.hazard_limits = limits_.at(traj->object_class);
  else if (traj->object_class != "person")
    throw Error("xosc: object_class '" + traj->object_class + "' has no kinematic limits in " +
                limits_.file());
  opt.ego_size_lwh = ego_size_;
  opt.ego_front = ego_front_;
  if (coordinates_ != "anchor") {
    const Frame* f = in.get<Frame>("frames");
    const bool at_anchor = f && std::abs(f->timestamp - traj->anchor_time) < 1e-6;
    if (at_anchor && f->ego.T_world_ego)
      opt.T_world_anchor = f->ego.T_world_ego;
    else if (coordinates_ == "world")
      throw Error("xosc: coordinates 'world' needs the ego pose of the anchor frame (t=" +
                  num_text(traj->anchor_time, 3) + " s)" +
                  (at_anchor ? "; frame " + std::to_string(f->index) + " carries none"
                             : "; connect the frames input"));
  }
  opt.lanes = scene_lanes(traj->spec, &opt.kerb_offset);
  opt.ego_mode = ego_mode_;
  opt.lead_in_s = lead_in_;
  opt.after_s = after_;
  // The recording's ego track (dataset poses or the video's ego motion) carries the road before and after
  // the plan.
  if (const Frame* f = in.get<Frame>("frames"); f && std::abs(f->timestamp - traj->anchor_time) < 1e-6 &&
                                                f->ego_track && f->ego_track->samples.size() >= 2) {
    const std::string where =
        "xosc: frame " + std::to_string(f->index) + " (" + f->ego_track->source + " ego track)";
    opt.ego_path = hazard::EgoPath::recorded(f->ego_track->samples, traj->anchor_time, where);
  }
  ++written_;
  const std::filesystem::path xosc_name =
      with_suffix(file_, written_, std::filesystem::path(file_).extension().string());
  const std::filesystem::path xodr_name = with_suffix(file_, written_, ".xodr");
  opt.road_file = xodr_name.filename().string();
  const XoscExport ex = export_scenario(*traj, opt);
  // Every name stays inside the run folder (the output-path policy). The road first: a scenario is never on
  // disk without the road it names.
  const std::string what = "node '" + ctx.node_id() + "': param 'file'";
  write_file_atomic(resolve_output_path(ctx.output_dir(), xodr_name.string(), what), ex.xodr);
  write_file_atomic(resolve_output_path(ctx.output_dir(), xosc_name.string(), what), ex.xosc);
  if (!catalog_.empty() && !catalog_written_) {
    write_file_atomic(
        resolve_output_path(ctx.output_dir(), catalog_, "node '" + ctx.node_id() + "': param 'catalog'"),
        write_hazard_catalog());
    catalog_written_ = true;
  }
  const XoscSummary& s = ex.summary;
  ctx.log(LogLevel::kInfo,
          "wrote " + xosc_name.string() + " and " + xodr_name.string() + " (" + traj->kind + ", " +
              (opt.T_world_anchor ? "world" : "anchor") + " coordinates): " + s.trigger + " " +
              num_text(s.trigger_value) + " starts the hazard at t=" + num_text(s.trigger_time) +
              " s, plan minimum TTC " + num_text(s.plan_min_ttc) + " s at t=" + num_text(s.critical_time) +
              " s, stop at " + num_text(s.stop_time) + " s");
}

}  // namespace hf
