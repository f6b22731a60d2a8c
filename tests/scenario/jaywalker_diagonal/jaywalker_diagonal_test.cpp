// Loads the built plugin like the host does and plans with the template it registers.
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <cmath>

#include "hazardforge/plugin.hpp"
#include "hazardforge/registry.hpp"

namespace {

hf::ComponentRegistry& registry() {
  static hf::ComponentRegistry reg;
  static const bool loaded = [] {
    void* lib = dlopen(PLUGIN_FILE, RTLD_NOW | RTLD_LOCAL);
    if (!lib) throw std::runtime_error(dlerror());
    auto entry = reinterpret_cast<hf_plugin_entry_fn>(dlsym(lib, HF_PLUGIN_ENTRY_SYMBOL));
    if (!entry) throw std::runtime_error("no entry symbol");
    char err[256] = {};
    if (entry()->register_components(static_cast<hf::Registrar*>(&reg), err, sizeof err) != 0)
      throw std::runtime_error(err);
    return true;
  }();
  (void)loaded;
  return reg;
}

hf::HazardSpec spec(double heading_deg, double speed) {
  hf::HazardSpec s;
  s.kind = "jaywalker_diagonal";
  s.object_class = "person";
  s.initial_distance_m = 30;
  s.side = "left";
  s.speed_mps = speed;
  s.heading_deg = heading_deg;
  return s;
}

hf::SceneContext scene() {
  hf::SceneContext sc;
  sc.timestamp = 1.0;
  sc.ego_speed_mps = 8.0;
  sc.camera = hf::CameraModel::pinhole(1600, 900, 1266, 1266, 800, 450);
  return sc;
}

TEST(JaywalkerDiagonal, WalksDiagonallyFromTheKerb) {
  auto tpl =
      registry().create<hf::HazardTemplate>("hazard_template", "jaywalker_diagonal", {{"duration_s", 4.0}});
  const hf::HazardTrajectory tr = tpl->plan(spec(-45, 1.5), scene());
  EXPECT_DOUBLE_EQ(tr.points.front().x, 30.0);
  EXPECT_DOUBLE_EQ(tr.points.front().y, 5.75);  // kerb: 1.75 + 3.5 + 0.5 m
  EXPECT_NEAR(tr.points.front().heading, -M_PI / 4, 1e-12);
  EXPECT_NEAR(tr.points[20].y - tr.points[0].y, -1.5 * std::sqrt(0.5), 1e-9);  // 1 s later
  // In the ego path (|y| < 1.8 m) after 3.72 s; the gap 26.35 m closes at 8 - 1.06 m/s and reaches 0 at 3.797
  // s, so the plan ends at that contact: the last sample is at 3.75 s, with TTC = gap / closing there.
  const double closing = 8.0 - 1.5 * std::sqrt(0.5);
  EXPECT_EQ(tr.points.size(), 76u);
  EXPECT_NEAR(tr.intended_min_ttc_s, (26.35 - closing * 3.75) / closing, 1e-9);
}

TEST(JaywalkerDiagonal, DescribesItself) {
  auto tpl = registry().create<hf::HazardTemplate>("hazard_template", "jaywalker_diagonal", {});
  EXPECT_EQ(tpl->hazard_kind(), "jaywalker_diagonal");
  EXPECT_EQ(tpl->kind_info().needs, std::vector<std::string>{"sidewalks"});
  EXPECT_NE(registry().find("hazard_template", "jaywalker_diagonal")->info.doc.find("Needs: sidewalks."),
            std::string::npos);
}

TEST(JaywalkerDiagonal, SharedAndOwnChecks) {
  auto tpl = registry().create<hf::HazardTemplate>("hazard_template", "jaywalker_diagonal", {});
  const std::vector<hf::Refusal> fast = tpl->check(spec(-45, 12), scene());
  ASSERT_EQ(fast.size(), 1u);
  EXPECT_EQ(fast[0].code, hf::refusal::kClassLimit);
  EXPECT_EQ(fast[0].text, "speed_mps 12 exceeds the person limit of 7 m/s");
  const std::vector<hf::Refusal> straight = tpl->check(spec(-90, 1.5), scene());
  ASSERT_EQ(straight.size(), 1u);
  EXPECT_EQ(straight[0].code, hf::refusal::kSpec);
  EXPECT_EQ(straight[0].text, "heading_deg -90 is not a diagonal across the road from the left");
}

}  // namespace
