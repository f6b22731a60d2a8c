// The default asset set: complete, well-formed, and exactly what the generator produces.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "hazardforge/assets/asset_library.hpp"
#include "hazardforge/assets/box_geometry.hpp"
#include "hazardforge/geometry.hpp"
#include "render_fixtures.hpp"
#include "temp_dir.hpp"

namespace hf::render {
namespace {

namespace fs = std::filesystem;

TEST(DefaultAssets, EveryClassHasSixteenViewsWithAlphaAndGeometry) {
  const AssetIndex idx = load_asset_index(test::default_asset_dir());
  std::map<std::string, std::set<long>> views;
  for (const AssetSpec& s : idx.assets) {
    SCOPED_TRACE(s.file);
    views[s.object_class].insert(std::lround(s.azimuth_deg * 10));
    EXPECT_EQ(view_for_azimuth(s.azimuth_deg) == s.view ||
                  angle_diff_deg(view_azimuth_deg(s.view), s.azimuth_deg) <= 22.5,
              true);
    const cv::Mat img = cv::imread((test::default_asset_dir() / s.file).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(img.type(), CV_8UC4);
    EXPECT_EQ(img.size(), s.image_size);
    std::vector<cv::Mat> ch;
    cv::split(img, ch);
    // Opaque object, transparent surroundings (the border rows and columns are empty).
    EXPECT_GT(cv::countNonZero(ch[3] == 255), img.total() / 5);
    EXPECT_EQ(cv::countNonZero(ch[3].row(0)) + cv::countNonZero(ch[3].col(0)), 0);
    // Box geometry: bottom corners below the top ones, ground contact inside the picture's width.
    for (int k = 0; k < 4; ++k) EXPECT_GT(s.box_corners_px[k].y, s.box_corners_px[k + 4].y);
    EXPECT_GT(s.anchor_px.x, 0);
    EXPECT_LT(s.anchor_px.x, s.image_size.width);
  }
  for (const char* cls : {"car", "truck", "bus", "person"}) EXPECT_EQ(views[cls].size(), 16u) << cls;
  // Real-world sizes follow share/class_sizes.yaml.
  const ClassPriors priors = ClassPriors::load((fs::path(share_dir()) / "class_sizes.yaml").string());
  for (const AssetSpec& s : idx.assets) {
    EXPECT_NEAR(s.size_lwh[2], priors.at(s.object_class).height, 1e-6) << s.file;
    EXPECT_NEAR(s.size_lwh[1], priors.at(s.object_class).width, 1e-6) << s.file;
  }
}

TEST(DefaultAssets, CommittedPicturesAreTheGeneratorsOutput) {
  const fs::path out = fs::temp_directory_path() / ("hf_make_assets_check_" + std::to_string(::getpid()));
  fs::remove_all(out);
  // Every class, so every picture committed under share/assets is checked to be the generator's output.
  const std::string cmd = std::string(HF_MAKE_ASSETS) + " --out " + out.string() + " > /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const AssetIndex fresh = load_asset_index(out);
  const AssetIndex committed = load_asset_index(test::default_asset_dir());
  std::map<std::string, AssetSpec> by_file;
  for (const auto& s : committed.assets) by_file[s.file] = s;
  ASSERT_EQ(fresh.assets.size(), 96u);  // sixteen views of each class, the car in three colours
  EXPECT_EQ(std::count_if(fresh.assets.begin(), fresh.assets.end(),
                          [](const AssetSpec& s) { return s.object_class == "car"; }),
            48);
  // No picture in the folder that the generator does not make.
  std::set<std::string> generated;
  for (const AssetSpec& s : fresh.assets) generated.insert(s.file);
  std::vector<std::string> stray;
  for (const auto& e : fs::directory_iterator(test::default_asset_dir()))
    if (e.path().extension() == ".png" && !generated.count(e.path().filename().string()))
      stray.push_back(e.path().filename().string());
  EXPECT_TRUE(stray.empty()) << stray.size() << " picture(s) not made by the generator, e.g. "
                             << stray.front();
  for (const AssetSpec& s : fresh.assets) {
    SCOPED_TRACE(s.file);
    ASSERT_TRUE(by_file.count(s.file));
    const AssetSpec& c = by_file[s.file];
    EXPECT_EQ(c.view, s.view);
    EXPECT_EQ(c.image_size, s.image_size);
    for (int k = 0; k < 8; ++k) EXPECT_NEAR(cv::norm(c.box_corners_px[k] - s.box_corners_px[k]), 0.0, 0.01);
    const cv::Mat a = cv::imread((out / s.file).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat b = cv::imread((test::default_asset_dir() / s.file).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(a.size(), b.size());
    cv::Mat d;
    cv::absdiff(a, b, d);
    double mx = 0;
    cv::minMaxLoc(d.reshape(1), nullptr, &mx);
    EXPECT_LE(mx, 1.0);  // identical up to floating-point rounding across compilers
  }
}

TEST(AssetIndex, MalformedEntriesNameTheFileLineAndField) {
  const hf::test::TempDir tmp;
  const fs::path& dir = tmp.path();
  std::ofstream(dir / "assets.yaml") << "format: hazardforge-assets\nversion: 1\nassets:\n  - file: x.png\n"
                                        "    class: car\n    view: sideways\n";
  try {
    load_asset_index(dir);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find((dir / "assets.yaml").string() + ":6:"), std::string::npos) << m;
    EXPECT_NE(m.find("unknown view 'sideways'"), std::string::npos) << m;
  }
}

TEST(AssetLibrary, UnknownClassNamesTheClassesAvailable) {
  const AssetLibrary lib = AssetLibrary::load(test::default_asset_dir());
  try {
    lib.select("tram", 0.0, "", 30.0);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("class 'tram'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bus, car, person, truck"), std::string::npos) << e.what();
  }
  // The nearest view wins, and the kept instance is preferred within the tolerance.
  EXPECT_EQ(lib.select("car", 170.0, "", 30.0).spec.file, "car_rear.png");
  EXPECT_EQ(lib.select("car", -100.0, "", 30.0).spec.file, "car_right.png");
}

}  // namespace
}  // namespace hf::render
