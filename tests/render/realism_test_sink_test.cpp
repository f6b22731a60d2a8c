// The realism_test sink on synthetic frames: a flat box drawn into textured frames is told apart from the
// textured real objects around it; the result with its real-against-real control, the crops' features and the
// contact sheet are written.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hazardforge/testing/stage_runner.hpp"
#include "realism_test_sink.hpp"
#include "render_fixtures.hpp"

namespace hf::render {
namespace {

namespace fs = std::filesystem;

TEST(RealismTestSink, AFlatBoxAmongTexturedCarsIsToldApartAndTheSheetIsWritten) {
  auto runner = hf::testing::StageRunner::create<RealismTestSink>();
  const CameraModel cam = hf::test::test_camera();
  for (int i = 0; i < 16; ++i) {
    cv::Mat orig = hf::test::textured_image({800, 450}, 20 + i);
    Tracks d;
    d.frame_index = i;
    // Two real cars: textured patches, tinted.
    for (int k = 0; k < 2; ++k) {
      const cv::Rect r(60 + 300 * k + 7 * i, 150 + 5 * k, 90 + 3 * i, 60 + 2 * i);
      cv::Mat tex = hf::test::textured_image(r.size(), 200 + 10 * i + k), tint;
      cv::add(tex, cv::Scalar(30 * k, 10, 50), tint);
      tint.copyTo(orig(r));
      Track t;
      t.id = 7 + k;
      t.box = cv::Rect2f(r);
      t.label = "car";
      t.score = 0.9f;
      t.hits = i + 1;
      d.items.push_back(t);
    }
    cv::Mat aug = orig.clone();
    const cv::Rect ins(560, 250, 100 + 2 * i, 70 + i);
    aug(ins).setTo(cv::Scalar(150, 150, 150));  // the toy insertion: one flat grey
    HazardInstance h;
    h.frame_index = i;
    h.visible = true;
    h.kind = "sudden_stop";
    h.object_class = "car";
    h.box = h.drawn_box = cv::Rect2f(ins);
    h.picture_file = "car.png";
    h.picture_source = "generated";
    const Frame fo = hf::test::make_frame(i, 0.1 * i, orig, cam), fa = hf::test::make_frame(i, 0.1 * i, aug, cam);
    runner.push("original", fo, fo.timestamp);
    runner.push("augmented", fa, fa.timestamp);
    runner.push("hazard", h, fo.timestamp);
    runner.push("tracks", d, fo.timestamp);
  }
  runner.run();
  const fs::path dir = runner.output_dir();
  std::ifstream in(dir / "realism.json");
  ASSERT_TRUE(in.good());
  const Json j = Json::parse(in);
  EXPECT_EQ(j["picture_source"], "generated");
  EXPECT_EQ(j["inserted_crops"], 16);
  EXPECT_EQ(j["real_crops"], 32);
  EXPECT_GT(j["auc"].get<double>(), 0.9);
  EXPECT_GT(j["auc_ci95"][0].get<double>(), 0.7);
  // The control splits the real crops by track: two cars, one on each side.
  EXPECT_EQ(j["real_objects"], 2);
  EXPECT_TRUE(j["control_auc"].is_number());
  int lines = 0;
  std::ifstream crops(dir / "realism" / "crops.jsonl");
  for (std::string l; std::getline(crops, l);) ++lines;
  EXPECT_EQ(lines, 48);
  const cv::Mat sheet = cv::imread((dir / "realism" / "contact_sheet.png").string());
  ASSERT_FALSE(sheet.empty());
  EXPECT_GT(sheet.rows, 2 * 96);  // a row of real crops above a row of inserted ones
}

}  // namespace
}  // namespace hf::render
