// hazard_planner: picks the template registered for spec.kind, checks feasibility, plans, records the result.
#include "hazard_planner.hpp"

#include <algorithm>

#include <hazardforge/atomic_file.hpp>
#include <hazardforge/json_text.hpp>
#include <hazardforge/number_text.hpp>
#include <hazardforge/output_path.hpp>
#include "hazardforge/hazard/kinematics.hpp"

namespace hf {

ComponentInfo HazardPlanner::describe() {
  ComponentInfo i;
  i.name = "hazard_planner";
  i.kind = kind::kPlanner;
  i.summary = "plans the hazard's trajectory with the hazard template registered for spec.kind";
  i.doc =
      "Emits one HazardTrajectory per distinct spec, at the first frame with timestamp >= spec.start_time_s "
      "(the "
      "anchor frame), using ctx.components() to create the hazard_template named by spec.kind with "
      "templates[kind] as its params. An infeasible spec stops the run with the template's reasons "
      "(on_infeasible: error) or is recorded and skipped (on_infeasible: skip).";
  i.inputs = {sticky(port<HazardSpec>("hazard", "the hazard to insert")),
              port<Frame>("frames", "camera, ego speed and time of each frame"),
              optional(port<ObjectStates>("states", "tracked objects the hazard may build on"))};
  i.outputs = {port<HazardTrajectory>("trajectory", "object and ego motion in the anchor frame")};
  i.params = {
      ParamSpec::object("templates")
          .describe("per hazard kind, the params of its template, e.g. {cut_in: {duration_s: 4}}"),
      ParamSpec::number("ego_speed_mps", -1.0)
          .from_scene("ego.speed_mps")
          .range(-1, 100)
          .describe("ego speed when neither the frame nor the object states carry one (-1 = none)"),
      ParamSpec::string("on_infeasible", "error")
          .one_of({"error", "skip"})
          .describe("infeasible spec: stop or skip"),
      ParamSpec::string("file", "trajectory.json").describe("file written below the run's output folder"),
  };
  return i;
}

void HazardPlanner::open(StageContext& ctx) {
  const Params& p = ctx.params();
  templates_ = p.raw("templates");
  std::vector<std::string> names = ctx.components().component_names(kind::kHazardTemplate);
  std::sort(names.begin(), names.end());
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  for (auto it = templates_.begin(); it != templates_.end(); ++it) {
    if (!it->is_object())
      throw Error("node '" + ctx.node_id() + "': parameter 'templates': '" + it.key() +
                  "' must map to that template's params, got " + it->dump());
    if (std::find(names.begin(), names.end(), it.key()) == names.end())
      throw Error("node '" + ctx.node_id() + "': parameter 'templates' names '" + it.key() +
                  "', which is no registered hazard_template; registered: " + (list.empty() ? "none" : list));
  }
  ego_speed_param_ = p.get_double("ego_speed_mps");
  skip_infeasible_ = p.get_string("on_infeasible") == "skip";
  file_ = p.get_string("file");
  output_param_path(ctx, "file");  // refused at open when it would leave the run folder
  if (file_.empty()) throw Error("node '" + ctx.node_id() + "': parameter 'file' is empty");
}

void HazardPlanner::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  const HazardSpec* spec = in.get<HazardSpec>("hazard");
  if (!spec) return;
  const Frame& frame = in.require<Frame>("frames");
  const std::string key = Json(*spec).dump();
  if (key == last_spec_ || frame.timestamp + 1e-9 < spec->start_time_s) return;
  last_spec_ = key;
  const std::string where =
      "frame " + std::to_string(frame.index) + " (t=" + num_text(frame.timestamp, 3) + " s)";

