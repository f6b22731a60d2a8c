// The nuscenes source on the real scene-0916 tables, checked against hand computations from the same tables.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>

#include <nlohmann/json.hpp>

#include "hazardforge/testing/stage_runner.hpp"
#include "io_test_util.hpp"
#include "nuscenes_source.hpp"
#include "nuscenes_tables.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;
using source::NuScenesSource;
using test::error_of;
using test::run_source;
using test::TempDir;

fs::path dataroot() {
  return test::shared_data("nuscenes");
}

Json load(const std::string& table) {
  std::ifstream in(dataroot() / "v1.0-mini" / (table + ".json"));
  return Json::parse(in);
}
const Json& by_token(const Json& table, const std::string& token) {
  for (const Json& r : table)
    if (r["token"] == token) return r;
  throw std::runtime_error("no token " + token);
}

// v' = q v q*, written out independently of the source's matrix form.
cv::Vec3d rotate(const Json& q, const cv::Vec3d& v, bool inverse) {
  const double w = q[0], s = inverse ? -1.0 : 1.0;
  const cv::Vec3d u(s * q[1].get<double>(), s * q[2].get<double>(), s * q[3].get<double>());
  return 2.0 * u.dot(v) * u + (w * w - u.dot(u)) * v + 2.0 * w * u.cross(v);
}
cv::Vec3d vec(const Json& j) {
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

std::string params() {
  return "{dataroot: '" + dataroot().string() + "'}";
}

TEST(NuScenesSource, Scene0916KeyframesIntrinsicsAndEgoMotion) {
  HF_REQUIRE_SHARED(dataroot() / "v1.0-mini/scene.json");
  testing::StageRunner r;
  auto frames = run_source<NuScenesSource>(params(), &r);
  ASSERT_EQ(frames.size(), 41u);
  EXPECT_EQ(*dynamic_cast<SourceStage&>(r.stage()).frame_count(), 41);

  const Json sd = load("sample_data"), poses = load("ego_pose"), cs = load("calibrated_sensor");
  const Frame& f0 = frames[0];
  const Json& sd0 = by_token(sd, f0.meta["sample_data_token"].get<std::string>());
  const Json& K = by_token(cs, sd0["calibrated_sensor_token"].get<std::string>())["camera_intrinsic"];
  EXPECT_DOUBLE_EQ(f0.camera.fx, K[0][0].get<double>());
  EXPECT_DOUBLE_EQ(f0.camera.fy, K[1][1].get<double>());
  EXPECT_DOUBLE_EQ(f0.camera.cx, K[0][2].get<double>());
  EXPECT_DOUBLE_EQ(f0.camera.cy, K[1][2].get<double>());
  EXPECT_NEAR(f0.camera.fx, 1266.417203046554, 1e-9);
  EXPECT_EQ(f0.camera.width, 1600);
  EXPECT_EQ(f0.image.size(), cv::Size(1600, 900));
  // CAM_FRONT looks forward: its optical axis is ego +x, its image x axis is ego -y; 1.51 m above the ground.
  const cv::Vec3d axis = f0.camera.R_ego_cam * cv::Vec3d(0, 0, 1),
                  right = f0.camera.R_ego_cam * cv::Vec3d(1, 0, 0);
  EXPECT_GT(axis[0], 0.999);
  EXPECT_LT(right[1], -0.999);
  EXPECT_NEAR(f0.camera.t_ego_cam[2], 1.51095763913, 1e-9);
  EXPECT_EQ(f0.origin.scene, "scene-0916");
  EXPECT_EQ(f0.origin.dataset, "nuscenes");
  EXPECT_FALSE(f0.origin.description.empty());
  EXPECT_EQ(f0.meta["timestamp_us"], 1538984233512470);
  EXPECT_EQ(f0.source_id, sd0["filename"]);

  // Timestamps relative to the first keyframe, ~2 Hz.
  EXPECT_DOUBLE_EQ(f0.timestamp, 0.0);
  for (size_t i = 1; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].index, static_cast<int64_t>(i));
    EXPECT_NEAR(frames[i].timestamp - frames[i - 1].timestamp, 0.5, 0.15);
  }
  EXPECT_DOUBLE_EQ(frames[20].timestamp, 9.89999);  // (1538984243412460 - 1538984233512470) us

  // Ego speed at frame 20 by hand: central difference of the poses of keyframes 19 and 21.
  auto pose_of = [&](const Frame& f) -> const Json& {
    return by_token(
        poses,
        by_token(sd, f.meta["sample_data_token"].get<std::string>())["ego_pose_token"].get<std::string>());
  };
  const Json &pa = pose_of(frames[19]), &pb = pose_of(frames[21]);
  const double dt =
      static_cast<double>(pb["timestamp"].get<int64_t>() - pa["timestamp"].get<int64_t>()) * 1e-6;
  const cv::Vec3d v = (vec(pb["translation"]) - vec(pa["translation"])) * (1.0 / dt);
  ASSERT_TRUE(frames[20].ego.speed_mps);
  EXPECT_NEAR(*frames[20].ego.speed_mps, cv::norm(v), 1e-9);
  EXPECT_NEAR(*frames[20].ego.speed_mps, 4.742208, 1e-5);
  EXPECT_GT(*frames[20].ego.speed_mps, 1.0);  // a parking-lot crawl: a few m/s
  EXPECT_LT(*frames[20].ego.speed_mps, 10.0);
  // One-sided at the ends.
  const Json &p0 = pose_of(frames[0]), &p1 = pose_of(frames[1]);
  const double dt0 =
      static_cast<double>(p1["timestamp"].get<int64_t>() - p0["timestamp"].get<int64_t>()) * 1e-6;
  EXPECT_NEAR(*frames[0].ego.speed_mps,
              cv::norm((vec(p1["translation"]) - vec(p0["translation"])) * (1.0 / dt0)), 1e-9);
  // Ego velocity in its own axes points forward when driving forward.
  ASSERT_TRUE(frames[20].annotations && frames[20].annotations->ego_velocity_ego);
  const cv::Vec3d ve = *frames[20].annotations->ego_velocity_ego;
  EXPECT_NEAR(cv::norm(ve), cv::norm(v), 1e-9);
  EXPECT_NEAR(cv::norm(ve - rotate(pose_of(frames[20])["rotation"], v, true)), 0.0, 1e-9);
  EXPECT_GT(ve[0], 0.95 * cv::norm(ve));
  ASSERT_TRUE(frames[20].ego.T_world_ego);
  EXPECT_NEAR((*frames[20].ego.T_world_ego)(0, 3), pose_of(frames[20])["translation"][0].get<double>(), 1e-9);
}

