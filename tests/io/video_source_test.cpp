// The video, image_sequence and camera sources on synthetic files with known content.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "hazardforge/apps/calibration.hpp"
#include "folder_clock.hpp"
#include "image_sequence_source.hpp"
#include "synthetic_road.hpp"
#include "io_test_util.hpp"
#include "test_support.hpp"
#include "video_source.hpp"

namespace hf {
namespace {

using source::CameraSource;
using source::ImageSequenceSource;
using source::VideoSource;
using test::error_of;
using test::run_source;
using test::TempDir;

// Frame k: uniform grey level 10 + 20 k, with a white square whose x position encodes k.
cv::Mat synthetic(int k, cv::Size size) {
  cv::Mat m(size, CV_8UC3, cv::Scalar::all(10 + 20 * k));
  cv::rectangle(m, cv::Rect(10 + 8 * k, 20, 16, 16), cv::Scalar::all(255), cv::FILLED);
  return m;
}

std::filesystem::path write_video(const TempDir& dir, int frames, cv::Size size, double fps) {
  const auto file = dir / "clip.mp4";
  cv::VideoWriter w(file.string(), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps, size);
  EXPECT_TRUE(w.isOpened());
  for (int k = 0; k < frames; ++k) w.write(synthetic(k, size));
  w.release();
  return file;
}

TEST(VideoSource, ReadsEveryFrameWithTimestampsAndContent) {
  TempDir dir;
  const auto file = write_video(dir, 12, {320, 240}, 25.0);
  testing::StageRunner r;
  auto frames = run_source<VideoSource>("{path: '" + file.string() + "', fx: 400}", &r);
  ASSERT_EQ(frames.size(), 12u);
  auto* src = dynamic_cast<SourceStage*>(&r.stage());
  ASSERT_TRUE(src->frame_count());
  EXPECT_EQ(*src->frame_count(), 12);
  for (int k = 0; k < 12; ++k) {
    const Frame& f = frames[static_cast<size_t>(k)];
    EXPECT_EQ(f.index, k);
    EXPECT_NEAR(f.timestamp, k / 25.0, 1e-12);
    EXPECT_EQ(f.image.size(), cv::Size(320, 240));
    EXPECT_EQ(f.image.type(), CV_8UC3);
    // Lossy codec: the grey level of a flat area comes back within a few levels.
    EXPECT_NEAR(cv::mean(f.image(cv::Rect(200, 150, 60, 60)))[0], 10 + 20 * k, 6.0) << "frame " << k;
    EXPECT_EQ(f.meta["file_frame"], k);
  }
  EXPECT_DOUBLE_EQ(frames[0].camera.fx, 400);
  EXPECT_DOUBLE_EQ(frames[0].camera.fy, 400);
  EXPECT_DOUBLE_EQ(frames[0].camera.cx, 160);
  EXPECT_DOUBLE_EQ(frames[0].camera.cy, 120);
  EXPECT_DOUBLE_EQ(frames[0].camera.height_above_ground(), 1.5);
  EXPECT_FALSE(frames[0].ego.speed_mps);
}

TEST(VideoSource, StartMaxFramesResizeAndFpsOverride) {
  TempDir dir;
  const auto file = write_video(dir, 12, {320, 240}, 25.0);
  auto frames =
      run_source<VideoSource>("{path: '" + file.string() +
                              "', start_frame: 3, max_frames: 4, fps: 10, resize_width: 160, fx: 400, "
                              "camera_height: 1.2, camera_pitch_deg: 2, ego_speed_mps: 13.5}");
  ASSERT_EQ(frames.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    const Frame& f = frames[static_cast<size_t>(k)];
    EXPECT_EQ(f.index, k);
    EXPECT_NEAR(f.timestamp, k / 10.0, 1e-12);
    EXPECT_EQ(f.image.size(), cv::Size(160, 120));
    EXPECT_NEAR(cv::mean(f.image(cv::Rect(100, 75, 30, 30)))[0], 10 + 20 * (k + 3), 6.0);
    EXPECT_EQ(f.meta["file_frame"], k + 3);
  }
  const CameraModel& c = frames[0].camera;
  EXPECT_EQ(c.width, 160);
  EXPECT_EQ(c.height, 120);
  EXPECT_DOUBLE_EQ(c.fx, 200);
  EXPECT_DOUBLE_EQ(c.fy, 200);
  EXPECT_DOUBLE_EQ(c.cx, 80);
  EXPECT_DOUBLE_EQ(c.cy, 60);
  EXPECT_NEAR(c.pitch(), 2 * CV_PI / 180, 1e-12);
  EXPECT_DOUBLE_EQ(c.height_above_ground(), 1.2);
  ASSERT_TRUE(frames[0].ego.speed_mps);
  EXPECT_DOUBLE_EQ(*frames[0].ego.speed_mps, 13.5);
}

TEST(VideoSource, AssumedFovIsWarnedAndUsed) {
  TempDir dir;
  const auto file = write_video(dir, 2, {320, 240}, 25.0);
  testing::StageRunner r;
  auto frames = run_source<VideoSource>("{path: '" + file.string() + "'}", &r);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_NEAR(frames[0].camera.fx, 160 / std::tan(30 * CV_PI / 180), 1e-9);
  bool warned = false;
  for (const auto& l : r.log())
    warned |= l.rfind("warning: ", 0) == 0 &&
              l.find("assuming a 60 deg horizontal field of view") != std::string::npos;
  EXPECT_TRUE(warned);
  // An explicit FOV is used without a warning.
  testing::StageRunner r2;
  frames = run_source<VideoSource>("{path: '" + file.string() + "', hfov_deg: 90}", &r2);
  EXPECT_NEAR(frames[0].camera.fx, 160, 1e-9);
  // (These flat frames show no road: the warnings left say so, and no FOV warning is among them.)
  for (const auto& l : r2.log()) {
    if (l.rfind("warning: ", 0) != 0) continue;
    EXPECT_EQ(l.find("field of view"), std::string::npos) << l;
    EXPECT_TRUE(l.find("no horizon could be estimated") != std::string::npos ||
                l.find("speed could not be estimated") != std::string::npos)
        << l;
  }
}

TEST(VideoSource, CalibrationUndistortsAndScales) {
  TempDir dir;
  // A 640x480 calibration applied to a 320x240 video: same aspect, so K scales by 1/2.
  CalibrationResult cal;
  cal.image_width = 640;
  cal.image_height = 480;
  cal.fx = 600;
  cal.fy = 610;
  cal.cx = 330;
  cal.cy = 250;
  cal.distortion = {0.3, 0.1, 0.0, 0.0, 0.0};
  write_calibration(cal, dir / "cal.yaml");
  const auto file = write_video(dir, 3, {320, 240}, 25.0);
  auto frames = run_source<VideoSource>("{path: '" + file.string() + "', calibration: '" +
                                        (dir / "cal.yaml").string() + "'}");
  ASSERT_EQ(frames.size(), 3u);
  const CameraModel& c = frames[0].camera;
  EXPECT_DOUBLE_EQ(c.fx, 300);
  EXPECT_DOUBLE_EQ(c.fy, 305);
  EXPECT_DOUBLE_EQ(c.cx, 165);
  EXPECT_DOUBLE_EQ(c.cy, 125);
  EXPECT_TRUE(c.distortion.empty()) << "undistorted frames carry no distortion";
  // Correcting a pincushion lens (k1 > 0) maps the output corners outside the recorded image: black.
  EXPECT_LT(cv::mean(frames[2].image(cv::Rect(0, 0, 4, 4)))[0], 5.0);
  EXPECT_NEAR(cv::mean(frames[2].image(cv::Rect(200, 150, 40, 40)))[0], 50, 6.0);

  // Without undistortion the distortion stays in the model and the corner keeps its grey; undistorting that
  // frame with cv::undistort and the scaled K gives exactly the source's frame.
  auto raw = run_source<VideoSource>("{path: '" + file.string() + "', undistort: false, calibration: '" +
                                     (dir / "cal.yaml").string() + "'}");
  EXPECT_EQ(raw[0].camera.distortion, cal.distortion);
  EXPECT_NEAR(cv::mean(raw[2].image(cv::Rect(0, 0, 4, 4)))[0], 50, 6.0);
  cv::Mat expected;
  cv::undistort(raw[2].image, expected, c.K(), cal.distortion);
  EXPECT_EQ(cv::norm(expected, frames[2].image, cv::NORM_INF), 0.0);

  // A calibration of another aspect ratio does not apply.
  cal.image_width = 1280;
  write_calibration(cal, dir / "wide.yaml");
  EXPECT_EQ(error_of([&] {
              run_source<VideoSource>("{path: '" + file.string() + "', calibration: '" +
                                      (dir / "wide.yaml").string() + "'}");
            }),
            "calibration '" + (dir / "wide.yaml").string() + "' is for 1280x480 images but video file '" +
                file.string() + "' is 320x240 (different aspect ratio)");
}

TEST(VideoSource, BadFilesGiveOneClearMessage) {
  TempDir dir;
  const auto missing = dir / "nope.mp4";
  EXPECT_EQ(error_of([&] { run_source<VideoSource>("{path: '" + missing.string() + "'}"); }),
            "video file or image folder '" + missing.string() + "' does not exist");
  const auto junk = dir / "junk.mp4";
  std::ofstream(junk) << "this is not a video\n";
  EXPECT_EQ(error_of([&] { run_source<VideoSource>("{path: '" + junk.string() + "'}"); }),
            "cannot open video file '" + junk.string() + "': not a video OpenCV/FFmpeg can decode");
  const auto file = write_video(dir, 3, {320, 240}, 25.0);
  EXPECT_EQ(error_of([&] { run_source<VideoSource>("{path: '" + file.string() + "', start_frame: 5}"); }),
            "video file '" + file.string() + "' ends at frame 3, before start_frame 5");
  EXPECT_EQ(error_of([&] {
              run_source<VideoSource>("{path: '" + file.string() + "', calibration: '" +
                                      (dir / "none.yaml").string() + "'}");
            }),
            "calibration file '" + (dir / "none.yaml").string() + "' does not exist");
}

TEST(VideoSource, TruncatedFileEndsOrNamesTheFrame) {
  TempDir dir;
  const auto file = write_video(dir, 30, {320, 240}, 25.0);
  // Cut the file in half: FFmpeg either stops early or reports the broken frame by index; both are handled
  // without returning garbage frames.
  const auto size = std::filesystem::file_size(file);
  std::filesystem::resize_file(file, size / 2);
  std::vector<Frame> frames;
  const std::string err =
      error_of([&] { frames = run_source<VideoSource>("{path: '" + file.string() + "'}"); });
  if (err.empty()) {
    EXPECT_LT(frames.size(), 30u);
  } else {
    EXPECT_NE(err.find("video file '" + file.string() + "'"), std::string::npos) << err;
  }
}

// AVI declares its frame count in the header, before the frames: a cut file keeps the declaration, so the
// source can tell that frames are missing.
std::filesystem::path write_avi(const TempDir& dir, int frames) {
  const auto file = dir / "clip.avi";
  cv::VideoWriter w(file.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25.0, {320, 240});
  EXPECT_TRUE(w.isOpened());
  for (int k = 0; k < frames; ++k) w.write(synthetic(k, {320, 240}));
  w.release();
  return file;
}

TEST(VideoSource, FewerFramesThanDeclaredFailsUnlessPartialIsAllowed) {
  TempDir dir;
  const auto file = write_avi(dir, 38);
  std::filesystem::resize_file(file, std::filesystem::file_size(file) * 4 / 10);
  const std::string err =
      error_of([&] { run_source<VideoSource>("{path: '" + file.string() + "', fx: 400}"); });
  const std::string head = "video file '" + file.string() + "' decodes ";
  ASSERT_EQ(err.rfind(head, 0), 0u) << err;
  const int decoded = std::stoi(err.substr(head.size()));
  EXPECT_LT(decoded, 37);
  EXPECT_EQ(err, head + std::to_string(decoded) +
                     " of the 38 frames its container declares (decoding stops at "
                     "frame " +
                     std::to_string(decoded) +
                     "): the file is truncated or corrupt; set allow_partial: "
                     "true to use the frames that decode");
  testing::StageRunner r;
  const auto frames =
      run_source<VideoSource>("{path: '" + file.string() + "', fx: 400, allow_partial: true}", &r);
  EXPECT_EQ(static_cast<int>(frames.size()), decoded);
  const auto& log = r.log();
  EXPECT_NE(std::find(log.begin(), log.end(),
                      "incomplete: video file '" + file.string() + "' decodes " + std::to_string(decoded) +
                          " of the 38 frames its container declares (decoding stops at frame " +
                          std::to_string(decoded) + "): the file is truncated or corrupt"),
            log.end());
}

TEST(ImageSequenceSource, ATruncatedImageFailsNamingTheFrame) {
  TempDir dir;
  std::filesystem::create_directories(dir / "imgs");
  for (int k = 0; k < 3; ++k)
    cv::imwrite((dir / ("imgs/" + std::to_string(k) + ".jpg")).string(), synthetic(k, {320, 240}));
  const auto cut = dir / "imgs/1.jpg";
  std::filesystem::resize_file(cut, std::filesystem::file_size(cut) / 2);
  EXPECT_EQ(
      error_of([&] {
        run_source<ImageSequenceSource>("{path: '" + (dir / "imgs").string() +
                                        "', pattern: '*.jpg', fx: 400}");
      }),
      "image '" + cut.string() +
          "' (frame 1) is truncated: the JPEG has no end-of-image marker (the decoder would fill the rest "
          "with grey)");
}

TEST(ImageSequenceSource, SortedMatchingFilesExactContent) {
  TempDir dir;
  // Written out of order, plus files the pattern must skip.
  for (int k : {3, 0, 4, 1, 2}) {
    char name[32];
    std::snprintf(name, sizeof name, "img_%03d.png", k);
    cv::imwrite((dir / name).string(), synthetic(k, {200, 100}));
  }
  std::ofstream(dir / "notes.txt") << "x";
  cv::imwrite((dir / "other.jpg").string(), synthetic(9, {200, 100}));
  testing::StageRunner r;
  auto frames =
      run_source<ImageSequenceSource>("{path: '" + dir.path().string() + "', fps: 5, fx: 150, cy: 40}", &r);
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_EQ(*dynamic_cast<SourceStage&>(r.stage()).frame_count(), 5);
  for (int k = 0; k < 5; ++k) {
    const Frame& f = frames[static_cast<size_t>(k)];
    EXPECT_EQ(f.index, k);
    EXPECT_NEAR(f.timestamp, k * 0.2, 1e-12);
    EXPECT_EQ(cv::norm(f.image, synthetic(k, {200, 100}), cv::NORM_INF), 0.0) << "PNG is lossless";
    char name[32];
    std::snprintf(name, sizeof name, "img_%03d.png", k);
    EXPECT_EQ(f.source_id, name);
  }
  EXPECT_DOUBLE_EQ(frames[0].camera.cx, 100);
  EXPECT_DOUBLE_EQ(frames[0].camera.cy, 40);

  frames = run_source<ImageSequenceSource>("{path: '" + dir.path().string() +
                                           "', pattern: '*.jpg', resize_height: 50, hfov_deg: 90}");
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].image.size(), cv::Size(100, 50));
  EXPECT_NEAR(frames[0].camera.fx, 50, 1e-9);
  EXPECT_EQ(frames[0].camera.width, 100);