  std::vector<std::string> names = ctx.components().component_names(kind::kHazardTemplate);
  std::sort(names.begin(), names.end());
  if (std::find(names.begin(), names.end(), spec->kind) == names.end()) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    throw Error("hazard kind '" + spec->kind + "' in the spec at " + where +
                " has no registered hazard_template; registered: " + (list.empty() ? "none" : list));
  }

  SceneContext scene;
  scene.timestamp = frame.timestamp;
  scene.camera = frame.camera;
  scene.origin = frame.origin;
  scene.ego_track = frame.ego_track;
  scene.road_markings = frame.road_markings;
  scene.road = spec->road;  // the road the spec was designed on, so the plan is made on the same one
  const ObjectStates* states = in.get<ObjectStates>("states");
  if (states) {
    scene.objects = states->objects;
    scene.distance_origin_x = states->distance_origin_x;
  }
  if (frame.ego.speed_mps)
    scene.ego_speed_mps = frame.ego.speed_mps;
  else if (states && states->ego_speed_mps)
    scene.ego_speed_mps = states->ego_speed_mps;
  else if (ego_speed_param_ >= 0)
    scene.ego_speed_mps = ego_speed_param_;
  else
    throw Error(
        "hazard spec at " + where +
        ": the ego speed is unknown (neither the frame nor the object states carry it); set the planner's "
        "ego_speed_mps");
  if (!frame.camera.valid()) throw Error("hazard spec at " + where + ": the frame has no valid camera model");

  Json tpl_params = templates_.contains(spec->kind) ? templates_[spec->kind] : Json::object();
  // The generator's bounds (horizon, how long a hazard may be under way) unless the template params state
  // them.
  Json with_bounds = tpl_params;
  if (spec->horizon_s && !with_bounds.contains("duration_s")) with_bounds["duration_s"] = *spec->horizon_s;
  if (spec->max_under_way_s && !with_bounds.contains("max_under_way_s"))
    with_bounds["max_under_way_s"] = *spec->max_under_way_s;
  std::unique_ptr<HazardTemplate> tpl;
  try {
    tpl = ctx.components().create<HazardTemplate>(kind::kHazardTemplate, spec->kind, with_bounds);
  } catch (const DiagnosticError&) {
    if (with_bounds == tpl_params) throw;
    // A template not built on the shared kit does not take the bounds: it plans with its own.
    tpl = ctx.components().create<HazardTemplate>(kind::kHazardTemplate, spec->kind, tpl_params);
  }
  const std::vector<Refusal> reasons = tpl->check(*spec, scene);

  ++planned_;
  std::string name = file_;
  if (planned_ > 1) {
    const std::filesystem::path f(file_);
    name = (f.parent_path() / (f.stem().string() + "_" + std::to_string(planned_) + f.extension().string()))
               .string();
  }
  Json planner = {{"frame", frame.index},   {"timestamp", frame.timestamp},
                  {"template", spec->kind}, {"feasible", reasons.empty()},
                  {"reasons", reasons},     {"ego_speed_mps", *scene.ego_speed_mps}};
  if (!reasons.empty()) {
    const std::string msg =
        "hazard spec '" + spec->kind + "' at " + where + " is infeasible: " + refusal_text(reasons);
    write_file_atomic(ctx.output_dir() / name,
                      json_text(Json{{"planner", planner}, {"spec", *spec}}, 2) + "\n");
    if (!skip_infeasible_) throw NoHazardFits(msg, reasons);
    ctx.log(LogLevel::kWarning, msg + " (skipped)");
    return;
  }
  HazardTrajectory traj = tpl->plan(*spec, scene);
  Json j = traj;
  j["planner"] = planner;
  write_file_atomic(ctx.output_dir() / name, json_text(j, 2) + "\n");
  ctx.log(LogLevel::kInfo, "planned '" + spec->kind + "' at " + where + ": " +
                               std::to_string(traj.points.size()) + " samples, intended minimum TTC " +
                               num_text(traj.intended_min_ttc_s) + " s");
  out.emit("trajectory", std::move(traj));
}

}  // namespace hf