TEST(NuScenesSource, AnnotationInEgoFrameByHand) {
  HF_REQUIRE_SHARED(dataroot() / "v1.0-mini/scene.json");
  auto frames = run_source<NuScenesSource>(params());
  ASSERT_EQ(frames.size(), 41u);
  const Frame& f = frames[20];
  ASSERT_TRUE(f.annotations);
  EXPECT_EQ(f.annotations->objects.size(), 67u);

  const Json anns = load("sample_annotation"), sd = load("sample_data"), poses = load("ego_pose"),
             samples = load("sample"), inst = load("instance");
  const Json& a = by_token(anns, "831eebb6ef574c68b1fbc6c034367ee1");
  ASSERT_EQ(a["sample_token"], f.meta["sample_token"]);
  const Json& pose = by_token(
      poses,
      by_token(sd, f.meta["sample_data_token"].get<std::string>())["ego_pose_token"].get<std::string>());
  const cv::Vec3d expect = rotate(pose["rotation"], vec(a["translation"]) - vec(pose["translation"]), true);

  const AnnotatedObject* o = nullptr;
  for (const auto& x : f.annotations->objects)
    if (x.instance_id == a["instance_token"]) o = &x;
  ASSERT_NE(o, nullptr);
  EXPECT_NEAR(o->center_ego[0], expect[0], 1e-9);
  EXPECT_NEAR(o->center_ego[1], expect[1], 1e-9);
  EXPECT_NEAR(o->center_ego[2], expect[2], 1e-9);
  EXPECT_NEAR(o->center_ego[0], 8.0092, 1e-4);  // ahead and to the right
  EXPECT_NEAR(o->center_ego[1], -5.7262, 1e-4);
  EXPECT_EQ(o->category, "vehicle.car");
  EXPECT_EQ(o->label, "car");
  EXPECT_DOUBLE_EQ(o->size_lwh[0], 4.654);  // nuScenes [w, l, h] = [1.689, 4.654, 1.61]
  EXPECT_DOUBLE_EQ(o->size_lwh[1], 1.689);
  EXPECT_DOUBLE_EQ(o->size_lwh[2], 1.61);
  EXPECT_EQ(o->num_points, 236 + 4);
  // The hidden share is the middle of the visibility bin its token names ("1".."4": 0-40 .. 80-100 %
  // visible).
  const std::map<std::string, double> hidden = {{"1", 0.8}, {"2", 0.5}, {"3", 0.3}, {"4", 0.1}};
  ASSERT_TRUE(hidden.count(a["visibility_token"].get<std::string>()));
  EXPECT_DOUBLE_EQ(o->occlusion, hidden.at(a["visibility_token"].get<std::string>()));
  std::map<double, int> shares;
  for (const auto& x : f.annotations->objects) ++shares[x.occlusion];
  int tokens = 0;
  for (const Json& r : anns)
    if (r["sample_token"] == f.meta["sample_token"]) {
      ++tokens;
      --shares[hidden.at(r["visibility_token"].get<std::string>())];
    }
  EXPECT_EQ(tokens, 67);
  for (const auto& [share, left] : shares) EXPECT_EQ(left, 0) << "hidden share " << share;
  // Heading: the box's x axis rotated into the ego frame.
  const cv::Vec3d hx = rotate(pose["rotation"], rotate(a["rotation"], {1, 0, 0}, false), true);
  EXPECT_NEAR(o->yaw_ego, std::atan2(hx[1], hx[0]), 1e-9);
  // Velocity like the devkit's box_velocity: centred difference of prev/next annotations.
  const Json &prev = by_token(anns, a["prev"].get<std::string>()),
             &next = by_token(anns, a["next"].get<std::string>());
  const double dt =
      static_cast<double>(
          by_token(samples, next["sample_token"].get<std::string>())["timestamp"].get<int64_t>() -
          by_token(samples, prev["sample_token"].get<std::string>())["timestamp"].get<int64_t>()) *
      1e-6;
  const cv::Vec3d vw = (vec(next["translation"]) - vec(prev["translation"])) * (1.0 / dt);
  ASSERT_TRUE(o->velocity_ego);
  EXPECT_NEAR(cv::norm(*o->velocity_ego - rotate(pose["rotation"], vw, true)), 0.0, 1e-9);

  // Label mapping over the whole scene.
  std::map<std::string, std::string> seen;
  for (const Frame& fr : frames)
    for (const auto& x : fr.annotations->objects) seen[x.category] = x.label;
  EXPECT_EQ(seen["vehicle.car"], "car");
  EXPECT_EQ(seen["vehicle.truck"], "truck");
  EXPECT_EQ(seen["vehicle.bus.rigid"], "bus");
  EXPECT_EQ(seen["vehicle.motorcycle"], "motorcycle");
  EXPECT_EQ(seen["vehicle.bicycle"], "bicycle");
  EXPECT_EQ(seen["human.pedestrian.adult"], "person");
  ASSERT_TRUE(seen.count("static_object.bicycle_rack"));
  EXPECT_EQ(seen["static_object.bicycle_rack"], "");
}

