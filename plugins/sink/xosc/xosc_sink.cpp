// xosc sink: picks the coordinates (anchor or the dataset's world frame) and writes the scenario file.
#include "xosc_sink.hpp"

#include <hazardforge/atomic_file.hpp>
#include <hazardforge/output_path.hpp>
#include "hazardforge/geometry.hpp"
#include "xosc_writer.hpp"

namespace hf {

ComponentInfo XoscSink::describe() {
  ComponentInfo i;
  i.name = "xosc";
  i.kind = kind::kSink;
  i.summary = "writes each planned hazard as an ASAM OpenSCENARIO 1.2 (.xosc) scenario";
  i.doc =
      "Ego and hazard become entities (Vehicle with BoundingBox, Performance from share/hazard_limits.yaml "
      "and "
      "Axles; Pedestrian for persons), are teleported to their first samples in Init, and follow their timed "
      "polylines (FollowTrajectoryAction, relative timing, position following). Vehicles are placed by their "
      "rear "
      "axle. With coordinates auto/world the anchor frame's ego pose maps the plan into the dataset's world "
      "frame.";
  i.inputs = {sticky(port<HazardTrajectory>("trajectory", "the planned hazard")),
              optional(port<Frame>("frames", "the anchor frame's ego pose, for world coordinates"))};
  i.params = {
      ParamSpec::string("file", "scenario.xosc").describe("file written below the run's output folder"),
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
  author_ = p.get_string("author");
  description_ = p.get_string("description");
  coordinates_ = p.get_string("coordinates");
  ego_name_ = p.get_string("ego_name");
  hazard_name_ = p.get_string("hazard_name");
  ego_front_ = p.get_double("ego_front_m");
  if (ego_name_.empty() || hazard_name_.empty() || ego_name_ == hazard_name_)
    throw Error("node '" + ctx.node_id() + "': ego_name and hazard_name must be non-empty and differ");
  const std::string limits = p.get_path("limits").string();
  limits_ = hazard::LimitsTable::load(limits.empty() ? hazard::LimitsTable::default_path() : limits);
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
                  hazard::num(traj->anchor_time, 3) + " s)" +
                  (at_anchor ? "; frame " + std::to_string(f->index) + " carries none"
                             : "; connect the frames input"));
  }
  ++written_;
  std::string name = file_;
  if (written_ > 1) {
    const std::filesystem::path f(file_);
    name = (f.parent_path() / (f.stem().string() + "_" + std::to_string(written_) + f.extension().string()))
               .string();
  }
  write_file_atomic(ctx.output_dir() / name, write_xosc(*traj, opt));
  ctx.log(LogLevel::kInfo, "wrote " + name + " (" + traj->kind + ", " + std::to_string(traj->points.size()) +
                               " vertices, " + (opt.T_world_anchor ? "world" : "anchor") + " coordinates)");
}

}  // namespace hf