  EXPECT_EQ(error_of([&] {
              run_source<ImageSequenceSource>("{path: '" + dir.path().string() + "', pattern: '*.bmp'}");
            }),
            "image folder '" + dir.path().string() + "' has no file matching '*.bmp'");
  // An image of another size mid-stream names the file.
  cv::imwrite((dir / "img_005.png").string(), synthetic(5, {100, 100}));
  EXPECT_EQ(
      error_of([&] { run_source<ImageSequenceSource>("{path: '" + dir.path().string() + "', fx: 100}"); }),
      "image '" + (dir / "img_005.png").string() + "' is 100x100 but the stream started at 200x100");
  std::ofstream(dir / "img_006.png") << "broken";
  std::filesystem::remove(dir / "img_005.png");
  EXPECT_EQ(
      error_of([&] { run_source<ImageSequenceSource>("{path: '" + dir.path().string() + "', fx: 100}"); }),
      "image '" + (dir / "img_006.png").string() + "' (frame 5) cannot be decoded");
}

TEST(ImageSequenceSource, KittiRawFolder) {
  const auto folder = test::shared_data("kitti-raw-2011_09_26/2011_09_26/image_02/data");
  HF_REQUIRE_SHARED(folder);
  testing::StageRunner r;
  auto frames = run_source<ImageSequenceSource>(
      "{path: '" + folder.string() +
          "', fx: 721.5377, cx: 609.5593, cy: 172.854, camera_height: 1.65, max_frames: 3}",
      &r);
  EXPECT_EQ(*dynamic_cast<SourceStage&>(r.stage()).frame_count(), 3);
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[2].image.size(), cv::Size(1242, 375));
  EXPECT_NEAR(frames[2].timestamp, 0.2, 1e-12);
  EXPECT_EQ(frames[0].source_id, "0000000000.png");
}

