// jaywalker_diagonal hazard template: a person crosses the road diagonally, already walking when it appears.
#include <cmath>
#include <numbers>

#include "hazardforge/hazard/template_base.hpp"
#include "hazardforge/number_text.hpp"
#include "hazardforge/plugin.hpp"

namespace example {

// Kind hazard_template, name jaywalker_diagonal. Starts on the kerb on `side` at x = initial_distance_m and
// walks at speed_mps along heading_deg, a diagonal towards the other side. Params: the shared template
// params.
class JaywalkerDiagonal : public hf::hazard::KindTemplate<JaywalkerDiagonal> {
 public:
  // What the kind is, for the prompt and `hazardforge inspect`; its name, summary and classes follow from it.
  static hf::HazardKindInfo info() {
    hf::HazardKindInfo k;
    k.kind = "jaywalker_diagonal";
    k.summary = "a person crosses diagonally";
    k.play_out =
        "steps off the kerb on `side` at x = initial_distance_m and walks at speed_mps along heading_deg, "
        "a diagonal towards the other side (for example -45 from the left, 45 from the right).";
    k.object_classes = {"person"};
    k.needs = {hf::scene_condition::kSidewalks};
    return k;
  }

 protected:
  hf::hazard::Design design(const hf::hazard::PlanRequest& req,
                            std::vector<hf::Refusal>& reasons) const override {
    const int side = req.side_sign();  // +1 left, -1 right
    const double h = req.spec.heading_deg * std::numbers::pi / 180;
    const double across = -side * std::sin(h);  // share of the motion towards the other side
    if (side == 0) {
      reasons.push_back({hf::refusal::kSpec, "side must be 'left' or 'right'", "jaywalker_diagonal"});
    } else if (across < 0.34 || std::abs(std::cos(h)) < 0.34) {  // 20 degrees off both axes at least
      reasons.push_back({hf::refusal::kSpec,
                         "heading_deg " + hf::num_text(req.spec.heading_deg) +
                             " is not a diagonal across the road from the " + req.spec.side,
                         "jaywalker_diagonal"});
    }
    if (!reasons.empty()) return {};

    const double x0 = req.spec.initial_distance_m;
    const double y0 = side * (req.road.edge(side) + req.road.kerb_offset_m);
    const double vx = req.spec.speed_mps * std::cos(h), vy = req.spec.speed_mps * std::sin(h);
    hf::hazard::Design d;
    d.motion = [=](double tau) {
      hf::hazard::ObjectMotion m;
      m.x = x0 + vx * tau;
      m.y = y0 + vy * tau;
      m.vx = vx;
      m.vy = vy;
      return m;
    };
    return d;
  }
};

}  // namespace example

HAZARDFORGE_PLUGIN("jaywalker_diagonal", "0.1.0", "MIT", "hazard template: a diagonal jaywalker") {
  reg.add<example::JaywalkerDiagonal>();
}