TEST(NuScenesSource, ParamsScenesResizeAndNoAnnotations) {
  HF_REQUIRE_SHARED(dataroot() / "v1.0-mini/scene.json");
  auto frames = run_source<NuScenesSource>(
      "{dataroot: '" + dataroot().string() +
      "', scenes: [scene-0916], annotations: false, resize_width: 1280, max_frames: 2}");
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_FALSE(frames[0].annotations);
  EXPECT_EQ(frames[0].image.size(), cv::Size(1280, 720));
  EXPECT_NEAR(frames[0].camera.fx, 1266.417203046554 * 0.8, 1e-9);
  EXPECT_EQ(error_of([] {
              run_source<NuScenesSource>("{dataroot: '" + dataroot().string() + "', scenes: [scene-0001]}");
            }),
            "nuScenes table '" + (dataroot() / "v1.0-mini/scene.json").string() +
                "': no scene named 'scene-0001' (has: scene-0916)");
  EXPECT_EQ(source::map_label("vehicle.emergency.police",
                              NuScenesSource::describe().param("label_map")->default_value),
            "car");
  EXPECT_EQ(source::map_label("vehicle.emergency.ambulance",
                              NuScenesSource::describe().param("label_map")->default_value),
            "truck");
  EXPECT_EQ(
      source::map_label("vehicle.construction", NuScenesSource::describe().param("label_map")->default_value),
      "truck");
  EXPECT_EQ(
      source::map_label("vehicle.carriage", NuScenesSource::describe().param("label_map")->default_value),
      "");
  EXPECT_EQ(source::map_label("movable_object.barrier",
                              NuScenesSource::describe().param("label_map")->default_value),
            "");
}

