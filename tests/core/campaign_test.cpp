// The campaign's candidate windows on scouted frames the tests make, its reason classes, its refusals of bad
// campaign files (through the CLI) and the lifetime of its attempts' processes.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <fstream>

#include <opencv2/imgcodecs.hpp>

#include "command.hpp"
#include "hazardforge/apps/campaign.hpp"
#include "hazardforge/apps/child_process.hpp"
#include "temp_dir.hpp"

namespace hf::apps {
using namespace hf::core;
namespace {

// A 10 Hz recording of `n` frames, Safe, the ego at 8 m/s driving straight.
std::vector<ScoutFrame> clip(int n, double fps = 10.0) {
  std::vector<ScoutFrame> f(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    f[i].frame = i;
    f[i].t = i / fps;
    f[i].ego_speed = 8.0;
    f[i].ego_yaw_rate = 0.0;
    f[i].objects = {{"car", 20.0 + i % 7}, {"car", 35.0}};
  }
  return f;
}

TEST(CampaignWindows, UnsafeFramesStandingEgoAndTooLittleClipLeftAreNoCandidates) {
  CampaignSpec s;
  auto f = clip(80);  // 8 s
  f[30].safe = false;
  f[40].ego_speed = 0.2;  // below min_ego_speed_mps
  const auto w = candidate_windows(f, s);
  std::set<int64_t> triggers;
  for (const auto& x : w) triggers.insert(x.trigger);
  EXPECT_FALSE(triggers.count(0));   // no history at all
  EXPECT_FALSE(triggers.count(30));  // Unsafe already
  EXPECT_FALSE(triggers.count(40));  // the ego stands
  EXPECT_TRUE(triggers.count(70));   // 1.0 s left
  EXPECT_FALSE(triggers.count(71));  // 0.9 s left < min_left_s
  EXPECT_EQ(w.size(), 80u - 1 - 2 - 9);
  EXPECT_NEAR(w.front().history_s, 1.0, 1e-9);
}

TEST(CampaignWindows, AttemptFramesCoverHistoryHorizonAndMargin) {
  CampaignSpec s;
  const auto w = candidate_windows(clip(200), s);  // 20 s
  for (const auto& x : w) {
    if (x.trigger != 50) continue;
    EXPECT_EQ(x.first, 40);                    // 1 s of history: frames 40..49
    EXPECT_EQ(x.last, 50 + 60 + 5);            // the 6 s horizon and 0.5 s margin
    EXPECT_NEAR(x.history_s, 1.0, 1e-9);
    EXPECT_NEAR(*x.turn_deg, 0.0, 1e-9);
    return;
  }
  FAIL() << "frame 50 is no candidate";
}

TEST(CampaignWindows, AStraightStretchComesBeforeABendAndCloseWindowsComeLast) {
  CampaignSpec s;
  auto f = clip(200);
  for (int i = 0; i < 100; ++i) f[i].ego_yaw_rate = 0.3;  // 17 deg/s: a bend for the first 10 s
  const auto w = candidate_windows(f, s);
  ASSERT_FALSE(w.empty());
  EXPECT_GE(w.front().t, 10.0 - 1e-9);   // the best window is on the straight
  EXPECT_LT(std::abs(*w.front().turn_deg), 1.0);
  // The first windows are at least spacing_s apart.
  for (size_t i = 0; i < 5; ++i)
    for (size_t j = i + 1; j < 5; ++j) EXPECT_GE(std::abs(w[i].t - w[j].t), s.spacing_s - 1e-9);
}

TEST(CampaignWindows, SlowFrameRatesGetAtLeastHistoryFramesOfHistory) {
  CampaignSpec s;
  const auto w = candidate_windows(clip(41, 2.0), s);  // nuScenes keyframes: 2 Hz
  for (const auto& x : w)
    if (x.trigger == 20) {
      EXPECT_EQ(x.first, 15);  // 5 frames = 2.5 s, more than history_s
      EXPECT_NEAR(x.history_s, 2.5, 1e-9);
      return;
    }
  FAIL() << "frame 20 is no candidate";
}

TEST(CampaignWindows, AShortClipSpreadsItsWindowsOverAQuarterOfIt) {
  CampaignSpec s;
  const auto w = candidate_windows(clip(50, 25.0), s);  // 2 s at 25 fps: triggers up to 1 s
  ASSERT_GE(w.size(), 2u);
  EXPECT_GE(std::abs(w[0].t - w[1].t), 2.0 / 4 - 1e-9);
}

TEST(CampaignWindows, TheDetectorsReachWeighsAFastEgo) {
  CampaignSpec s;
  auto slow = clip(100), fast = clip(100);
  for (auto& x : fast) x.ego_speed = 30.0;  // a hazard would have to appear ~108 m ahead; tracked up to ~35 m
  const auto ws = candidate_windows(slow, s), wf = candidate_windows(fast, s);
  ASSERT_TRUE(ws.front().reach_m && wf.front().appear_m);
  EXPECT_NEAR(*wf.front().reach_m, 35.0, 1e-9);
  EXPECT_GT(*wf.front().appear_m, 100.0);
  EXPECT_GT(ws.front().score, wf.front().score + 0.5);
}

// Stop-and-go: the ego slows from 3 m/s to a standstill at 5 s. A window is scored by the ground the ego
// still covers after it, not by the clip left: the earliest window whose tracks have history_frames frames
// comes first.
TEST(CampaignWindows, AnEgoThatStopsSoonAfterTheTriggerMeetsNoHazard) {
  CampaignSpec s;
  auto f = clip(100);
  for (auto& x : f) x.ego_speed = std::max(0.0, 3.0 * (1.0 - x.t / 5.0));
  const auto w = candidate_windows(f, s);
  ASSERT_FALSE(w.empty());
  for (const auto& x : w) {
    EXPECT_LT(x.t, 10.0 / 3.0 + 1e-9) << "the ego is below 1 m/s from 3.33 s on";  // min_ego_speed_mps
    EXPECT_NEAR(x.moving_s, 10.0 / 3.0 - x.t, 0.1 + 1e-9);
    EXPECT_GT(x.left_s, x.moving_s);
  }
  EXPECT_EQ(w.front().trigger, 5);  // the first frame with 5 frames before it
  ASSERT_TRUE(w.front().travel_m);
  // The integral of 3 (1 - t / 5) from 0.5 s to the stop, summed frame by frame (each frame's speed over its
  // 0.1 s: half a step's speed change too much).
  EXPECT_NEAR(*w.front().travel_m, 0.3 * 4.5 * 4.5, 0.15);
  EXPECT_GT(w.front().score, w.back().score);
}

// At a constant speed the ground covered ties every window with the whole horizon left; the longer history
// (up to history_s) breaks the tie.
TEST(CampaignWindows, AtAConstantSpeedTheLongerHistoryComesFirst) {
  CampaignSpec s;
  const auto w = candidate_windows(clip(200), s);
  ASSERT_FALSE(w.empty());
  EXPECT_NEAR(w.front().history_s, 1.0, 1e-9);
  ASSERT_TRUE(w.front().travel_m);
  EXPECT_NEAR(*w.front().travel_m, 8.0 * 6.0, 1e-6);
}

// Without the ego's speed the time left to watch the hazard ranks the windows.
TEST(CampaignWindows, WithoutSpeedsTheTimeLeftRanksTheWindows) {
  CampaignSpec s;
  auto f = clip(50);  // 5 s, less than the horizon: later windows have less left
  for (auto& x : f) x.ego_speed.reset();
  const auto w = candidate_windows(f, s);
  ASSERT_GE(w.size(), 2u);
  EXPECT_FALSE(w.front().travel_m.has_value());
  EXPECT_EQ(w.front().trigger, 5);  // the longest time left among the windows with 5 frames before them
  EXPECT_GT(w.front().score, w[1].score);
}

TEST(CampaignReasons, NumbersAreLeftOutSoReasonsCount) {
  EXPECT_EQ(reason_class("the inserted object is never visible (0 of 15 frames)"),
            "the inserted object is never visible (# of # frames)");
  EXPECT_EQ(reason_class("minimum scene TTC 2.26 s >= 1.5 s"), reason_class("minimum scene TTC 1.89 s >= 1.5 s"));
  EXPECT_EQ(reason_class("x at -3.5 m"), "x at # m");
}

// summary.md's "last reasons": the reasons that say why, each once, within the length; the count of the
// rest points to index.json.
TEST(CampaignReasons, TheSummaryShowsTheReasonsThatSayWhyOnce) {
  const std::string none = "no hazard was inserted: no planned trajectory arrived (the run's log says why)";
  const std::string refusal = "node 'generator': frame 25: offline: no hazard fits this scene: the ego stops";
  const std::string shorter =
      "generator: frame 25, horizon 5.2 s: offline: no hazard fits this scene: the ego stops; trying a "
      "horizon "
      "of 4.2 s";
  EXPECT_EQ(reasons_digest(Json::array({none, refusal, shorter, refusal})),
            refusal + " (3 more in index.json)");
  EXPECT_EQ(reasons_digest(Json::array({none})), none);  // alone, it is what there is to say
  EXPECT_EQ(reasons_digest(Json::array({shorter})), shorter);
  EXPECT_EQ(reasons_digest(Json::array()), "");
  const std::string a = "minimum scene TTC 2.89 s", b = "re-detected in 2 of 9 visible frames";
  EXPECT_EQ(reasons_digest(Json::array({a, b})), a + "; " + b);
  EXPECT_EQ(reasons_digest(Json::array({a, b}), 30), a + " (1 more in index.json)");
  // One reason longer than the limit is cut at a word.
  const std::string d = reasons_digest(Json::array({std::string(40, 'x') + " " + std::string(40, 'y')}), 60);
  EXPECT_EQ(d, std::string(40, 'x') + " ...");
}

// A finished attempt as index.json holds it: its window, and whether the generator refused it and with which
// typed reasons (the run manifest's refusals).
Json attempt_at(const CampaignWindow& w, const std::string& outcome, const std::vector<Refusal>& refused) {
  Json a = {{"window", {{"trigger_frame", w.trigger}, {"t_s", w.t}}},
            {"outcome", outcome},
            {"reasons", Json::array({"no hazard was inserted: no planned trajectory arrived"})}};
  if (!refused.empty()) a["refusals"] = refused;
  return a;
}

TEST(CampaignReasons, ARefusalForTrafficDoesNotSayTheSceneForbidsTheKind) {
  CampaignWindow w;
  w.trigger = 21;
  const Refusal traffic{refusal::kTraffic, "cut_in: start point overlaps the detected car (track 1)", "cut_in"};
  const Refusal path{refusal::kTraffic, "cut_in: the planned path runs into the tracked truck (track 3)",
                     "cut_in"};
  const Refusal scene{refusal::kSceneLacks, "cut_in: the road has a single lane", "cut_in"};
  const Refusal timing{refusal::kPlacement, "cut_in: the lane change needs 3.97 s", "cut_in"};
  // Road users of that moment: another window has other traffic.
  EXPECT_TRUE(refused_for_traffic(attempt_at(w, "no hazard", {traffic})));
  EXPECT_TRUE(refused_for_traffic(attempt_at(w, "no hazard", {traffic, path})));
  EXPECT_TRUE(scene_refusal(attempt_at(w, "no hazard", {traffic, path})).empty());
  // What the scene is, alone or beside traffic: the pair stops when it repeats.
  EXPECT_FALSE(refused_for_traffic(attempt_at(w, "no hazard", {scene})));
  EXPECT_FALSE(refused_for_traffic(attempt_at(w, "no hazard", {traffic, timing})));
  EXPECT_EQ(scene_refusal(attempt_at(w, "no hazard", {traffic, timing, scene})),
            (std::set<std::string>{"cut_in:placement", "cut_in:scene_lacks"}));
  // Not refused at all (drawn, then not verified), or refused without typed reasons: neither.
  EXPECT_FALSE(refused_for_traffic(attempt_at(w, "not verified", {traffic})));
  EXPECT_FALSE(refused_for_traffic(attempt_at(w, "no hazard", {})));
  EXPECT_TRUE(scene_refusal(attempt_at(w, "failed", {scene})).empty());
}

// A hazard first seen far away that cannot reach the target in time, or come into view plausibly, is placed
// there from the window's first frame in the pair's next attempts; other refusals change nothing.
TEST(CampaignWindows, AfterAHazardFirstSeenTooFarTheNextAttemptsStartAtTheirTrigger) {
  CampaignWindow w;
  w.trigger = 21;
  const Refusal far{refusal::kTtcUnreachable,
                    "sudden_stop: a lead first seen small (from 45.9 m) cannot bring the TTC to 0.9 s", "sudden_stop"};
  const Refusal view{refusal::kNotInView, "cut_in: no start already under way comes into view from the image border",
                     "cut_in"};
  const Refusal scene{refusal::kSceneLacks, "cut_in: the road has a single lane", "cut_in"};
  EXPECT_FALSE(starts_at_trigger({}));
  EXPECT_FALSE(starts_at_trigger({attempt_at(w, "no hazard", {scene})}));
  EXPECT_FALSE(starts_at_trigger({attempt_at(w, "not verified", {})}));
  EXPECT_TRUE(starts_at_trigger({attempt_at(w, "no hazard", {far})}));
  EXPECT_TRUE(starts_at_trigger({attempt_at(w, "no hazard", {scene, view})}));
  // Once started at its trigger, a pair goes on that way whatever the later outcomes.
  Json from_start = attempt_at(w, "not verified", {});
  from_start["window"]["from_start"] = true;
  EXPECT_TRUE(starts_at_trigger({attempt_at(w, "no hazard", {scene}), from_start}));
}

TEST(CampaignWindows, AfterARefusalForTrafficTheNextAttemptWaitsForTheTrafficToMoveOn) {
  CampaignSpec s;  // 2 seeds per window, traffic_wait_s 1
  std::vector<CampaignWindow> w(5);
  const double t[] = {2.1, 2.3, 0.8, 2.5, 3.4};  // rank order, as candidate_windows gives them
  for (size_t i = 0; i < w.size(); ++i) {
    w[i].trigger = static_cast<int64_t>(std::lround(t[i] * 10));
    w[i].t = t[i];
  }
  const std::vector<Refusal> traffic = {
      {refusal::kTraffic, "cut_in: start point (x 2.9 m, y 3.5 m) overlaps the detected car (track 3)", "cut_in"}};
  const std::vector<Refusal> scene = {{refusal::kSceneLacks, "cut_in: the road has a single lane", "cut_in"}};
  std::vector<Json> done;
  EXPECT_EQ(next_window(w, done, s).trigger, 21);  // the best window first
  // Refused for a car beside the ego: not the same moment again, nor 0.2 s later; the best one >= 1 s later.
  done.push_back(attempt_at(w[0], "no hazard", traffic));
  EXPECT_EQ(next_window(w, done, s).trigger, 34);
  s.traffic_wait_s = 0.4;
  EXPECT_EQ(next_window(w, done, s).trigger, 25);
  s.traffic_wait_s = 1.0;
  // Any other outcome keeps the window for its second seed, then goes on in rank order.
  done = {attempt_at(w[0], "no hazard", scene)};
  EXPECT_EQ(next_window(w, done, s).trigger, 21);
  done.push_back(attempt_at(w[0], "failed", {}));
  EXPECT_EQ(next_window(w, done, s).trigger, 23);
  // Traffic at the last window with no later one left: the best window with seeds left.
  done = {attempt_at(w[4], "no hazard", traffic)};
  EXPECT_EQ(next_window(w, done, s).trigger, 21);
  // Every window had its seeds: they repeat in rank order.
  done.clear();
  for (const CampaignWindow& x : w)
    for (int k = 0; k < s.seeds_per_window; ++k) done.push_back(attempt_at(x, "failed", {}));
  EXPECT_EQ(next_window(w, done, s).trigger, 21);
  EXPECT_FALSE(refused_for_traffic(attempt_at(w[0], "failed", traffic)));  // it was drawn: not a refusal
  EXPECT_TRUE(refused_for_traffic(attempt_at(w[0], "no hazard", traffic)));
}

TEST(CampaignCli, ABadCampaignFileIsRefusedNamingFileLineAndKey) {
  test::TempDir dir;
  const auto spec = dir / "c.yaml";
  std::ofstream(spec) << "name: c\nbudget: {attempts: 0, cpu: 10}\nrecordings:\n  - name: a\n    config: missing.yaml\n"
                      << "  - name: a b\n    config: missing.yaml\n";
  const auto r = test::run_command(std::string(HF_EXE) + " campaign " + test::quote(spec) + " -o " +
                                   test::quote(dir / "out"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find(spec.string() + ":2:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("'attempts' must be a number in [1.0, 1000.0]"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("unknown key 'cpu' in 'budget'"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("missing.yaml not found"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("a recording needs a 'name' of letters"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));  // nothing written for a refused campaign
}

// An attempt dies with the campaign that started it, however the campaign ends (SIGKILL included), so a
// campaign run again never meets a survivor writing into the attempt's folder; and it runs in its own process
// group, so a terminal's Ctrl-C reaches it once, forwarded by the campaign.
TEST(CampaignAttempts, AnAttemptDiesWithItsCampaignAndHasItsOwnProcessGroup) {
  test::TempDir dir;
  int alive[2], report[2];  // alive: the attempt holds the write end while it lives; report: its pid
  ASSERT_EQ(pipe(alive), 0);
  ASSERT_EQ(pipe(report), 0);
  const pid_t campaign = fork();
  ASSERT_GE(campaign, 0);
  if (campaign == 0) {
    close(alive[0]);
    close(report[0]);
    pid_t attempt = 0;
    try {
      attempt = spawn_logged({"/bin/sleep", "600"}, dir / "attempt.log");
    } catch (...) {
      _exit(1);
    }
    if (write(report[1], &attempt, sizeof attempt) != sizeof attempt) _exit(1);
    close(alive[1]);
    pause();
    _exit(0);
  }
  close(alive[1]);
  close(report[1]);
  pid_t attempt = 0;
  ASSERT_EQ(read(report[0], &attempt, sizeof attempt), static_cast<ssize_t>(sizeof attempt));
  close(report[0]);
  EXPECT_EQ(getpgid(attempt), attempt);
  ASSERT_EQ(kill(campaign, SIGKILL), 0);
  int st = 0;
  ASSERT_EQ(waitpid(campaign, &st, 0), campaign);
  // End of file on `alive` once the attempt's copy of the write end is gone, i.e. once it has died. The
  // deadline only bounds a failure; a passing run returns as soon as the attempt is gone.
  pollfd p{alive[0], POLLIN, 0};
  const int ready = poll(&p, 1, 60000);
  char c = 0;
  const bool died = ready == 1 && read(alive[0], &c, 1) == 0;
  close(alive[0]);
  if (!died) kill(attempt, SIGKILL);
  EXPECT_TRUE(died) << "the attempt outlived its campaign by a minute";
}

// A campaign killed while an attempt ran reads the attempt back when its run ended on its own, and runs it
// again only when it did not end.
TEST(CampaignAttempts, AnAttemptThatEndedOnItsOwnIsReadBackNotRunAgain) {
  test::TempDir dir;
  auto with_status = [&](const std::string& status) {
    std::ofstream(dir / "manifest.json") << Json{{"status", status}}.dump();
    return finished_run_exit_code(dir.path());
  };
  EXPECT_EQ(finished_run_exit_code(dir.path()), std::nullopt);  // no manifest: never started
  EXPECT_EQ(with_status("completed"), 0);
  EXPECT_EQ(with_status("incomplete"), 0);
  EXPECT_EQ(with_status("failed"), 1);
  EXPECT_EQ(with_status("interrupted"), std::nullopt);
  EXPECT_EQ(with_status("running"), std::nullopt);
}

// ---- recordings found, not listed
// ---------------------------------------------------------------------------

bool has(const std::vector<std::string>& v, const std::string& x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

TEST(CampaignRecordingsFrom, ANuscenesDatarootGivesEveryMatchingSceneWithItsLogsDrivingSide) {
  test::TempDir dir;
  const auto tables = dir / "v1.0-mini";
  std::filesystem::create_directories(tables);
  std::ofstream(tables / "scene.json")
      << R"([{"token":"s1","name":"scene-0001","log_token":"l1"},{"token":"s2","name":"scene-0002","log_token":"l2"},
             {"token":"s3","name":"scene-0916","log_token":"l1"},{"token":"s4"}])";
  std::ofstream(tables / "log.json") << R"([{"token":"l1","location":"singapore-onenorth"},
                                            {"token":"l2","location":"boston-seaport"}])";
  FoundRecordings f = nuscenes_recordings(dir.path(), "", {"scene-000*"});
  ASSERT_EQ(f.found.size(), 2u);
  EXPECT_EQ(f.found[0].name, "scene-0001");
  EXPECT_TRUE(has(f.found[0].set, "scene.road.driving_side=left"));
  EXPECT_TRUE(has(f.found[0].set, "source.scenes=[\"scene-0001\"]"));
  EXPECT_TRUE(has(f.found[0].set, "source.version=\"v1.0-mini\""));
  EXPECT_TRUE(has(f.found[1].set, "scene.road.driving_side=right"));
  ASSERT_EQ(f.skipped.size(), 1u);  // the scene without a name
  EXPECT_EQ(nuscenes_recordings(dir.path(), "v1.0-mini", {}).found.size(), 3u);

  // No log table: the camera files' log names carry the UTC offset (+0800: Singapore).
  std::filesystem::remove(tables / "log.json");
  std::filesystem::create_directories(dir / "samples" / "CAM_FRONT");
  std::ofstream(dir / "samples" / "CAM_FRONT" / "n015-2018-10-08-15-36-50+0800__CAM_FRONT__1.jpg") << "x";
  f = nuscenes_recordings(dir.path(), "", {"scene-0916"});
  ASSERT_EQ(f.found.size(), 1u);
  EXPECT_TRUE(has(f.found[0].set, "scene.road.driving_side=left"));
  // Two table folders and none named; no table at all.
  std::filesystem::create_directories(dir / "v1.0-trainval");
  std::ofstream(dir / "v1.0-trainval" / "scene.json") << "[]";
  EXPECT_THROW(nuscenes_recordings(dir.path(), "", {}), Error);
  EXPECT_THROW(nuscenes_recordings(dir / "samples", "", {}), Error);
}

TEST(CampaignRecordingsFrom, AKittiRawRootGivesEveryDriveWithItsCameraAndRate) {
  test::TempDir dir;
  const auto date = dir / "2011_09_26";
  std::filesystem::create_directories(date / "2011_09_26_drive_0001_sync" / "image_02" / "data");
  std::filesystem::create_directories(date / "2011_09_26_drive_0002_sync" / "image_02" / "data");
  cv::imwrite((date / "2011_09_26_drive_0001_sync" / "image_02" / "data" / "0000000000.png").string(),
              cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(9)));
  std::ofstream(date / "calib_cam_to_cam.txt")
      << "calib_time: 09-Jan-2012\nP_rect_02: 7.215377e+02 0 6.095593e+02 4.485728e+01 0 7.215377e+02 "
         "1.728540e+02 2.163791e-01 0 0 1 2.745884e-03\n";
  const FoundRecordings f = kitti_raw_recordings(dir.path());
  ASSERT_EQ(f.found.size(), 1u);
  EXPECT_EQ(f.found[0].name, "2011_09_26_drive_0001_sync");
  const auto& set = f.found[0].set;
  EXPECT_TRUE(has(set, "source.fps=10"));
  EXPECT_TRUE(has(set, "scene.camera.fx=721.5377"));
  EXPECT_TRUE(has(set, "scene.camera.cx=609.5593"));
  EXPECT_TRUE(has(set, "scene.camera.cy=172.854"));
  EXPECT_TRUE(has(set, "scene.camera.height_m=1.65"));
  EXPECT_TRUE(has(set, "scene.road.driving_side=right"));
  ASSERT_EQ(f.skipped.size(), 1u);  // drive 2 has no frames
  EXPECT_NE(f.skipped[0].what.find("drive_0002"), std::string::npos);
  EXPECT_THROW(kitti_raw_recordings(dir / "nothing"), Error);
}

TEST(CampaignRecordingsFrom, FilePatternsGiveVideosAndPictureFoldersAndLeaveOutWhatCannotBeRead) {
  test::TempDir dir;
  std::filesystem::create_directories(dir / "a" / "frames");
  std::filesystem::create_directories(dir / "b");
  std::filesystem::create_directories(dir / "a" / "notes");
  std::ofstream(dir / "a" / "drive #1.mp4") << "not empty";
  std::ofstream(dir / "a" / "empty.mp4");
  std::ofstream(dir / "a" / "readme.txt") << "x";
  std::ofstream(dir / "b" / "drive #1.MP4") << "not empty";
  cv::imwrite((dir / "a" / "frames" / "0001.jpg").string(), cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(9)));
  const FoundRecordings f = file_recordings(
      {(dir / "a" / "*").string(), (dir / "b" / "*.{mp4,MP4}").string(), (dir / "c*").string()});
  std::vector<std::string> names, taken;
  for (const auto& r : f.found) names.push_back(unique_recording_name(r.name, taken));
  EXPECT_EQ(names, (std::vector<std::string>{"drive__1", "frames", "drive__1-2"}));
  EXPECT_TRUE(has(f.found[0].set, "source.path=\"" + (dir / "a" / "drive #1.mp4").string() + "\""));
  std::vector<std::string> skipped;
  for (const auto& k : f.skipped)
    skipped.push_back(std::filesystem::path(k.what).filename().string() + ": " + k.reason);
  EXPECT_TRUE(has(skipped, "empty.mp4: empty"));
  EXPECT_TRUE(has(skipped, "notes: a folder without pictures (png, jpg, bmp, tif)"));
  EXPECT_TRUE(has(skipped, "c*: matches nothing"));
  EXPECT_EQ(f.skipped.size(), 3u);  // readme.txt is not a recording and not reported
}