// A folder of rendered road frames: a camera pitched down 3 deg, 1.5 m high, driving 12 m/s while turning at
// 0.1 rad/s, 10 fps.
std::filesystem::path write_drive(const TempDir& dir, int frames) {
  const auto folder = dir / "drive";
  std::filesystem::create_directories(folder);
  const CameraModel cam = CameraModel::pinhole(640, 360, 576, 576, 320, 180, 1.5, 3.0 * CV_PI / 180, 1.5);
  for (int k = 0; k < frames; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "%04d.png", k);
    cv::imwrite((folder / name).string(), test::road::render(cam, test::road::pose_at(0.1 * k, 12.0, 0.1)));
  }
  return folder;
}

Json read_json(const std::filesystem::path& p) {
  std::ifstream in(p);
  return Json::parse(in);
}

TEST(VideoSource, AnImageFolderTellsItsPitchAndEgoMotion) {
  TempDir dir;
  const auto folder = write_drive(dir, 16);
  testing::StageRunner r;
  const auto frames = run_source<VideoSource>("{path: '" + folder.string() + "', fps: 10, fx: 576}", &r);
  ASSERT_EQ(frames.size(), 16u);
  // What the run says about itself: the geometry used and where each value came from.
  const Json cam = read_json(r.output_dir() / "camera.json");
  EXPECT_NEAR(cam["pitch_deg"].get<double>(), 3.0, 0.5) << cam.dump(2);
  EXPECT_NEAR(cam["horizon_y"].get<double>(), 180 - 576 * std::tan(3.0 * CV_PI / 180), 5.0);
  EXPECT_EQ(cam["fps"], 10.0);
  EXPECT_EQ(cam["sources"]["fps"], "stated");
  EXPECT_EQ(cam["sources"]["intrinsics"], "stated fx/fy/cx/cy");
  EXPECT_EQ(cam["sources"]["pitch_deg"].get<std::string>().rfind("estimated from the video", 0), 0u);
  // The height is not stated: the lane lines (3.5 m apart in the rendered road; 3.6 m assumed) give it.
  EXPECT_EQ(cam["sources"]["height_m"].get<std::string>().rfind("estimated from the lane lines", 0), 0u)
      << cam.dump(2);
  EXPECT_NEAR(cam["height_m"].get<double>(), 1.5 * 3.6 / 3.5, 0.05);
  for (const Frame& f : frames) EXPECT_NEAR(f.camera.height_above_ground(), cam["height_m"].get<double>(), 1e-9);
  // The speed says how the smoother weighed the readings.
  EXPECT_NE(cam["sources"]["ego_speed"].get<std::string>().find("; smoothed over the clip with the readings'"),
            std::string::npos)
      << cam["sources"]["ego_speed"];
  // Every frame carries the pitch, its speed and yaw rate (source video) and the clip's ego track.
  std::vector<double> speeds, yaw_rates;
  for (const Frame& f : frames) {
    EXPECT_NEAR(f.camera.pitch() * 180 / CV_PI, cam["pitch_deg"].get<double>(), 1e-9);
    ASSERT_TRUE(f.ego.speed_mps);
    EXPECT_EQ(f.ego.source, "video");
    speeds.push_back(*f.ego.speed_mps);
    yaw_rates.push_back(*f.ego.yaw_rate);
    ASSERT_TRUE(f.ego_track);
    EXPECT_EQ(f.ego_track->source, "video");
    EXPECT_EQ(f.ego_track->samples.size(), 16u);
    ASSERT_TRUE(f.stream_end);
    EXPECT_NEAR(*f.stream_end, 1.5, 1e-9);
  }
  std::sort(speeds.begin(), speeds.end());
  std::sort(yaw_rates.begin(), yaw_rates.end());
  EXPECT_NEAR(speeds[8], 12.0, 1.2);
  EXPECT_NEAR(yaw_rates[8], 0.1, 0.03);
  // The ego track integrates them: 1.5 s at 12 m/s.
  const auto& last = frames.back().ego_track->samples.back();
  EXPECT_NEAR(std::hypot(last.x, last.y), 18.0, 2.0);
  // One line per frame.
  std::ifstream lines(r.output_dir() / "ego_motion.jsonl");
  int n = 0;
  for (std::string l; std::getline(lines, l); ++n) {
    const Json j = Json::parse(l);
    EXPECT_EQ(j["frame"], n);
    EXPECT_NEAR(j["timestamp"].get<double>(), 0.1 * n, 1e-9);
    EXPECT_EQ(j["source"], "video");
    EXPECT_TRUE(j["speed_mps"].is_number());
    EXPECT_TRUE(j["yaw_rate_dps"].is_number());
    EXPECT_GT(j["yaw_rate_sigma_dps"].get<double>(), 0.0);
    // At 10 fps the turn comes from the road (no two-view step): measured where the speed is.
    if (j["measured"].get<bool>()) {
      EXPECT_TRUE(j["yaw_measured"].get<bool>()) << l;
    }
  }
  EXPECT_EQ(n, 16);
}