// A copy of the tables (images linked) to break on purpose.
class BrokenCopy {
 public:
  BrokenCopy() {
    fs::create_directories(dir_ / "v1.0-mini");
    for (const auto& e : fs::directory_iterator(dataroot() / "v1.0-mini"))
      fs::copy_file(e.path(), dir_ / "v1.0-mini" / e.path().filename());
    fs::create_directory_symlink(dataroot() / "samples", dir_ / "samples");
  }
  fs::path root() const { return dir_.path(); }
  fs::path table(const std::string& name) const { return dir_ / ("v1.0-mini/" + name + ".json"); }
  std::string params() const { return "{dataroot: '" + root().string() + "'}"; }

 private:
  TempDir dir_;
};

TEST(NuScenesSource, BrokenTablesNameTheFile) {
  HF_REQUIRE_SHARED(dataroot() / "v1.0-mini/scene.json");
  {
    BrokenCopy c;
    fs::remove(c.table("ego_pose"));
    EXPECT_EQ(error_of([&] { run_source<NuScenesSource>(c.params()); }),
              "nuScenes table '" + c.table("ego_pose").string() + "' does not exist");
  }
  {
    BrokenCopy c;
    fs::remove(c.table("sample_annotation"));
    // Without annotations the annotation tables are not needed.
    EXPECT_EQ(
        run_source<NuScenesSource>("{dataroot: '" + c.root().string() + "', annotations: false}").size(),
        41u);
    EXPECT_EQ(error_of([&] { run_source<NuScenesSource>(c.params()); }),
              "nuScenes table '" + c.table("sample_annotation").string() + "' does not exist");
  }
  {
    BrokenCopy c;
    std::ofstream(c.table("sample")) << "[{\"token\": \"a\",\n \"timestamp\": }]";
    EXPECT_EQ(error_of([&] { run_source<NuScenesSource>(c.params()); }),
              "nuScenes table '" + c.table("sample").string() +
                  "': invalid JSON: parse error at line 2, column 15: syntax error while parsing value - "
                  "unexpected "
                  "'}'; expected '[', '{', or a literal");
  }
  {
    BrokenCopy c;
    Json sd = load("sample_data");
    std::string token;
    for (Json& r : sd)
      if (r["filename"].get<std::string>().find("CAM_FRONT/") != std::string::npos && r["is_key_frame"]) {
        r.erase("ego_pose_token");
        token = r["token"];
        break;
      }
    std::ofstream(c.table("sample_data")) << sd.dump();
    EXPECT_EQ(error_of([&] { run_source<NuScenesSource>(c.params()); }),
              "nuScenes table '" + c.table("sample_data").string() + "': record '" + token +
                  "': field 'ego_pose_token' is missing or not a string");
  }
  {
    BrokenCopy c;
    Json ca = load("calibrated_sensor");
    std::string cam_token;
    for (const Json& r : load("sample_data"))
      if (r["filename"].get<std::string>().find("CAM_FRONT/") != std::string::npos)
        cam_token = r["calibrated_sensor_token"];
    for (Json& r : ca)
      if (r["token"] == cam_token) r["camera_intrinsic"] = Json::array();
    std::ofstream(c.table("calibrated_sensor")) << ca.dump();
    EXPECT_EQ(error_of([&] { run_source<NuScenesSource>(c.params()); }),
              "nuScenes table '" + c.table("calibrated_sensor").string() + "': record '" + cam_token +
                  "': field 'camera_intrinsic' is not a 3x3 matrix");
  }
}

