// Real frames of every shipped recording through the shipped assessment configs: no track reports a speed its
// class cannot reach, and no vehicle is reported as two overlapping tracks in one frame.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include "command.hpp"
#include "hazardforge/hazard/kinematics.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

fs::path unique_dir(const std::string& name) {
  std::random_device rd;
  fs::path d = fs::temp_directory_path() /
               ("hf_hygiene_" + name + "_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
  fs::create_directories(d);
  return d;
}

bool vehicle(const std::string& l) {
  return l == "car" || l == "truck" || l == "bus";
}

double iou(const Json& a, const Json& b) {
  const cv::Rect2d ra(a[0].get<double>(), a[1].get<double>(), a[2].get<double>(), a[3].get<double>());
  const cv::Rect2d rb(b[0].get<double>(), b[1].get<double>(), b[2].get<double>(), b[3].get<double>());
  const double inter = (ra & rb).area();
  return inter / (ra.area() + rb.area() - inter);
}

struct Findings {
  int frames = 0, states = 0, with_velocity = 0;
  std::vector<std::string> too_fast, duplicates;
};

// Reads the estimator's ObjectStates of every line of the run's frames.jsonl (one line per frame, a key per
// input stream).
Findings inspect(const fs::path& records, const LimitsTable& limits) {
  Findings f;
  std::ifstream in(records);
  std::string line;
  while (std::getline(in, line)) {
    const Json all = Json::parse(line);
    if (!all.contains("estimator.states")) continue;
    const Json& j = all["estimator.states"];
    ++f.frames;
    const int64_t frame = j.at("frame").get<int64_t>();
    const double ego = j["ego_speed_mps"].is_number() ? j["ego_speed_mps"].get<double>() : -1.0;
    const Json& objs = j["objects"];
    for (const Json& o : objs) {
      ++f.states;
      const std::string label = o.at("label");
      if (!limits.has(label) || !o["velocity_rel"].is_array()) continue;
      ++f.with_velocity;
      const double vmax = limits.at(label).max_speed_mps;
      const double vrel = std::hypot(o["velocity_rel"][0].get<double>(), o["velocity_rel"][1].get<double>());
      // Relative to an ego of known speed the object can close at most vmax + ego; without an ego speed the
      // relative velocity also carries the ego's own (up to a motorway's 40 m/s).
      const double bound = vmax + (ego >= 0 ? ego : 40.0);
      std::ostringstream why;
      if (vrel > bound + 1e-6) why << "relative speed " << vrel << " m/s > " << bound;
      if (o["speed_mps"].is_number() && o["speed_mps"].get<double>() > vmax + 1e-6)
        why << " speed " << o["speed_mps"].get<double>() << " m/s > " << vmax;
      if (!why.str().empty())
        f.too_fast.push_back("frame " + std::to_string(frame) + " track " +
                             std::to_string(o["track_id"].get<int64_t>()) + " (" + label + "): " + why.str());
    }
    for (size_t a = 0; a < objs.size(); ++a)
      for (size_t b = a + 1; b < objs.size(); ++b) {
        if (!vehicle(objs[a]["label"]) || !vehicle(objs[b]["label"])) continue;
        if (objs[a]["misses"].is_number() &&
            (objs[a]["misses"].get<int>() > 0 || objs[b]["misses"].get<int>() > 0))
          continue;
        const double o = iou(objs[a]["box"], objs[b]["box"]);
        if (o >= 0.6)
          f.duplicates.push_back("frame " + std::to_string(frame) + ": tracks " +
                                 std::to_string(objs[a]["track_id"].get<int64_t>()) + " and " +
                                 std::to_string(objs[b]["track_id"].get<int64_t>()) + " overlap at IoU " +
                                 std::to_string(o));
      }
  }
  return f;
}

class TrackHygiene : public ::testing::TestWithParam<std::string> {};

TEST_P(TrackHygiene, NoImpossibleSpeedsAndNoDuplicateVehicleTracks) {
  const std::string config = GetParam();
  const fs::path out = unique_dir(fs::path(config).stem().string());
  const auto r = test::run_command(test::quote(test::binary_dir() / "bin/hazardforge") + " run " +
                                   test::quote(test::source_dir() / "configs" / config) + " -o " +
                                   test::quote(out / "run") + " -q");
  ASSERT_EQ(r.code, 0) << r.out;
  const LimitsTable limits = LimitsTable::load((test::source_dir() / "share/hazard_limits.yaml").string());
  const Findings f = inspect(out / "run/frames.jsonl", limits);
  std::cout << config << ": " << f.frames << " frames, " << f.states << " object states, " << f.with_velocity
            << " with a velocity\n";
  EXPECT_GT(f.frames, 30);
  EXPECT_GT(f.with_velocity, 20);
  for (const std::string& s : f.too_fast) ADD_FAILURE() << config << ": " << s;
  for (const std::string& s : f.duplicates) ADD_FAILURE() << config << ": " << s;
  fs::remove_all(out);
}

INSTANTIATE_TEST_SUITE_P(ShippedRecordings, TrackHygiene,
                         ::testing::Values("assess_nuscenes.yaml", "assess_kitti_raw.yaml",
                                           "assess_video.yaml"),
                         [](const auto& info) { return fs::path(info.param).stem().string(); });

}  // namespace
}  // namespace hf