// A camera nodding by 0.6 deg at 2 Hz over a street with building fronts, 25 fps: each frame's camera follows
// its own pitch (the clip's plus the measured deviation), and ego_motion.jsonl says it; with follow_attitude
// off every frame has the clip's.
TEST(VideoSource, EachFramesCameraFollowsTheFootagesNod) {
  TempDir dir;
  const auto folder = dir / "nod";
  std::filesystem::create_directories(folder);
  auto nod = [](int k) { return 0.6 * std::sin(2 * CV_PI * 2.0 * k / 25.0); };
  for (int k = 0; k < 30; ++k) {
    const CameraModel cam =
        CameraModel::pinhole(640, 360, 576, 576, 320, 180, 1.5, (3.0 + nod(k)) * CV_PI / 180, 1.5);
    char name[32];
    std::snprintf(name, sizeof name, "%04d.png", k);
    cv::imwrite((folder / name).string(),
                test::road::render_with_walls(cam, test::road::pose_at(k / 25.0, 12.0, 0.0, {0, 0.3, 0})));
  }
  const std::string params = "{path: '" + folder.string() + "', fps: 25, fx: 576, camera_height: 1.5, ";
  testing::StageRunner r;
  const auto frames = run_source<VideoSource>(params + "camera_pitch_deg: 3}", &r);
  ASSERT_EQ(frames.size(), 30u);
  double worst = 0;
  for (size_t k = 5; k + 5 < frames.size(); ++k)  // the slow attitude's edges aside
    worst =
        std::max(worst, std::abs(frames[k].camera.pitch() * 180 / CV_PI - (3.0 + nod(static_cast<int>(k)))));
  EXPECT_LT(worst, 0.15) << "deg";
  const Json cam = read_json(r.output_dir() / "camera.json");
  EXPECT_EQ(
      cam["sources"]["attitude_per_frame"].get<std::string>().rfind("the clip's pitch and roll plus", 0), 0u)
      << cam.dump(2);
  std::ifstream lines(r.output_dir() / "ego_motion.jsonl");
  size_t n = 0;
  for (std::string l; std::getline(lines, l); ++n)
    EXPECT_NEAR(Json::parse(l)["pitch_deg"].get<double>(), frames.at(n).camera.pitch() * 180 / CV_PI, 1e-9);
  EXPECT_EQ(n, 30u);
  testing::StageRunner off;
  for (const Frame& f :
       run_source<VideoSource>(params + "camera_pitch_deg: 3, follow_attitude: false}", &off))
    EXPECT_NEAR(f.camera.pitch() * 180 / CV_PI, 3.0, 1e-9);
}