// What fuzz_hazard_reply found for replies holds for tables: a number too large for a double is an
// out_of_range error in nlohmann, which must still name the table.
TEST(NuScenesSource, ANumberTooLargeForADoubleNamesTheTable) {
  TempDir dir;
  std::ofstream(dir / "t.json") << R"([{"token": "a", "timestamp": 1e999}])";
  EXPECT_EQ(
      error_of([&] { source::nuscenes::Table::load(dir / "t.json"); }),
      "nuScenes table '" + (dir / "t.json").string() + "': invalid JSON: number overflow parsing '1e999'");
}

// Values valid JSON allows but geometry does not: each fails at load naming the file, record and field.
TEST(NuScenesSource, ImpossibleValuesAreRefusedWithTheRecord) {
  HF_REQUIRE_SHARED(dataroot() / "v1.0-mini/scene.json");
  // The CAM_FRONT keyframes of the scene in sample-chain order are what the source reads.
  std::vector<Json> keyframes;
  for (const Json& r : load("sample_data"))
    if (r["filename"].get<std::string>().find("CAM_FRONT/") != std::string::npos && r["is_key_frame"])
      keyframes.push_back(r);
  std::sort(keyframes.begin(), keyframes.end(),
            [](const Json& a, const Json& b) { return a["timestamp"] < b["timestamp"]; });
  ASSERT_GE(keyframes.size(), 2u);
  // The earliest keyframe starts its scene; the next one in its sample chain follows it.
  const std::string next_sample = by_token(load("sample"), keyframes[0]["sample_token"])["next"];
  for (const Json& k : keyframes)
    if (k["sample_token"] == next_sample) keyframes[1] = k;
  {
    BrokenCopy c;
    Json poses = load("ego_pose");
    const std::string pose = keyframes[0]["ego_pose_token"];
    for (Json& r : poses)
      if (r["token"] == pose) r["rotation"] = Json::array({0, 0, 0, 0});
    std::ofstream(c.table("ego_pose")) << poses.dump();
    EXPECT_EQ(error_of([&] { run_source<NuScenesSource>(c.params()); }),
              "nuScenes table '" + c.table("ego_pose").string() + "': record '" + pose +
                  "': field 'rotation' = [0, 0, 0, 0] is not a unit quaternion (norm 0)");
  }
  {
    BrokenCopy c;
    Json ca = load("calibrated_sensor");
    const std::string cam = keyframes[0]["calibrated_sensor_token"];
    for (Json& r : ca)
      if (r["token"] == cam) r["camera_intrinsic"][0][0] = 0;
    std::ofstream(c.table("calibrated_sensor")) << ca.dump();
    const std::string e = error_of([&] { run_source<NuScenesSource>(c.params()); });
    EXPECT_EQ(e.rfind("nuScenes table '" + c.table("calibrated_sensor").string() + "': record '" + cam +
                          "': field 'camera_intrinsic' has focal lengths fx = 0, fy = ",
                      0),
              0u)
        << e;
    EXPECT_NE(e.find("; both must be positive"), std::string::npos) << e;
  }
  {
    BrokenCopy c;
    Json sd = load("sample_data");
    const std::string second = keyframes[1]["token"];
    for (Json& r : sd)
      if (r["token"] == second) r["timestamp"] = keyframes[0]["timestamp"];
    std::ofstream(c.table("sample_data")) << sd.dump();
    const std::string t0 = std::to_string(keyframes[0]["timestamp"].get<int64_t>());
    const std::string e = error_of([&] { run_source<NuScenesSource>(c.params()); });
    EXPECT_EQ(e.rfind("nuScenes table '" + c.table("sample_data").string() + "': record '" + second +
                          "': field 'timestamp' = " + t0 + " is not after the previous keyframe's " + t0 +
                          " (scene ",
                      0),
              0u)
        << e;
    EXPECT_NE(e.find("); keyframe timestamps must increase strictly"), std::string::npos) << e;
  }
}

