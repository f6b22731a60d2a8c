// jaywalker_diagonal hazard template: a person crosses the road diagonally, already walking when it appears.
#include <cmath>
#include <numbers>

#include "hazardforge/hazard/template_base.hpp"
#include "hazardforge/plugin.hpp"

namespace example {

// Kind hazard_template, name jaywalker_diagonal. Starts on the kerb on `side` at x = initial_distance_m and
// walks at speed_mps along heading_deg, a diagonal towards the other side. Params: the shared template
// params.
class JaywalkerDiagonal : public hf::hazard::TemplateBase {
 public:
  static hf::ComponentInfo describe() {
    return base_info("jaywalker_diagonal", "a person crosses diagonally");
  }
  std::string hazard_kind() const override { return "jaywalker_diagonal"; }

 protected:
  std::vector<std::string> allowed_classes() const override { return {"person"}; }

  hf::hazard::Design design(const hf::hazard::PlanRequest& req,
                            std::vector<std::string>& reasons) const override {
    const int side = req.side_sign();  // +1 left, -1 right
    const double h = req.spec.heading_deg * std::numbers::pi / 180;
    const double across = -side * std::sin(h);  // share of the motion towards the other side
    if (side == 0) {
      reasons.push_back("side must be 'left' or 'right'");
    } else if (across < 0.34 || std::abs(std::cos(h)) < 0.34) {  // 20 degrees off both axes at least
      reasons.push_back("heading_deg " + hf::hazard::num(req.spec.heading_deg) +
                        " is not a diagonal across the road from the " + req.spec.side);
    }
    if (!reasons.empty()) return {};

    const double x0 = req.spec.initial_distance_m;
    const double y0 = side * (req.road.edge(side) + req.road.kerb_offset);
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