TEST(VideoSource, StatedValuesWinAndAnUnstatedFrameRateIsSaidLoudly) {
  TempDir dir;
  const auto folder = write_drive(dir, 6);
  testing::StageRunner r;
  const auto frames = run_source<VideoSource>(
      "{path: '" + folder.string() + "', fx: 576, camera_pitch_deg: 0, ego_speed_mps: 7}", &r);
  ASSERT_EQ(frames.size(), 6u);
  const Json cam = read_json(r.output_dir() / "camera.json");
  EXPECT_EQ(cam["fps"], 10.0);
  EXPECT_EQ(cam["sources"]["fps"].get<std::string>().rfind("assumed 10 fps", 0), 0u);
  EXPECT_EQ(cam["pitch_deg"], 0.0);  // stated 0, kept
  EXPECT_EQ(cam["sources"]["pitch_deg"], "stated");
  // The speed is stated but the height is not: the lane lines are still looked at (6 frames may be too few).
  EXPECT_NE(cam["sources"]["height_m"].get<std::string>().find("lane lines"), std::string::npos) << cam.dump(2);
  bool fps_warned = false, pitch_warned = false;
  for (const std::string& l : r.log()) {
    fps_warned = fps_warned || l.find("ASSUMING 10 fps") != std::string::npos;
    pitch_warned = pitch_warned || (l.find("the stated camera pitch 0") != std::string::npos &&
                                    l.find("disagrees with the footage") != std::string::npos);
  }
  EXPECT_TRUE(fps_warned);
  EXPECT_TRUE(pitch_warned) << "a stated pitch the footage contradicts by 3 deg is warned about";
  for (const Frame& f : frames) {
    EXPECT_EQ(*f.ego.speed_mps, 7.0);
    EXPECT_EQ(f.ego.source, "param");
  }
}

