// The footage_harvester sink (footage_harvester.hpp).
#include "footage_harvester.hpp"

#include "hazardforge/error.hpp"
#include "hazardforge/geometry.hpp"
#include "hazardforge/number_text.hpp"

namespace hf::render {

ComponentInfo FootageHarvester::describe() {
  ComponentInfo i;
  i.name = "footage_harvester";
  i.kind = kind::kSink;
  i.summary = "cuts a recording's own whole, sharp, stable road users into an asset folder (no annotations)";
  i.doc =
      "Tracked cars and persons seen in at least 3 frames, not cut by the border or hidden by a nearer box, "
      "sharp and tall enough, are cut out by grabCut seeded from their box, matted and colour-decontaminated; "
      "a cut is kept when a second cut of the same track agrees with it. The view comes from the object's "
      "motion, the size from the camera model at its range. Writes PNGs with alpha and assets.yaml (the format "
      "of share/assets) when the stream ends, the best cut per track and view; the log says what was kept and "
      "why the rest was not.";
  i.inputs = {port<Frame>("frames", "the recording's frames"),
              port<ObjectStates>("states", "the tracked objects' ranges and motion"),
              optional(port<Tracks>("tracks", "the tracks (how often each was matched)"))};
  i.params = {
      ParamSpec::string("out_dir", "appearances")
          .describe("asset folder to write; relative = below the run's output folder"),
      ParamSpec::number("min_height_px", 40.0).range(8.0, 2000.0).describe("smallest box cut"),
  };
  return i;
}

void FootageHarvester::open(StageContext& ctx) {
  const Params& p = ctx.params();
  out_dir_ = p.get_string("out_dir");
  if (out_dir_.empty()) throw Error("out_dir is empty");
  if (out_dir_.is_relative()) out_dir_ = ctx.output_dir() / out_dir_;
  FootageHarvestOptions o;
  o.min_height_px = p.get_double("min_height_px");
  harvest_ = std::make_unique<FootageHarvest>(o, ClassPriors::load(share_dir() + "/class_sizes.yaml"));
}

void FootageHarvester::process(StageContext& ctx, const Inputs& in, Outputs& /*out*/) {
  const Frame& f = in.require<Frame>("frames");
  const double before = harvest_->seconds();
  harvest_->offer(f, footage_objects(in.get<ObjectStates>("states"), in.get<Tracks>("tracks")));
  ctx.record_timing("footage_harvest", harvest_->seconds() - before);
}

void FootageHarvester::finish(StageContext& ctx, Outputs& /*out*/) {
  const int n = harvest_->save(out_dir_);
  ctx.log(LogLevel::kInfo, "footage harvest: " + harvest_->summary() +
                               (n > 0 ? "; written to " + out_dir_.string() : std::string()) + " (" +
                               num_text(harvest_->seconds(), 1) + " s)");
}

}  // namespace hf::render