TEST(NuScenesSource, SecondSceneContinuesAfterAGap) {
  HF_REQUIRE_SHARED(dataroot() / "v1.0-mini/scene.json");
  // The scene listed twice under two names stands in for a two-scene dataset.
  BrokenCopy c;
  Json scenes = load("scene");
  Json twin = scenes[0];
  twin["token"] = "twin";
  twin["name"] = "scene-twin";
  scenes.push_back(twin);
  std::ofstream(c.table("scene")) << scenes.dump();
  auto frames = run_source<NuScenesSource>("{dataroot: '" + c.root().string() +
                                           "', annotations: false, scene_gap_s: 2}");
  ASSERT_EQ(frames.size(), 82u);
  EXPECT_EQ(frames[41].origin.scene, "scene-twin");
  EXPECT_EQ(frames[41].meta["scene_start"], true);
  EXPECT_EQ(frames[40].meta["scene_start"], false);
  EXPECT_EQ(frames[41].index, 41);
  EXPECT_DOUBLE_EQ(frames[41].timestamp, frames[40].timestamp + 2.0);
  EXPECT_DOUBLE_EQ(frames[81].timestamp - frames[41].timestamp, frames[40].timestamp);
  // Ego motion is differenced within a scene: the twin's first frame is one-sided again, like frame 0.
  EXPECT_DOUBLE_EQ(*frames[41].ego.speed_mps, *frames[0].ego.speed_mps);
  // Only the named scene.
  EXPECT_EQ(run_source<NuScenesSource>("{dataroot: '" + c.root().string() +
                                       "', annotations: false, scenes: [scene-twin]}")
                .size(),
            41u);
}

TEST(NuScenesSource, MissingImageNamesTheFile) {
  HF_REQUIRE_SHARED(dataroot() / "v1.0-mini/scene.json");
  TempDir dir;
  fs::create_directory_symlink(dataroot() / "v1.0-mini", dir / "v1.0-mini");
  fs::create_directories(dir / "samples/CAM_FRONT");
  std::vector<fs::path> images;
  for (const auto& e : fs::directory_iterator(dataroot() / "samples/CAM_FRONT")) images.push_back(e.path());
  std::sort(images.begin(), images.end());
  for (const auto& p : images) fs::create_symlink(p, dir / "samples/CAM_FRONT" / p.filename());
  fs::remove(dir / "samples/CAM_FRONT" / images[7].filename());
  const std::string yaml = "{dataroot: '" + dir.path().string() + "', scenes: [scene-0916]}";
  const Json sd = load("sample_data");
  std::string token;
  for (const Json& r : sd)
    if (r["filename"] == "samples/CAM_FRONT/" + images[7].filename().string()) token = r["token"];
  EXPECT_EQ(error_of([&] { run_source<NuScenesSource>(yaml); }),
            "nuScenes image '" + (dir / "samples/CAM_FRONT" / images[7].filename()).string() +
                "' (sample_data '" + token + "') does not exist");
  // Without images required, the missing one becomes a black frame of the recorded size.
  auto frames =
      run_source<NuScenesSource>("{dataroot: '" + dir.path().string() + "', images_required: false}");
  ASSERT_EQ(frames.size(), 41u);
  EXPECT_EQ(frames[7].image.size(), cv::Size(1600, 900));
  EXPECT_EQ(cv::countNonZero(frames[7].image.reshape(1)), 0);
  EXPECT_GT(cv::countNonZero(frames[6].image.reshape(1)), 0);
}

}  // namespace
}  // namespace hf