TEST(CampaignRecordingsFrom, AnEntrysErrorsNameFileLineAndKey) {
  test::TempDir dir;
  std::ofstream(dir / "g.yaml") << "nodes: []\n";
  const auto spec = dir / "c.yaml";
  std::ofstream(spec)
      << "name: c\nrecordings_from:\n  - videos: x/*.mp4\n    nuscenes: y\n    config: g.yaml\n"
      << "  - kitti_raw: k\n    config: g.yaml\n    scenes: [a]\n  - videos: x.mp4\n";
  try {
    load_campaign(spec.string());
    FAIL() << "accepted";
  } catch (const DiagnosticError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(":3:"), std::string::npos) << what;
    EXPECT_NE(what.find("an entry names one source"), std::string::npos) << what;
    EXPECT_NE(what.find("'scenes' and 'version' belong to a nuscenes entry"), std::string::npos) << what;
    EXPECT_NE(what.find("needs a 'config'"), std::string::npos) << what;
  }
  // Found entries come after the listed ones, named uniquely, with the entry's overrides last.
  std::filesystem::create_directories(dir / "v");
  std::ofstream(dir / "v" / "a.mp4") << "x";
  std::ofstream(spec) << "name: c\nrecordings:\n  - {name: a, config: g.yaml}\nrecordings_from:\n"
                      << "  - {videos: v/*.mp4, config: g.yaml, set: [source.fps=5]}\n"
                      << "  - {videos: [w/*.mp4], config: g.yaml}\n";
  const CampaignSpec s = load_campaign(spec.string());
  ASSERT_EQ(s.recordings.size(), 2u);
  EXPECT_EQ(s.recordings[1].name, "a-2");
  EXPECT_EQ(s.recordings[1].set.back(), "source.fps=5");
  ASSERT_EQ(s.skipped.size(), 1u);
  EXPECT_NE(s.skipped[0].what.find("c.yaml:6: "), std::string::npos) << s.skipped[0].what;
  EXPECT_EQ(s.skipped[0].reason, "matches nothing");
}

}  // namespace
}  // namespace hf::apps
