// LabelTtcMetric: the ground-truth protocol on camera-relative labels, objects named by their track ids.
#include "label_ttc_metric.hpp"

#include <charconv>

namespace hf {

ComponentInfo LabelTtcMetric::describe() {
  ComponentInfo i;
  i.name = "label_ttc";
  i.kind = kind::kRiskMetric;
  i.summary = "reference TTC per labelled track from KITTI tracking labels (camera-relative motion) (s)";
  i.doc =
      "The ground-truth protocol (docs/evaluation.md) on Frame::annotations from the kitti source: KITTI "
      "tracking labels have no ego motion, so velocities are relative to the camera and closing = -v_rel.x "
      "along the camera's forward axis. Labels of `categories` (KITTI types); in path when x > 0 and |y| < "
      "corridor_half_width + corridor_margin + w/2 (corridor_path straight; ego_path would follow "
      "Frame.ego's yaw "
      "rate, which KITTI tracking frames do not carry); gap = x - front_overhang - l/2 (default: from the "
      "camera); "
      "TTC = max(gap, 0) / closing when closing > min_closing_mps, else infinite; unknown for tracks "
      "labelled "
      "in one frame only. Scene TTC = minimum over in-path labels. ObjectRisk.track_id = KITTI track id.";
  i.inputs = {
      port<Frame>("frames", "frames carrying camera-relative label annotations (kitti source)"),
      optional(port<ObjectStates>("states", "unused; lets the node stand where a risk metric is expected"))};
  i.outputs = {port<RiskAssessment>("risk", "per-track TTC, scene TTC and the reference label")};
  i.params = GroundTruthProtocol::params(
      {0.0,
       "ego origin (below camera 2) to the reference the gap is measured from (m); 0 = camera",
       {"Car", "Van", "Truck", "Pedestrian", "Person_sitting", "Cyclist", "Tram"},
       "KITTI types (category prefixes) that count; Misc and DontCare are left out by default",
       "tracks labelled in one frame only: ignore = unknown TTC; static = not moving relative to the "
       "camera"});
  return i;
}

void LabelTtcMetric::open(StageContext& ctx) {
  protocol_ = GroundTruthProtocol::from(ctx.params());
}

void LabelTtcMetric::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  const Frame& f = in.require<Frame>("frames");
  const std::string what =
      "label_ttc: frame " + std::to_string(f.index) +
      (f.origin.dataset_frame ? " (dataset frame " + std::to_string(*f.origin.dataset_frame) + ")" : "");
  if (!f.annotations)
    throw Error(what + ": no annotations; label_ttc needs a source with labels (kitti, layout tracking)");
  RiskAssessment r = protocol_.assess(*f.annotations, f.ego, what);
  // The protocol names objects by annotation index; a KITTI track id is stable across frames.
  const int64_t critical_index = r.critical_track;
  for (ObjectRisk& o : r.objects) {
    const std::string& id = f.annotations->objects[static_cast<size_t>(o.track_id)].instance_id;
    int64_t track = -1;
    const auto [end, ec] = std::from_chars(id.data(), id.data() + id.size(), track);
    if (ec != std::errc() || end != id.data() + id.size() || track < 0)
      throw Error(what + ": annotation " + std::to_string(o.track_id) + " has instance id '" + id +
                  "', not a KITTI track id (a non-negative integer)");
    if (o.track_id == critical_index) r.critical_track = track;
    o.track_id = track;
  }
  r.stage = "label_ttc";
  r.frame_index = f.index;
  r.metric = ctx.node_id();
  out.emit("risk", std::move(r));
}

}  // namespace hf