TEST(VideoSource, IntrinsicsAreStatedForTheirImageSize) {
  TempDir dir;
  const auto folder = write_drive(dir, 2);
  // Measured on 1280x720 frames: scaled to these 640x360 ones.
  testing::StageRunner r;
  const auto frames = run_source<VideoSource>("{path: '" + folder.string() + "', fps: 10, fx: 1152, cx: 640, cy: 360, "
                                              "intrinsics_size: [1280, 720], self_calibrate: false}", &r);
  EXPECT_DOUBLE_EQ(frames[0].camera.fx, 576);
  EXPECT_DOUBLE_EQ(frames[0].camera.cx, 320);
  // Without the size, a principal point that fits another image is an error naming the size it fits.
  EXPECT_NE(error_of([&] {
              run_source<VideoSource>("{path: '" + folder.string() + "', fps: 10, fx: 1152, cx: 640, cy: 360}");
            }).find("it fits a 1280x720 image: state camera.intrinsics_size"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              run_source<VideoSource>("{path: '" + folder.string() + "', fps: 10, fx: 1152, intrinsics_size: [1000, 1000]}");
            }).find("different aspect ratio"),
            std::string::npos);
}

// Image folders whose names carry times: nuScenes' "..._1538984233512470.jpg" (microseconds), ns and ms
// stamps; frame counters, mixed lengths, names out of time order and a single file give none.
TEST(FolderClock, TimesFromTheFileNames) {
  using source::times_from_names;
  auto paths = [](std::initializer_list<const char*> names) {
    std::vector<std::filesystem::path> v;
    for (const char* n : names) v.emplace_back(std::string("/data/") + n);
    return v;
  };
  const auto us = times_from_names(paths({"n015__CAM_FRONT__1538984233512470.jpg",
                                          "n015__CAM_FRONT__1538984234012472.jpg",
                                          "n015__CAM_FRONT__1538984234412460.jpg"}));
  ASSERT_TRUE(us.has_value());
  EXPECT_EQ(us->unit, "us");
  ASSERT_EQ(us->seconds.size(), 3u);
  EXPECT_DOUBLE_EQ(us->seconds[0], 0.0);
  EXPECT_NEAR(us->seconds[1], 0.500002, 1e-9);
  EXPECT_NEAR(us->seconds[2], 0.899990, 1e-9);
  const auto ns = times_from_names(paths({"ring_front_315966070559696000.png", "ring_front_315966070592963000.png"}));
  ASSERT_TRUE(ns.has_value());
  EXPECT_EQ(ns->unit, "ns");
  EXPECT_NEAR(ns->seconds[1], 0.033267, 1e-9);
  const auto ms = times_from_names(paths({"1700000000000.jpg", "1700000000100.jpg", "1700000000200.jpg"}));
  ASSERT_TRUE(ms.has_value());
  EXPECT_NEAR(ms->median_interval_s, 0.1, 1e-12);
  EXPECT_FALSE(times_from_names(paths({"0000000000.png", "0000000001.png", "0000000002.png"})));  // KITTI counters
  EXPECT_FALSE(times_from_names(paths({"a_1538984233512470.jpg", "a_1538984234012.jpg"})));        // mixed lengths
  EXPECT_FALSE(times_from_names(paths({"b_1538984234012472.jpg", "a_1538984233512470.jpg"})));     // back in time
  EXPECT_FALSE(times_from_names(paths({"x_1538984233512470.jpg"})));
  EXPECT_FALSE(times_from_names(paths({"f_1538984233512470.jpg", "f_1538984333512470.jpg"})));  // 100 s apart
}

