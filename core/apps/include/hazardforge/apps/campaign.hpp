// `hazardforge campaign`: recordings x hazard kinds, searched in closed loop for verified scenarios
// (docs/campaigns.md).
#pragma once

#include <atomic>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "hazardforge/apps/executor.hpp"
#include "hazardforge/apps/recordings_from.hpp"
#include "hazardforge/core/host.hpp"
#include "hazardforge/refusal.hpp"

namespace hf::apps {

// The CLI uses the host through its public interface (hazardforge/core/*.hpp).
using core::Host;

struct CampaignRecording {
  std::string name;                   // path-safe; names its folders
  std::filesystem::path config;       // a scenario graph with nodes 'generator' and 'verifier'
  std::vector<std::string> set;       // overrides for this recording (source path, scene facts, ...)
  std::filesystem::path set_base;     // relative paths in `set` refer to this (the campaign file's folder)
  SourceLocation where;               // in the campaign file
};

// A campaign file. Defaults are what docs/campaigns.md explains.
struct CampaignSpec {
  std::string name;
  std::string description;
  std::filesystem::path file;
  std::vector<std::string> kinds;  // empty = every registered hazard_template
  int attempts = 6;                // per (recording, kind)
  double cpu_s = 900;              // per (recording, kind), CPU seconds of its attempts
  int scenarios_per_pair = 1;      // verified scenarios wanted per pair
  double history_s = 1.0;          // time before the trigger each attempt runs (tracks need velocities) ...
  int history_frames = 5;  // ... and at least this many frames (new tracks' first velocities are noisy);
                           // a trigger with fewer frames before it ranks lower
  double min_left_s = 1.0;         // clip needed after the trigger
  double max_horizon_s = 6.0;      // the generator's longest horizon: frames after it are not run
  double margin_s = 0.5;           // frames run after the horizon
  double spacing_s = 1.0;          // windows closer than this (at most a quarter of the clip) to a better one
                                   // are tried last
  double min_ego_speed_mps = 1.0;  // a standing ego meets no hazard
  double lead_s = 2.0;             // typical time from a hazard's first sight to its critical moment
  int seeds_per_window = 2;        // attempts at one trigger frame before the next window
  double traffic_wait_s = 1.0;  // after a refusal that names only traffic, the next window is this much later
  double min_horizon_s = 3.0;   // the generator shortens its horizon down to this while no hazard fits
  std::vector<CampaignRecording> recordings;  // listed, then found by recordings_from
  std::vector<SkippedRecording> skipped;      // found but not usable (reported; the campaign goes on)
};

// Reads and checks a campaign file (every problem at once, with file and line). Throws hf::DiagnosticError.
CampaignSpec load_campaign(const std::string& file);

// One frame of a recording's scouting run: its own assessment, no hazard.
struct ScoutFrame {
  int64_t frame = 0;
  double t = 0;
  bool safe = true;                   // every risk metric says Safe
  std::optional<double> scene_ttc;    // lowest scene TTC (s) of the time-to-collision metrics
  std::optional<double> ego_speed;    // m/s, as the generator sees it
  std::optional<double> ego_yaw_rate; // rad/s
  std::vector<std::pair<std::string, double>> objects;  // label, distance (m) of the tracked objects
};

// A candidate trigger frame and the frames an attempt there runs.
struct CampaignWindow {
  int64_t trigger = 0, first = 0, last = 0;
  double t = 0, left_s = 0, history_s = 0, score = 0;
  // Of left_s, the time the ego moves (its speed unknown or at least min_ego_speed_mps): a hazard can only
  // become critical for an ego that still moves.
  double moving_s = 0;
  // The ground (m) the ego covers over the horizon after the trigger, when its speed is known there.
  std::optional<double> travel_m;
  std::optional<double> ego_speed, scene_ttc;
  std::optional<double> turn_deg;  // the ego's heading change over the horizon
  std::optional<double> appear_m;  // where a hazard critical after lead_s must be first seen
  std::optional<double> reach_m;   // 90th percentile of the distances the detector tracked in this recording
  // The attempt runs from its trigger frame (first = trigger): the hazard is there from the clip's first frame,
  // as the recording's objects in view are, planned on the scouting pass's estimates (starts_at_trigger).
  bool from_start = false;
};

// Safe frames with enough clip left, best first (the ground the ego covers over the horizon, or without
// speeds the time it moves; tracks old enough for velocities; a Safe margin; a straight ego path over the
// horizon; the detector's reach at the distance a hazard must appear); windows within spacing_s of a better
// one moved to the end.
std::vector<CampaignWindow> candidate_windows(const std::vector<ScoutFrame>& frames, const CampaignSpec& spec);

// The typed reasons a finished attempt (an index.json entry) was refused for: its run's manifest `refusals`
// (NoHazardFits), copied into the entry's "refusals".
std::vector<Refusal> attempt_refusals(const Json& attempt);

// Whether a finished attempt ended without a hazard because the generator refused it for road users of that
// moment only (every reason refusal::kTraffic): another window has other traffic, so such a refusal at two
// trigger frames does not stop a pair; a refusal for what the scene is (scene_lacks, ...) does.
bool refused_for_traffic(const Json& attempt);

// The codes (with their kinds) of an attempt's refusal other than traffic: two attempts at different
// trigger frames refused for the same ones end the pair.
std::set<std::string> scene_refusal(const Json& attempt);

// Whether a pair's next attempt runs from its trigger frame (CampaignWindow::from_start): once an attempt was
// refused because nothing first seen far enough away reaches the target TTC in time (ttc_unreachable) or comes
// into view plausibly (not_in_view), and for every later attempt of the pair. Needs the scouting pass's states
// (the generator plans on them at a run's first frames).
bool starts_at_trigger(const std::vector<Json>& attempts);

// The window of a pair's next attempt, from its finished attempts in order (index.json entries: "window" with
// "trigger_frame" and "t_s", "outcome", "refusals"): seeds_per_window attempts at a window, windows in rank
// order; after a refusal for traffic, the best-ranked window at least traffic_wait_s later with seeds left
// (the ego has moved on, and the traffic with it). Once every window has had its seeds, they repeat in rank
// order.
const CampaignWindow& next_window(const std::vector<CampaignWindow>& windows,
                                  const std::vector<Json>& attempts, const CampaignSpec& spec);

// A failure reason with its numbers replaced by '#', so reasons can be counted across attempts.
std::string reason_class(const std::string& reason);

// What summary.md shows of an attempt's reasons: the ones that say why, each once, joined up to about
// max_chars, then how many more index.json lists. "No planned trajectory arrived" and a shorter horizon's
// retry (a generator warning ending "trying a horizon of N s") are left out when anything else is listed.
std::string reasons_digest(const Json& reasons, size_t max_chars = 300);

struct CampaignOptions {
  std::string spec;
  std::string output_dir;  // default runs/<name>
  int jobs = 1;
  int max_attempts = -1;   // attempts started by this invocation (-1 = no limit); run again to go on
  bool quiet = false;
  std::string executor = "local";  // local | slurm (attempts as tasks of Slurm job arrays)
  // Attempts read the scouting pass's detections on the original frames back instead of detecting again.
  bool perception_cache = true;
  SlurmOptions slurm;
  std::vector<std::string> plugin_paths;
  const std::atomic<bool>* interrupt = nullptr;
};

// The exit code of the run in folder `run` when it ended on its own (its manifest says completed or
// incomplete: 0, failed: 1); nothing when it was interrupted, never ended or is not there. A campaign killed
// while an attempt ran reads a finished attempt back with it instead of running it again.
std::optional<int> finished_run_exit_code(const std::filesystem::path& run);

int cmd_campaign(Host& host, const CampaignOptions& o);

// `hazardforge campaign status DIR`: what a campaign folder holds now, read from its files alone (no
// campaign file, no plugins): pairs and attempts by state, the recordings left out, every failed attempt with
// its log, attempts still running or queued, and Slurm tasks without an exit status. `json` prints it as one
// JSON object instead. Returns 0, or 1 when DIR is not a campaign folder.
int cmd_campaign_status(const std::filesystem::path& dir, bool json);

}  // namespace hf::apps