// The video source on such a folder: every frame, ego_motion.jsonl and camera.json carry the names' times (not
// index / fps), with no frame rate stated and no warning; a stated rate that agrees keeps them, one that does
// not is used evenly, with a warning naming both. The image_sequence source times them alike.
TEST(FolderClock, AnImageFolderIsTimedByItsNames) {
  TempDir dir;
  const auto folder = dir / "keyframes";
  std::filesystem::create_directories(folder);
  const std::vector<long long> us = {1538984233512470, 1538984234012472, 1538984234512460, 1538984234912460,
                                     1538984235412460};
  for (size_t k = 0; k < us.size(); ++k)
    cv::imwrite((folder / ("CAM_FRONT__" + std::to_string(us[k]) + ".jpg")).string(),
                synthetic(static_cast<int>(k), {160, 90}));
  const std::string base = "path: '" + folder.string() + "', fx: 150, self_calibrate: false";
  {
    testing::StageRunner r;
    const auto frames = run_source<VideoSource>("{" + base + "}", &r);
    ASSERT_EQ(frames.size(), us.size());
    for (size_t k = 0; k < us.size(); ++k)
      EXPECT_NEAR(frames[k].timestamp, (us[k] - us[0]) * 1e-6, 1e-9) << "frame " << k;
    EXPECT_NEAR(*frames[0].stream_end, (us.back() - us[0]) * 1e-6, 1e-9);
    for (const std::string& l : r.log()) EXPECT_EQ(l.find("ASSUMING"), std::string::npos) << l;
    const Json cam = read_json(r.output_dir() / "camera.json");
    EXPECT_NEAR(cam["fps"].get<double>(), 2.0, 1e-3);  // the median interval, 0.5 s
    EXPECT_EQ(cam["sources"]["fps"].get<std::string>().rfind("per-frame times from the file names (us", 0), 0u)
        << cam["sources"]["fps"];
    std::ifstream in(r.output_dir() / "ego_motion.jsonl");
    std::string line;
    for (size_t k = 0; std::getline(in, line); ++k)
      EXPECT_NEAR(Json::parse(line)["timestamp"].get<double>(), (us[k] - us[0]) * 1e-6, 1e-9) << "line " << k;
  }
  {
    testing::StageRunner r;
    const auto frames = run_source<VideoSource>("{" + base + ", fps: 2}", &r);
    EXPECT_NEAR(frames[3].timestamp, 1.39999, 1e-9);  // 0.4 s after frame 2, not 1.5
  }
  {
    testing::StageRunner r;
    const auto frames = run_source<VideoSource>("{" + base + ", fps: 10}", &r);
    EXPECT_NEAR(frames[3].timestamp, 0.3, 1e-12);
    bool warned = false;
    for (const std::string& l : r.log())
      warned = warned || (l.find("the file names carry times at 2.0") != std::string::npos &&
                          l.find("the stated frame rate is 10.0") != std::string::npos);
    EXPECT_TRUE(warned);
  }
  {
    testing::StageRunner r;
    const auto frames = run_source<ImageSequenceSource>("{" + base + ", pattern: '*.jpg'}", &r);
    ASSERT_EQ(frames.size(), us.size());
    EXPECT_NEAR(frames[3].timestamp, 1.39999, 1e-9);
  }
}

TEST(CameraSource, NonexistentDeviceOrUrlFails) {
  EXPECT_EQ(error_of([] { run_source<CameraSource>("{device: '57'}"); }),
            "cannot open camera device '57': no such device or the stream is unreachable");
  EXPECT_EQ(
      error_of([] { run_source<CameraSource>("{url: 'file:///nonexistent/hf/stream.ts'}"); }),
      "cannot open stream 'file:///nonexistent/hf/stream.ts': no such device or the stream is unreachable");
  EXPECT_EQ(error_of([] { run_source<CameraSource>("{}"); }),
            "camera source: give exactly one of 'device' and 'url'");
}

}  // namespace
}  // namespace hf
