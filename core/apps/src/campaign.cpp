// `hazardforge campaign`: a closed-loop search over recordings x hazard kinds. Each recording is scouted once
// (its own assessment, no hazard) to find candidate trigger windows; each (recording, kind) pair then runs
// generate -> plan -> render -> verify attempts over the windows and seeds, feeding every failed attempt's
// reasons back to the generator, until one is verified or the pair's budget is spent. Attempts are child
// processes restricted to their window's frames; each writes attempt.json when it is done, so a campaign run
// again continues where it stopped and repeats nothing. An attempt dies with its campaign and holds a lock
// beside its folder while it lives, so a campaign run again never collides with one still running.
#include <fcntl.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <fstream>
#include <thread>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "hazardforge/atomic_file.hpp"
#include "hazardforge/apps/campaign.hpp"
#include "hazardforge/apps/child_process.hpp"
#include "hazardforge/apps/scenarios.hpp"
#include "hazardforge/json_text.hpp"
#include "hazardforge/markup.hpp"
#include "hazardforge/params.hpp"
#include "hazardforge/redact.hpp"
#include "hazardforge/yaml_json.hpp"

namespace hf::apps {

using namespace hf::core;  // the host's public interface

namespace fs = std::filesystem;

namespace {

constexpr const char* kScoutNode = "campaign_scout";
constexpr const char* kHarvestNode = "campaign_footage_harvest";
constexpr const char* kFootageBank = "appearances";  // below the scouting run: the recording's own cuts
constexpr const char* kPerceptionNode = "campaign_perception";
constexpr const char* kPerceptionFile = "perception.jsonl";  // the detectors' output on the original frames

double self_cpu_s() {
  struct rusage ru {};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
         static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) * 1e-6;
}

std::string fixed(double v, int digits) {
  if (!std::isfinite(v)) return "–";
  std::ostringstream os;
  os << std::fixed << std::setprecision(digits) << v;
  return os.str();
}

bool safe_name(const std::string& s) {
  if (s.empty() || s == "." || s == "..") return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.';
  });
}

// ---- the campaign file ---------------------------------------------------------------------------------------

// Reads a campaign file into a CampaignSpec part by part, collecting every problem with its file and line.
struct CampaignReader {
  const YamlDocument& doc;
  CampaignSpec& s;
  std::vector<Diagnostic> diags;
  std::vector<std::string> names;  // the recordings' names so far

  const Json& v() const { return doc.value; }
  void bad(const std::string& ptr, const std::string& msg) {
    diags.push_back({Diagnostic::Severity::kError, doc.at(ptr), msg});
  }
  void number(const Json& obj, const std::string& ptr, const std::string& key, double& out, double lo,
              double hi) {
    if (!obj.contains(key)) return;
    if (!obj[key].is_number() || obj[key].get<double>() < lo || obj[key].get<double>() > hi) {
      bad(ptr + "/" + key, "'" + key + "' must be a number in [" + fixed(lo, 1) + ", " + fixed(hi, 1) + "]");
      return;
    }
    out = obj[key].get<double>();
  }
  void integer(const Json& obj, const std::string& ptr, const std::string& key, int& out, double lo,
               double hi) {
    double d = out;
    number(obj, ptr, key, d, lo, hi);
    out = static_cast<int>(d);
  }
  Json section(const std::string& key, const std::set<std::string>& allowed) {
    if (!v().contains(key)) return Json::object();
    if (!v()[key].is_object()) {
      bad("/" + key, "'" + key + "' is a mapping");
      return Json::object();
    }
    for (auto it = v()[key].begin(); it != v()[key].end(); ++it)
      if (!allowed.count(it.key())) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        bad("/" + key + "/" + it.key(),
            "unknown key '" + it.key() + "' in '" + key + "' (one of " + list + ")");
      }
    return v()[key];
  }
  void read_set(const Json& r, const std::string& ptr, std::vector<std::string>& out) {
    if (!r.contains("set")) return;
    const Json& set = r["set"];
    if (set.is_string())
      out.push_back(set.get<std::string>());
    else if (set.is_array())
      for (size_t k = 0; k < set.size(); ++k)
        if (set[k].is_string())
          out.push_back(set[k].get<std::string>());
        else
          bad(ptr + "/set/" + std::to_string(k), "an override is a string 'node.param=value'");
    else
      bad(ptr + "/set", "'set' is a list of overrides 'node.param=value'");
  }
  std::optional<fs::path> read_config(const Json& r, const std::string& ptr, const std::string& what) {
    if (!r.contains("config") || !r["config"].is_string()) {
      bad(ptr, what + " needs a 'config': the scenario graph to run on it");
      return std::nullopt;
    }
    fs::path c = expand_vars(r["config"].get<std::string>());
    if (c.is_relative()) c = s.file.parent_path() / c;
    c = c.lexically_normal();
    if (!fs::exists(c)) bad(ptr + "/config", "config " + c.string() + " not found");
    return c;
  }
  void string_list(const Json& x, const std::string& at, std::vector<std::string>& out) {
    if (x.is_string())
      out.push_back(x.get<std::string>());
    else if (x.is_array() && std::all_of(x.begin(), x.end(), [](const Json& e) { return e.is_string(); }))
      for (const Json& e : x) out.push_back(e.get<std::string>());
    else
      bad(at, "a text or a list of texts");
  }
  fs::path path_of(const std::string& text) const {
    fs::path p = expand_vars(text);
    return p.is_relative() ? (s.file.parent_path() / p).lexically_normal() : p;
  }

  void head(const std::string& file);
  void listed();
  void found();
  void found_entry(const Json& r, const std::string& ptr);
};

// name, description, kinds, budget, scenarios_per_pair, windows.
void CampaignReader::head(const std::string& file) {
  static const std::set<std::string> kKeys = {
      "name",    "description", "kinds",           "budget",
      "windows", "recordings",  "recordings_from", "scenarios_per_pair"};
  for (auto it = v().begin(); it != v().end(); ++it)
    if (!kKeys.count(it.key()))
      bad("/" + it.key(),
          "unknown key '" + it.key() +
              "' (a campaign has name, description, kinds, budget, windows, scenarios_per_pair, "
              "recordings, recordings_from)");
  s.name = v().value("name", fs::path(file).stem().string());
  if (!safe_name(s.name)) bad("/name", "name '" + s.name + "' must be letters, digits, '-', '_' or '.'");
  s.description = v().value("description", "");
  if (v().contains("kinds")) {
    if (!v()["kinds"].is_array())
      bad("/kinds", "'kinds' is a list of hazard kinds (hazard_template names)");
    else
      for (size_t i = 0; i < v()["kinds"].size(); ++i)
        if (v()["kinds"][i].is_string())
          s.kinds.push_back(v()["kinds"][i].get<std::string>());
        else
          bad("/kinds/" + std::to_string(i), "a kind is a name, e.g. cut_in");
  }
  const Json budget = section("budget", {"attempts", "cpu_s"});
  integer(budget, "/budget", "attempts", s.attempts, 1, 1000);
  number(budget, "/budget", "cpu_s", s.cpu_s, 1, 1e7);
  integer(v(), "", "scenarios_per_pair", s.scenarios_per_pair, 1, 100);
  const Json w = section(
      "windows", {"history_s", "history_frames", "min_left_s", "max_horizon_s", "margin_s", "spacing_s",
                  "seeds_per_window", "min_ego_speed_mps", "lead_s", "traffic_wait_s", "min_horizon_s"});
  number(w, "/windows", "history_s", s.history_s, 0, 30);
  number(w, "/windows", "min_left_s", s.min_left_s, 0.1, 60);
  number(w, "/windows", "max_horizon_s", s.max_horizon_s, 0.5, 60);
  number(w, "/windows", "margin_s", s.margin_s, 0, 10);
  number(w, "/windows", "spacing_s", s.spacing_s, 0, 60);
  number(w, "/windows", "min_ego_speed_mps", s.min_ego_speed_mps, 0, 80);
  number(w, "/windows", "lead_s", s.lead_s, 0, 20);
  number(w, "/windows", "traffic_wait_s", s.traffic_wait_s, 0, 60);
  number(w, "/windows", "min_horizon_s", s.min_horizon_s, 0, 60);
  integer(w, "/windows", "history_frames", s.history_frames, 0, 1000);
  integer(w, "/windows", "seeds_per_window", s.seeds_per_window, 1, 100);
}

// recordings: each {name, config, set}.
void CampaignReader::listed() {
  if (!v().contains("recordings")) return;
  const Json& list = v()["recordings"];
  if (!list.is_array()) {
    bad("/recordings", "'recordings' is a list of {name, config, set}");
    return;
  }
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string ptr = "/recordings/" + std::to_string(i);
    const Json& r = list[i];
    if (!r.is_object()) {
      bad(ptr, "a recording is {name, config, set}");
      continue;
    }
    for (auto it = r.begin(); it != r.end(); ++it)
      if (it.key() != "name" && it.key() != "config" && it.key() != "set")
        bad(ptr + "/" + it.key(), "unknown key '" + it.key() + "' in a recording (name, config, set)");
    CampaignRecording rec;
    rec.where = doc.at(ptr);
    if (!r.contains("name") || !r["name"].is_string() || !safe_name(r["name"].get<std::string>())) {
      bad(ptr + "/name", "a recording needs a 'name' of letters, digits, '-', '_' or '.'");
      continue;
    }
    rec.name = r["name"].get<std::string>();
    if (std::find(names.begin(), names.end(), rec.name) != names.end())
      bad(ptr + "/name", "two recordings are both named '" + rec.name + "'");
    names.push_back(rec.name);
    const auto c = read_config(r, ptr, "recording '" + rec.name + "'");
    if (!c) continue;
    rec.config = *c;
    rec.set_base = fs::absolute(s.file).parent_path();
    read_set(r, ptr, rec.set);
    s.recordings.push_back(std::move(rec));
  }
}

// recordings_from: recordings found in datasets and file patterns. A wrong key is the campaign file's error;
// what an entry finds but cannot use is reported and left out.
void CampaignReader::found() {
  if (!v().contains("recordings_from")) return;
  if (!v()["recordings_from"].is_array()) {
    bad("/recordings_from", "'recordings_from' is a list of {nuscenes | kitti_raw | videos, config, set}");
    return;
  }
  for (size_t i = 0; i < v()["recordings_from"].size(); ++i)
    found_entry(v()["recordings_from"][i], "/recordings_from/" + std::to_string(i));
}

void CampaignReader::found_entry(const Json& r, const std::string& ptr) {
  static const std::set<std::string> kSources = {"nuscenes", "kitti_raw", "videos"};
  static const std::set<std::string> kKeys = {"nuscenes", "kitti_raw", "videos", "config",
                                              "set",      "scenes",    "version"};
  if (!r.is_object()) {
    bad(ptr, "an entry is {nuscenes: DATAROOT | kitti_raw: FOLDER | videos: PATTERNS, config, set}");
    return;
  }
  std::vector<std::string> sources;
  for (auto it = r.begin(); it != r.end(); ++it) {
    if (!kKeys.count(it.key()))
      bad(ptr + "/" + it.key(), "unknown key '" + it.key() +
                                    "' in recordings_from (nuscenes, kitti_raw or videos; config, set; "
                                    "scenes and version for nuscenes)");
    if (kSources.count(it.key())) sources.push_back(it.key());
  }
  if (sources.size() != 1) {
    bad(ptr, "an entry names one source: nuscenes, kitti_raw or videos");
    return;
  }
  const std::string src = sources.front();
  if ((r.contains("scenes") || r.contains("version")) && src != "nuscenes")
    bad(ptr, "'scenes' and 'version' belong to a nuscenes entry");
  std::vector<std::string> values;  // the source's value(s)
  string_list(r[src], ptr + "/" + src, values);
  const auto c = read_config(r, ptr, "a recordings_from entry");
  std::vector<std::string> set;
  read_set(r, ptr, set);
  if (!c || values.empty()) return;
  FoundRecordings f;
  try {
    if (src == "nuscenes") {
      std::vector<std::string> scenes;
      if (r.contains("scenes")) string_list(r["scenes"], ptr + "/scenes", scenes);
      if (values.size() != 1) bad(ptr + "/nuscenes", "one dataroot per entry");
      f = nuscenes_recordings(path_of(values.front()), r.value("version", ""), scenes);
    } else if (src == "kitti_raw") {
      for (const std::string& root : values) {
        FoundRecordings k = kitti_raw_recordings(path_of(root));
        f.found.insert(f.found.end(), k.found.begin(), k.found.end());
        f.skipped.insert(f.skipped.end(), k.skipped.begin(), k.skipped.end());
      }
    } else {
      std::vector<std::string> patterns;
      for (const std::string& p : values) patterns.push_back(path_of(p).string());
      f = file_recordings(patterns);
    }
  } catch (const Error& e) {
    f.skipped.push_back({ptr, e.what()});
  }
  for (SkippedRecording& k : f.skipped) {
    k.what = s.file.string() + ":" + std::to_string(doc.at(ptr).line) + ": " + k.what;
    s.skipped.push_back(std::move(k));
  }
  for (FoundRecording& fr : f.found) {
    CampaignRecording rec;
    rec.where = doc.at(ptr);
    rec.name = unique_recording_name(fr.name, names);
    rec.config = *c;
    rec.set_base = fs::absolute(s.file).parent_path();
    rec.set = std::move(fr.set);
    rec.set.insert(rec.set.end(), set.begin(), set.end());  // the entry's own overrides win
    s.recordings.push_back(std::move(rec));
  }
}

}  // namespace

CampaignSpec load_campaign(const std::string& file) {
  YamlDocument doc = load_yaml_file(file);
  CampaignSpec s;
  s.file = fs::absolute(file).lexically_normal();
  CampaignReader r{doc, s, {}, {}};
  if (!doc.value.is_object()) {
    r.bad("", "a campaign is a mapping with 'recordings' (and optionally name, kinds, budget, windows)");
    throw DiagnosticError(std::move(r.diags));
  }
  r.head(file);
  const Json& v = doc.value;
  const bool listed = v.contains("recordings"), found = v.contains("recordings_from");
  if ((!listed || !v["recordings"].is_array() || v["recordings"].empty()) &&
      (!found || !v["recordings_from"].is_array() || v["recordings_from"].empty()))
    r.bad(listed  ? "/recordings"
          : found ? "/recordings_from"
                  : "",
          "a campaign needs 'recordings' (a list of {name, config, set}) or 'recordings_from' (a list of "
          "{nuscenes | kitti_raw | videos, config, set})");
  r.listed();
  r.found();
  if (r.diags.empty() && s.recordings.empty()) {
    const std::string first =
        s.skipped.empty() ? std::string("none") : s.skipped.front().what + ": " + s.skipped.front().reason;
    r.bad(found ? "/recordings_from" : "/recordings",
          "no recording found (" + std::to_string(s.skipped.size()) + " left out: " + first + ")");
  }
  if (!r.diags.empty()) throw DiagnosticError(std::move(r.diags));
  return s;
}

namespace {

// ---- scouting: the recording's own assessment ------------------------------------------------------------------

struct Scouted {
  std::vector<ScoutFrame> frames;
  double cpu_s = 0;
  bool has_feedback = false;  // the generator takes `feedback`
  fs::path states;            // the recording's object states (scout.jsonl), when the generator takes them
  fs::path appearances;       // cuts of the recording's own road users (an asset folder), when any were kept
  bool generator_prefers_appearances = false;  // the generator draws their classes first (recording_appearances)
  fs::path perception;        // the detectors' detections on every original frame (kPerceptionFile) ...
  std::vector<std::string> cached_detectors;  // ... of these nodes, which the attempts read back
};

// The detector nodes an attempt can read back from the scouting pass instead of detecting again: those
// upstream of the generator (they see the original frames, as in the scouting pass).
std::vector<std::string> cacheable_detectors(const Graph& g) {
  std::vector<std::string> out;
  for (const std::string& id : upstream_of(g, "generator"))
    if (const NodeSpec* n = g.node(id); n && n->component && n->component->info.kind == kind::kDetector &&
                                         n->component->info.name != "detection_replay")
      out.push_back(id);
  return out;
}

// What the generator node reads (its risk and states inputs) is what the scout records.
Scouted scout(Host& host, const CampaignSpec& spec, const CampaignRecording& rec, const fs::path& dir,
              const CampaignOptions& o) {
  Scouted out;
  Graph g = load_graph(host, rec.config, rec.set, nullptr, true, {}, rec.set_base);
  const NodeSpec* gen = g.node("generator");
  const NodeSpec* ver = g.node("verifier");
  if (!gen || !ver)
    throw Error(spec.file.string() + ":" + std::to_string(rec.where.line) + ": recording '" + rec.name + "': " +
                rec.config.string() +
                " has no node 'generator' and 'verifier' (include configs/subgraphs/hazard_ar.yaml)");
  for (const ParamSpec& p : gen->component->info.params)
    if (p.name == "feedback") out.has_feedback = true;
  bool takes_states = false, takes_appearances = false;
  for (const ParamSpec& p : gen->component->info.params) {
    if (p.name == "recording_states") takes_states = true;
    if (p.name == "recording_appearances") takes_appearances = true;
  }
  Json records = Json::array();
  for (const char* port : {"states", "risk"})
    if (auto it = gen->inputs.find(port); it != gen->inputs.end())
      for (const std::string& s : it->second) records.push_back(s);
  const fs::path run_dir = dir / "scout";
  const Json scout_node = {{"id", kScoutNode},
                           {"stage", "jsonl"},
                           {"inputs", {{"records", records}}},
                           {"params", {{"file", "scout.jsonl"}, {"csv", false}}}};
  const Json manifest = read_json_or_null(run_dir / "manifest.json");
  const bool done = manifest.is_object() && manifest.value("status", "") == "completed" &&
                    fs::exists(run_dir / "scout.jsonl");
  if (!done) {
    RunRequest req;
    req.config = rec.config;
    req.overrides = rec.set;
    req.overrides_dir = rec.set_base;
    req.output_dir = run_dir;
    req.progress = false;
    req.quiet = true;
    req.interrupt = o.interrupt;
    req.extra_nodes = {scout_node};
    req.only_nodes = upstream_of(g, "generator");
    req.only_nodes.push_back(kScoutNode);
    // Perception once per recording: the detections on every original frame, for the attempts to read back.
    if (o.perception_cache)
      if (const std::vector<std::string> dets = cacheable_detectors(g); !dets.empty()) {
        Json recs = Json::array();
        for (const std::string& id : dets) recs.push_back(id + ".detections");
        req.extra_nodes.push_back({{"id", kPerceptionNode},
                                   {"stage", "jsonl"},
                                   {"inputs", {{"records", recs}}},
                                   {"params", {{"file", kPerceptionFile}, {"csv", false}}}});
        req.only_nodes.push_back(kPerceptionNode);
      }
    // The recording's own road users cut out over all of it, from what the renderer sees (its frames, states
    // and tracks), when the scouting pass computes those anyway: the attempts draw their hazards with them.
    if (const NodeSpec* ren = g.node("renderer")) {
      Json inputs = Json::object();
      bool computed = true;
      for (const char* port : {"frames", "states", "tracks"})
        if (auto it = ren->inputs.find(port); it != ren->inputs.end() && it->second.size() == 1) {
          const std::string& src = it->second.front();
          const std::string producer = src.substr(0, src.find('.'));
          if (std::find(req.only_nodes.begin(), req.only_nodes.end(), producer) == req.only_nodes.end())
            computed = false;
          inputs[port] = src;
        }
      // Only for a renderer that takes such cuts and draws with them (footage_appearances not turned off).
      const bool has_footage_param =
          std::any_of(ren->component->info.params.begin(), ren->component->info.params.end(),
                      [](const ParamSpec& p) { return p.name == "footage_assets_dir"; }) &&
          ren->params.value("footage_appearances", true);
      if (computed && inputs.contains("frames") && inputs.contains("states") && has_footage_param &&
          host.registry().find("sink", "footage_harvester")) {
        req.extra_nodes.push_back({{"id", kHarvestNode},
                                   {"stage", "footage_harvester"},
                                   {"inputs", inputs},
                                   {"params", {{"out_dir", kFootageBank}}}});
        req.only_nodes.push_back(kHarvestNode);
      }
    }
    req.folder_use = fs::exists(run_dir / "manifest.json") ? FolderUse::kOverwrite : FolderUse::kNew;
    const double cpu0 = self_cpu_s();
    RunOutcome r = run_config(host, req);
    out.cpu_s = self_cpu_s() - cpu0;
    write_file_atomic(run_dir / "cpu.json", json_text(Json{{"cpu_s", out.cpu_s}}) + "\n");
    if (r.exit_code != 0)
      throw Error("recording '" + rec.name + "': the scouting run failed (" + run_dir.string() + "):\n" +
                  r.message);
  } else {
    const Json cpu = read_json_or_null(run_dir / "cpu.json");
    out.cpu_s = cpu.is_object() ? cpu.value("cpu_s", 0.0) : 0.0;
  }
  // The whole recording's states: an attempt runs on its window only, yet what the recording shows elsewhere
  // (people on the pavement) is a fact about the scene.
  if (takes_states) out.states = fs::absolute(run_dir / "scout.jsonl");
  if (fs::exists(run_dir / kFootageBank / "assets.yaml")) {
    out.appearances = fs::absolute(run_dir / kFootageBank);
    out.generator_prefers_appearances = takes_appearances;
  }
  // A scouting run of an earlier version, or with the cache off, has no such record: its attempts detect.
  if (o.perception_cache && fs::exists(run_dir / kPerceptionFile) &&
      host.registry().find(kind::kDetector, "detection_replay")) {
    out.perception = fs::absolute(run_dir / kPerceptionFile);
    out.cached_detectors = cacheable_detectors(g);
  }
  std::ifstream in(run_dir / "scout.jsonl");
  std::string line;
  while (std::getline(in, line)) {
    Json j = Json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object()) continue;
    ScoutFrame f;
    f.frame = j.value("frame", int64_t{0});
    f.t = j.value("timestamp", 0.0);
    for (auto it = j.begin(); it != j.end(); ++it) {
      const Json& p = it.value();
      if (!p.is_object()) continue;
      if (p.contains("metric") && p.contains("label")) {  // a risk verdict: Safe only if every metric says so
        if (p["label"] != "Safe") f.safe = false;
        if (p.value("unit", "") == "s" && p.contains("scene_value") && p["scene_value"].is_number()) {
          const double ttc = p["scene_value"].get<double>();
          f.scene_ttc = f.scene_ttc ? std::min(*f.scene_ttc, ttc) : ttc;
        }
      } else if (p.contains("objects") && p.contains("ego_speed_mps")) {  // object states
        if (p["ego_speed_mps"].is_number()) f.ego_speed = p["ego_speed_mps"].get<double>();
        if (p.contains("ego_yaw_rate") && p["ego_yaw_rate"].is_number())
          f.ego_yaw_rate = p["ego_yaw_rate"].get<double>();
        for (const Json& ob : p["objects"])
          if (ob.contains("distance_m") && ob["distance_m"].is_number())
            f.objects.push_back({ob.value("label", ""), ob["distance_m"].get<double>()});
      }
    }
    out.frames.push_back(std::move(f));
  }
  if (out.frames.empty()) throw Error("recording '" + rec.name + "': the scouting run saw no frame");
  return out;
}

}  // namespace

// ---- candidate windows ------------------------------------------------------------------------------------------

std::vector<CampaignWindow> candidate_windows(const std::vector<ScoutFrame>& frames, const CampaignSpec& s) {
  std::vector<CampaignWindow> out;
  if (frames.size() < 2) return out;
  std::vector<double> dts;
  for (size_t i = 1; i < frames.size(); ++i) dts.push_back(frames[i].t - frames[i - 1].t);
  std::nth_element(dts.begin(), dts.begin() + dts.size() / 2, dts.end());
  const double dt = std::max(1e-3, dts[dts.size() / 2]);
  const double t_end = frames.back().t + dt;  // the clip ends one frame interval after its last frame
  // How far the detector demonstrably measures distances in this recording (90th percentile of tracked
  // objects): a hazard first seen beyond it would not be re-detected.
  std::vector<double> dist;
  for (const ScoutFrame& f : frames)
    for (const auto& o : f.objects) dist.push_back(o.second);
  std::optional<double> reach;
  if (dist.size() >= 5) {
    std::sort(dist.begin(), dist.end());
    reach = dist[static_cast<size_t>(0.9 * static_cast<double>(dist.size() - 1))];
  }
  const double history = std::max(s.history_s, s.history_frames * dt);  // what a well-tracked trigger has
  for (size_t i = 1; i < frames.size(); ++i) {
    const ScoutFrame& f = frames[i];
    if (!f.safe) continue;
    const double left = t_end - f.t;
    if (left < s.min_left_s - 1e-9) continue;
    if (f.ego_speed && *f.ego_speed < s.min_ego_speed_mps) continue;
    CampaignWindow w;
    w.trigger = f.frame;
    w.t = f.t;
    w.left_s = left;
    w.ego_speed = f.ego_speed;
    w.scene_ttc = f.scene_ttc;
    // Margins: history_s before the trigger (tracks need it for velocities), the horizon after it plus margin_s.
    const double horizon = std::min(left, s.max_horizon_s);
    // History: at least history_frames frames and everything within history_s.
    size_t first_i = i;
    while (first_i > 0 && (i - first_i < static_cast<size_t>(s.history_frames) ||
                           frames[first_i - 1].t >= f.t - s.history_s - 1e-6))
      --first_i;
    w.first = frames[first_i].frame;
    w.last = frames.back().frame;
    const double first_t = frames[first_i].t;
    double turn = 0;
    bool yaw_known = false;
    for (size_t k = 0; k < frames.size(); ++k) {
      const ScoutFrame& g = frames[k];
      if (g.t <= f.t + horizon + s.margin_s + 1e-9) w.last = g.frame;
      if (g.t >= f.t - 1e-9 && g.t < f.t + horizon - 1e-9 && g.ego_yaw_rate) {
        const double step = k + 1 < frames.size() ? frames[k + 1].t - g.t : dt;
        turn += *g.ego_yaw_rate * step;
        yaw_known = true;
      }
    }
    w.history_s = f.t - std::min(first_t, f.t);
    // The time the ego moves in what is left: each frame's interval counts unless the ego is known to stand
    // (below min_ego_speed_mps) then.
    w.moving_s = 0;
    for (size_t k = i; k < frames.size(); ++k) {
      const double step = (k + 1 < frames.size() ? frames[k + 1].t : t_end) - frames[k].t;
      if (!frames[k].ego_speed || *frames[k].ego_speed >= s.min_ego_speed_mps) w.moving_s += step;
    }
    if (yaw_known) w.turn_deg = turn * 180.0 / M_PI;
    // The ground the ego covers over the horizon: every hazard becomes critical by the ego closing in on it,
    // and an ego that crawls (or stops soon after the trigger) leaves a hazard in view no time to get there.
    double travel = 0;
    bool travel_known = true;
    for (size_t k = i; k < frames.size() && frames[k].t < f.t + horizon - 1e-9; ++k) {
      const double step =
          std::min(k + 1 < frames.size() ? frames[k + 1].t : t_end, f.t + horizon) - frames[k].t;
      if (!frames[k].ego_speed)
        travel_known = false;
      else
        travel += std::max(0.0, *frames[k].ego_speed) * step;
    }
    if (travel_known) w.travel_m = travel;
    // The score: the ego's motion after the trigger (the ground it covers over the horizon, relative to the
    // recording's best window, or without speeds the time it still moves), tracks old enough for velocities
    // (history_frames frames; the attempt itself runs history_s before), a Safe margin, a straight ego path
    // (hazards are laid out along it; a bend moves them across kerbs and out of view), and whether an object
    // that must become critical after lead_s + a TTC of 1.5 s is first seen within the detector's reach. The
    // motion term is added once every window is known.
    w.score =
        (s.history_frames > 0 ? std::min<double>(static_cast<double>(i), s.history_frames) / s.history_frames
                              : 1.0) +
        0.05 * (history > 0 ? std::min(w.history_s, history) / history : 1.0);  // breaks near-ties
    w.score += (!f.scene_ttc || *f.scene_ttc >= 3.0) ? 0.5 : 0.0;
    if (w.turn_deg) w.score += 0.5 * std::max(0.0, 1.0 - std::abs(*w.turn_deg) / 20.0);
    if (reach && f.ego_speed) {
      w.appear_m = *f.ego_speed * (s.lead_s + 1.5) + 3.4;
      w.reach_m = *reach;
      w.score += std::min(1.0, *reach / std::max(1.0, *w.appear_m));
    }
    out.push_back(w);
  }
  double best_travel = 0;
  bool all_travel = !out.empty();
  for (const CampaignWindow& w : out) {
    all_travel = all_travel && w.travel_m.has_value();
    if (w.travel_m) best_travel = std::max(best_travel, *w.travel_m);
  }
  for (CampaignWindow& w : out)
    w.score += all_travel && best_travel > 0 ? *w.travel_m / best_travel
                                             : std::min(w.moving_s, s.max_horizon_s) / s.max_horizon_s;
  std::stable_sort(out.begin(), out.end(),
                   [](const CampaignWindow& a, const CampaignWindow& b) { return a.score > b.score; });
  // Spread: a window within spacing_s (at most a quarter of the clip) of a better one adds little; they go to
  // the end of the list.
  const double spacing = std::min(s.spacing_s, (t_end - frames.front().t) / 4.0);
  std::vector<CampaignWindow> spread, close;
  for (const CampaignWindow& w : out) {
    const bool near = std::any_of(spread.begin(), spread.end(),
                                  [&](const CampaignWindow& x) { return std::abs(x.t - w.t) < spacing - 1e-9; });
    (near ? close : spread).push_back(w);
  }
  spread.insert(spread.end(), close.begin(), close.end());
  return spread;
}

Json to_json(const CampaignWindow& w) {
  auto opt = [](const std::optional<double>& v) { return v && std::isfinite(*v) ? Json(*v) : Json(); };
  return {{"trigger_frame", w.trigger},
          {"first_frame", w.first},
          {"last_frame", w.last},
          {"t_s", w.t},
          {"left_s", w.left_s},
          {"moving_s", w.moving_s},
          {"travel_m", opt(w.travel_m)},
          {"history_s", w.history_s},
          {"ego_speed_mps", opt(w.ego_speed)},
          {"scene_ttc_s", opt(w.scene_ttc)},
          {"turn_deg", opt(w.turn_deg)},
          {"appear_m", opt(w.appear_m)},
          {"from_start", w.from_start},
          {"reach_m", opt(w.reach_m)},
          {"score", w.score}};
}

// The same reason with its numbers left out, so reasons can be counted across attempts.
std::string reason_class(const std::string& reason) {
  std::string out;
  bool in_number = false;
  for (size_t i = 0; i < reason.size(); ++i) {
    const char c = reason[i];
    const bool digit = std::isdigit(static_cast<unsigned char>(c)) ||
                       ((c == '.' || c == '-') && i + 1 < reason.size() &&
                        std::isdigit(static_cast<unsigned char>(reason[i + 1])));
    if (digit) {
      if (!in_number) out += '#';
      in_number = true;
    } else {
      in_number = false;
      out += c;
    }
  }
  return out.size() > 160 ? out.substr(0, 157) + "..." : out;
}

std::string reasons_digest(const Json& reasons, size_t max_chars) {
  std::vector<std::string> all;
  for (const Json& r : reasons)
    if (r.is_string() && std::find(all.begin(), all.end(), r.get<std::string>()) == all.end())
      all.push_back(r.get<std::string>());
  const size_t listed = reasons.is_array() ? reasons.size() : 0;
  auto drop = [&all](auto&& pred) {
    std::vector<std::string> kept;
    for (const std::string& r : all)
      if (!pred(r)) kept.push_back(r);
    if (!kept.empty()) all = std::move(kept);
  };
  drop([](const std::string& r) {
    return r.rfind("no hazard was inserted: no planned trajectory arrived", 0) == 0;
  });
  drop([](const std::string& r) { return r.find("; trying a horizon of ") != std::string::npos; });
  std::string out;
  size_t shown = 0;
  for (const std::string& r : all) {
    if (!out.empty() && out.size() + 2 + r.size() > max_chars) break;
    out += (out.empty() ? "" : "; ") + r;
    ++shown;
  }
  if (out.size() > max_chars) {
    size_t cut = out.rfind(' ', max_chars);
    out = out.substr(0, cut == std::string::npos || cut < max_chars / 2 ? max_chars : cut) + " ...";
  }
  if (listed > shown) out += " (" + std::to_string(listed - shown) + " more in index.json)";
  return out;
}

std::vector<Refusal> attempt_refusals(const Json& attempt) {
  std::vector<Refusal> out;
  if (!attempt.is_object() || !attempt.contains("refusals") || !attempt["refusals"].is_array()) return out;
  for (const Json& r : attempt["refusals"])
    if (r.is_object()) out.push_back(r.get<Refusal>());
  return out;
}

bool refused_for_traffic(const Json& attempt) {
  if (!attempt.is_object() || attempt.value("outcome", "") != "no hazard") return false;
  return only_traffic(attempt_refusals(attempt));
}

std::set<std::string> scene_refusal(const Json& attempt) {
  std::set<std::string> r;
  if (!attempt.is_object() || attempt.value("outcome", "") != "no hazard") return r;
  for (const Refusal& f : attempt_refusals(attempt))
    if (f.code != refusal::kTraffic) r.insert(f.kind.empty() ? f.code : f.kind + ":" + f.code);
  return r;
}

namespace {
bool started_at_trigger(const Json& attempt) {
  return attempt.is_object() && attempt.contains("window") && attempt["window"].is_object() &&
         attempt["window"].value("from_start", false);
}
}  // namespace

bool starts_at_trigger(const std::vector<Json>& attempts) {
  for (const Json& a : attempts) {
    if (!a.is_object()) continue;
    if (started_at_trigger(a)) return true;
    if (a.value("outcome", "") != "no hazard") continue;
    for (const Refusal& r : attempt_refusals(a))
      if (r.code == refusal::kTtcUnreachable || r.code == refusal::kNotInView) return true;
  }
  return false;
}

const CampaignWindow& next_window(const std::vector<CampaignWindow>& windows,
                                  const std::vector<Json>& attempts, const CampaignSpec& s) {
  if (windows.empty()) throw Error("next_window(): no candidate window");
  std::map<int64_t, int> used;  // trigger frame -> attempts there
  for (const Json& a : attempts)
    if (a.contains("window") && a["window"].is_object())
      ++used[a["window"].value("trigger_frame", int64_t{-1})];
  auto has_seeds = [&](const CampaignWindow& w) {
    auto it = used.find(w.trigger);
    return it == used.end() || it->second < s.seeds_per_window;
  };
  if (!attempts.empty() && attempts.back().contains("window") && attempts.back()["window"].is_object()) {
    const Json& last = attempts.back();
    const Json& lw = last["window"];
    if (refused_for_traffic(last)) {
      const double later = lw.value("t_s", 0.0) + s.traffic_wait_s - 1e-9;
      for (const CampaignWindow& w : windows)
        if (w.t >= later && has_seeds(w)) return w;
    } else {
      for (const CampaignWindow& w : windows)
        if (w.trigger == lw.value("trigger_frame", int64_t{-1}) && has_seeds(w)) return w;
    }
  }
  for (const CampaignWindow& w : windows)
    if (has_seeds(w)) return w;
  const size_t k = attempts.size();
  return windows[(k / static_cast<size_t>(s.seeds_per_window)) % windows.size()];
}

namespace {

// ---- attempts -------------------------------------------------------------------------------------------------

struct Pair {
  const CampaignRecording* rec = nullptr;
  fs::path recording_states;  // the scout's object states, passed to the generator
  fs::path appearances;       // the scout's cuts of the recording's road users, passed to the renderer
  bool generator_prefers_appearances = false;  // ... and to the generator, which draws their classes first
  fs::path perception;        // the scout's detections, read back by these detector nodes
  std::vector<std::string> cached_detectors;
  std::string kind;
  size_t rec_index = 0;
  std::vector<Json> attempts;  // finished, in order
  bool running = false;
  std::string stopped;  // why no further attempt is made (empty = go on)
  int verified() const {
    return static_cast<int>(std::count_if(attempts.begin(), attempts.end(),
                                          [](const Json& a) { return a.value("passed", false); }));
  }
  double cpu() const {
    double c = 0;
    for (const Json& a : attempts) c += a.value("cpu_s", 0.0);
    return c;
  }
};

struct Planned {
  int index = 0;  // 1-based within the pair
  CampaignWindow window;
  int64_t seed = 1;
  std::string id;
  fs::path dir;
};

fs::path pair_dir(const fs::path& out, const Pair& p) {
  return out / "attempts" / p.rec->name / p.kind;
}

std::string attempt_id(int index, const CampaignWindow& w, int64_t seed) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%02d-f%03lld-s%lld", index, static_cast<long long>(w.trigger),
                static_cast<long long>(seed));
  return buf;
}

// The next attempt of a pair, or why there is none.
std::optional<Planned> plan_next(const Pair& p, const std::vector<CampaignWindow>& windows, const CampaignSpec& s,
                                 const fs::path& out, std::string* why) {
  if (p.verified() >= s.scenarios_per_pair) {
    *why = "verified";
    return std::nullopt;
  }
  if (static_cast<int>(p.attempts.size()) >= s.attempts) {
    *why = "attempt budget spent (" + std::to_string(s.attempts) + ")";
    return std::nullopt;
  }
  if (p.cpu() >= s.cpu_s) {
    *why = "CPU budget spent (" + fixed(p.cpu(), 0) + " of " + fixed(s.cpu_s, 0) + " s)";
    return std::nullopt;
  }
  if (windows.empty()) {
    *why = "no candidate window (no Safe frame with enough of the clip left)";
    return std::nullopt;
  }
  // A graph that does not start (a node's params, files or models) fails the same way at every window.
  if (!p.attempts.empty() && p.attempts.back().value("failed_to_start", false)) {
    const Json reasons = p.attempts.back().value("reasons", Json::array());
    *why = "the attempt's graph does not start: " +
           (reasons.empty() || !reasons.back().is_string() ? std::string("see its run.log")
                                                            : reasons.back().get<std::string>());
    return std::nullopt;
  }
  // A hazard there from the window's first frame once one first seen far away could not do (the generator plans
  // it on the scouting pass's states).
  const bool from_start = !p.recording_states.empty() && starts_at_trigger(p.attempts);
  // The generator refusing this kind for the same reasons at two different trigger frames, both run the way the
  // next would be: the scene does not allow it (no sidewalks, a single lane, ...); more windows and seeds would
  // only repeat the refusal.
  if (p.attempts.size() >= 2) {
    const Json& a = p.attempts[p.attempts.size() - 2];
    const Json& b = p.attempts.back();
    const auto ra = scene_refusal(a), rb = scene_refusal(b);
    if (!ra.empty() && ra == rb && a["window"]["trigger_frame"] != b["window"]["trigger_frame"] &&
        started_at_trigger(a) == from_start && started_at_trigger(b) == from_start) {
      std::vector<Refusal> shown;
      for (const Refusal& r : attempt_refusals(b))
        if (r.code != refusal::kTraffic) shown.push_back(r);
      std::string codes;
      for (const std::string& c : rb) codes += (codes.empty() ? "" : ", ") + c;
      *why = "the generator refuses this kind in this scene (" + codes + "): " + refusal_text(shown);
      return std::nullopt;
    }
  }
  Planned a;
  a.index = static_cast<int>(p.attempts.size()) + 1;
  a.window = next_window(windows, p.attempts, s);
  if (from_start) {
    a.window.from_start = true;
    a.window.first = a.window.trigger;
    a.window.history_s = 0;
  }
  a.seed = a.index;  // every attempt of a pair its own seed
  a.id = attempt_id(a.index, a.window, a.seed);
  a.dir = pair_dir(out, p) / a.id;
  return a;
}

Json feedback_of(const Pair& p) {
  Json fb = {{"attempts", Json::array()}};
  for (const Json& a : p.attempts) {
    if (a.value("passed", false)) continue;
    fb["attempts"].push_back({{"kind", p.kind},
                              {"object_class", a.value("object_class", "")},
                              {"spec", a.contains("spec") ? a["spec"] : Json()},
                              {"reasons", a.value("reasons", Json::array())},
                              {"trigger_frame", a["window"].value("trigger_frame", int64_t{0})},
                              {"seed", a.value("seed", int64_t{0})}});
  }
  return fb;
}

std::vector<std::string> attempt_args(const CampaignOptions& o, const CampaignSpec& s, const Pair& p,
                                      const Planned& a, const fs::path& feedback) {
  std::vector<std::string> args = {(executable_dir() / "hazardforge").string()};
  for (const auto& pp : o.plugin_paths) args.insert(args.end(), {"--plugin-path", pp});
  args.insert(args.end(), {"run", p.rec->config.string(), "-o", a.dir.string(), "-q", "--overwrite", "--frames",
                           std::to_string(a.window.first) + ":" + std::to_string(a.window.last)});
  args.insert(args.end(), {"--set-base", p.rec->set_base.string()});
  for (const std::string& s : p.rec->set) args.insert(args.end(), {"--set", s});
  args.insert(args.end(), {"--set", "generator.trigger=frame", "--set",
                           "generator.trigger_frame=" + std::to_string(a.window.trigger), "--set",
                           "generator.seed=" + std::to_string(a.seed), "--set",
                           "generator.force_kind=" + p.kind, "--set", "generator.kinds=[" + p.kind + "]",
                           "--set", "generator.min_horizon_s=" + fixed(s.min_horizon_s, 2)});
  if (!feedback.empty())
    args.insert(args.end(), {"--set", "generator.feedback=" + fs::absolute(feedback).string()});
  if (!p.recording_states.empty())
    args.insert(args.end(), {"--set", "generator.recording_states=" + p.recording_states.string()});
  if (!p.appearances.empty())
    args.insert(args.end(), {"--set", "renderer.footage_assets_dir=" + p.appearances.string()});
  if (!p.appearances.empty() && p.generator_prefers_appearances)
    args.insert(args.end(), {"--set", "generator.recording_appearances=" + p.appearances.string()});
  for (const std::string& id : p.cached_detectors)
    args.insert(args.end(), {"--set", id + ".stage=detection_replay", "--set",
                             id + ".file=" + Json(p.perception.string()).dump(), "--set",
                             id + ".record=" + id + ".detections"});
  return args;
}

// "node 'generator' (stage 'llm_hazard', /path/lib.so): frame 22: why" -> "node 'generator': frame 22: why"
std::string short_error(std::string e) {
  if (e.rfind("error: ", 0) == 0) e = e.substr(7);
  const auto open = e.find(" (stage '");
  const auto close = e.find("): ", open == std::string::npos ? 0 : open);
  if (e.rfind("node '", 0) == 0 && open != std::string::npos && close != std::string::npos)
    e = e.substr(0, open) + e.substr(close + 1);
  return redact_urls(e);
}

// What an attempt's run folder says about it: the index entry.
Json collect_attempt(const Pair& p, const Planned& a, const ChildExit& ex, double wall_s, const fs::path& out) {
  Json e = {{"recording", p.rec->name},
            {"kind", p.kind},
            {"attempt", a.index},
            {"id", a.id},
            {"window", to_json(a.window)},
            {"seed", a.seed},
            {"folder", fs::relative(a.dir, out).string()},
            {"exit_code", ex.exit_code},
            {"cpu_s", ex.cpu_s},
            {"wall_s", wall_s},
            {"passed", false},
            {"reasons", Json::array()}};
  const Json spec = read_json_or_null(a.dir / "hazard_spec.json");
  if (spec.is_object()) {
    e["spec"] = spec;
    e["object_class"] = spec.value("object_class", "");
  }
  // The verifier's typed verdict (its verification.json); a file that does not read as one is a failed run.
  std::optional<VerificationOutcome> v;
  if (const Json file = read_json_or_null(a.dir / "verification.json"); file.is_object()) {
    try {
      v = file.get<VerificationOutcome>();
    } catch (const Error& err) {
      e["reasons"].push_back((fs::relative(a.dir, out) / "verification.json").string() + ": " + err.what());
    }
  }
  if (v) {
    e["passed"] = v->passed && ex.exit_code == 0;
    e["reason_codes"] = Json::array();
    for (const Refusal& r : v->reasons) {
      e["reasons"].push_back(r.text);
      e["reason_codes"].push_back(r.code);
    }
    e["intended_min_ttc_s"] = v->intended_min_ttc_s ? Json(*v->intended_min_ttc_s) : Json();
    e["achieved_min_ttc_s"] = v->achieved_min_ttc_s ? Json(*v->achieved_min_ttc_s) : Json();
    e["achieved_at_frame"] = v->achieved_at_frame ? Json(*v->achieved_at_frame) : Json();
    e["hazard_critical_frames"] = v->hazard_critical_frames;
    e["spurious_frames"] = v->spurious_frames;
    e["redetection_rate"] = v->redetection_rate ? Json(*v->redetection_rate) : Json();
  }
  const Json m = read_json_or_null(a.dir / "manifest.json");
  e["status"] = m.is_object() ? m.value("status", "missing") : "missing";
  if (m.is_object() && m.value("failed_to_start", false)) e["failed_to_start"] = true;
  // No manifest at all: the run ended before it began, as it will at every window.
  if (!m.is_object() && ex.exit_code != 0) {
    e["failed_to_start"] = true;
    std::string last;
    std::ifstream log(a.dir / "run.log");
    for (std::string line; std::getline(log, line);)
      if (!line.empty()) last = line;
    e["reasons"].push_back("the attempt's run did not start" + (last.empty() ? std::string() : ": " + short_error(last)));
  }
  if (m.is_object() && m.contains("refusals") && m["refusals"].is_array()) {
    e["refusals"] = Json::array();
    for (const Json& r : m["refusals"])
      if (r.is_object() && r.contains("reasons") && r["reasons"].is_array())
        for (const Json& reason : r["reasons"]) e["refusals"].push_back(reason);
  }
  if (ex.exit_code != 0) {
    e["passed"] = false;
    if (m.is_object() && m.contains("errors"))
      for (const Json& err : m["errors"])
        if (err.is_string()) e["reasons"].push_back(short_error(err.get<std::string>()));
    if (e["reasons"].empty())
      e["reasons"].push_back("the attempt's run ended with exit code " + std::to_string(ex.exit_code) +
                             " (see " + (fs::relative(a.dir, out) / "run.log").string() + ")");
  }
  // Without a hazard, the generator's and planner's warnings say why (e.g. the trigger frame was Unsafe).
  if (!spec.is_object() && m.is_object() && m.contains("warnings"))
    for (const Json& w : m["warnings"]) {
      const std::string t = w.is_string() ? w.get<std::string>() : "";
      for (const char* node : {"[generator] warning: ", "[planner] warning: "})
        if (t.rfind(node, 0) == 0)
          e["reasons"].push_back(std::string(node + 1, std::strchr(node, ']') - node - 1) + ": " +
                                 t.substr(std::strlen(node)));
    }
  e["outcome"] = e["passed"].get<bool>()   ? "verified"
                 : !spec.is_object()       ? "no hazard"
                 : v                       ? "not verified"
                                           : "failed";
  return e;
}

// A verified attempt's deliverables, copied into scenarios/<recording>/<kind>/.
fs::path publish(const Json& e, const fs::path& out) {
  const fs::path src = out / e["folder"].get<std::string>();
  const fs::path dst = out / "scenarios" / e["recording"].get<std::string>() / e["kind"].get<std::string>();
  fs::create_directories(dst);
  for (const char* f : {"augmented.mp4", "before_after.mp4", "hazard_spec.json", "trajectory.json",
                        "verification.json", "scenario.xosc", "scenario.xodr", "hazard_maneuvers.xosc"})
    if (fs::exists(src / f)) fs::copy_file(src / f, dst / f, fs::copy_options::overwrite_existing);
  if (fs::exists(src / "stills" / "critical.png"))
    fs::copy_file(src / "stills" / "critical.png", dst / "critical.png", fs::copy_options::overwrite_existing);
  return dst;
}

// The lock an attempt's process holds for as long as it lives (inherited from the campaign, which closes its
// own copy): "<attempt folder>.lock", holding the attempt's pid.
fs::path attempt_lock(const Planned& a) {
  return a.dir.string() + ".lock";
}

// Waits until no process of an earlier campaign (killed while the attempt ran) still holds the attempt's
// lock, then removes the lock.
void wait_for_survivor(const Planned& a, const fs::path& out, bool quiet) {
  const fs::path lock = attempt_lock(a);
  const int fd = ::open(lock.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;
  char holder[64] = {};
  if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
    if (::read(fd, holder, sizeof holder - 1) < 0) holder[0] = '\0';
    if (!quiet)
      std::cerr << "campaign: attempt " << fs::relative(a.dir, out).string() << " (pid " << holder
                << ") of an earlier campaign is still running; waiting for it to end\n";
    while (flock(fd, LOCK_EX) != 0 && errno == EINTR) {
    }
  } else if (::read(fd, holder, sizeof holder - 1) > 0 && std::string(holder).rfind("slurm ", 0) == 0) {
    // A task of a Slurm job array holds no lock here: it runs while the scheduler still has it.
    std::string job(holder + 6);
    job.erase(job.find_last_not_of(" \n") + 1);
    bool told = false;
    while (slurm_job_alive(job)) {
      if (!quiet && !told)
        std::cerr << "campaign: attempt " << fs::relative(a.dir, out).string() << " (Slurm task " << job
                  << ") of an earlier campaign is still queued or running; waiting for it to end\n";
      told = true;
      std::this_thread::sleep_for(std::chrono::seconds(2));  // polling the scheduler
    }
  }
  ::close(fd);
  std::error_code ec;
  fs::remove(lock, ec);
}

// ---- reports ----------------------------------------------------------------------------------------------------

Json summarize(const std::vector<Pair>& pairs, double scout_cpu, double wall_s) {
  Json by_kind = Json::object(), by_rec = Json::object();
  std::map<std::string, int> reasons, refusal_codes, failure_codes;
  int attempts = 0, verified_attempts = 0, verified_pairs = 0, spurious_passes = 0, with_spurious = 0;
  double cpu = scout_cpu;
  for (const Pair& p : pairs) {
    for (Json* row : {&by_kind[p.kind], &by_rec[p.rec->name]}) {
      if (row->is_null()) *row = {{"pairs", 0}, {"verified_pairs", 0}, {"attempts", 0}, {"verified_attempts", 0}};
      (*row)["pairs"] = (*row)["pairs"].get<int>() + 1;
      (*row)["verified_pairs"] = (*row)["verified_pairs"].get<int>() + (p.verified() > 0 ? 1 : 0);
      (*row)["attempts"] = (*row)["attempts"].get<int>() + static_cast<int>(p.attempts.size());
      (*row)["verified_attempts"] = (*row)["verified_attempts"].get<int>() + p.verified();
    }
    verified_pairs += p.verified() > 0 ? 1 : 0;
    attempts += static_cast<int>(p.attempts.size());
    verified_attempts += p.verified();
    cpu += p.cpu();
    for (const Json& a : p.attempts) {
      // A spurious pass: verified without a single Unsafe frame attributed to the hazard.
      if (a.value("passed", false) && a.value("hazard_critical_frames", 0) == 0) ++spurious_passes;
      if (a.value("passed", false) && !a.value("spurious_frames", Json::array()).empty()) ++with_spurious;
      if (a.value("passed", false)) continue;
      if (const std::vector<Refusal> refused = attempt_refusals(a); !refused.empty()) {
        std::set<std::string> codes;  // each code once per attempt
        for (const Refusal& r : refused) codes.insert(r.code);
        for (const std::string& c : codes) ++refusal_codes[c];
        continue;
      }
      if (const Json codes = a.value("reason_codes", Json::array()); !codes.empty()) {
        std::set<std::string> once;
        for (const Json& c : codes)
          if (c.is_string() && !c.get<std::string>().empty()) once.insert(c.get<std::string>());
        for (const std::string& c : once) ++failure_codes[c];
        if (!once.empty()) continue;
      }
      for (const Json& r : a.value("reasons", Json::array()))
        if (r.is_string()) ++reasons[reason_class(r.get<std::string>())];
    }
  }
  for (Json* table : {&by_kind, &by_rec})
    for (auto it = table->begin(); it != table->end(); ++it)
      (*it)["yield"] = (*it)["attempts"].get<int>() > 0 ? (*it)["verified_attempts"].get<double>() /
                                                              (*it)["attempts"].get<double>()
                                                        : 0.0;
  std::vector<std::pair<int, std::string>> sorted;
  for (const auto& [r, n] : reasons) sorted.emplace_back(-n, r);
  std::sort(sorted.begin(), sorted.end());
  Json rs = Json::array();
  for (const auto& [n, r] : sorted) rs.push_back({{"reason", r}, {"count", -n}});
  return {{"pairs", pairs.size()},
          {"verified_pairs", verified_pairs},
          {"attempts", attempts},
          {"verified_attempts", verified_attempts},
          {"yield", attempts > 0 ? static_cast<double>(verified_attempts) / attempts : 0.0},
          {"spurious_passes", spurious_passes},
          {"verified_with_spurious_frames", with_spurious},
          {"cpu_s", cpu},
          {"scout_cpu_s", scout_cpu},
          {"cpu_s_per_verified_scenario", verified_pairs > 0 ? Json(cpu / verified_attempts) : Json()},
          {"wall_s", wall_s},
          {"by_kind", by_kind},
          {"by_recording", by_rec},
          {"failure_reasons", rs},
          {"refusal_codes", refusal_codes},
          {"verification_failure_codes", failure_codes}};
}

std::string summary_markdown(const CampaignSpec& s, const Json& sum, const std::vector<Pair>& pairs) {
  std::ostringstream md;
  md << "# Campaign: " << s.name << "\n\n";
  if (!s.description.empty()) md << s.description << "\n\n";
  md << sum["verified_pairs"].get<int>() << " of " << sum["pairs"].get<int>()
     << " (recording, kind) pairs verified; " << sum["verified_attempts"].get<int>() << " of "
     << sum["attempts"].get<int>() << " attempts verified (yield " << fixed(100 * sum["yield"].get<double>(), 0)
     << " %); " << sum["spurious_passes"].get<int>()
     << " spurious passes (verified without an Unsafe frame attributed to the hazard); "
     << sum["verified_with_spurious_frames"].get<int>()
     << " verified attempts also had Unsafe frames from something else. CPU "
     << fixed(sum["cpu_s"].get<double>(), 0) << " s in all (scouting " << fixed(sum["scout_cpu_s"].get<double>(), 0)
     << " s)";
  if (!sum["cpu_s_per_verified_scenario"].is_null())
    md << ", " << fixed(sum["cpu_s_per_verified_scenario"].get<double>(), 0) << " s per verified scenario";
  md << ".\n\n| recording | kind | result | attempts | CPU s | last reasons |\n|---|---|---|---:|---:|---|\n";
  for (const Pair& p : pairs) {
    std::string last;
    if (!p.attempts.empty() && !p.attempts.back().value("passed", false))
      last = reasons_digest(p.attempts.back().value("reasons", Json::array()));
    md << "| " << p.rec->name << " | " << p.kind << " | "
       << (p.verified() > 0 ? "verified" : p.stopped.empty() ? "pending" : "not verified: " + p.stopped) << " | "
       << p.attempts.size() << " | " << fixed(p.cpu(), 0) << " | " << last << " |\n";
  }
  if (!s.skipped.empty()) {
    md << "\n| left out | why |\n|---|---|\n";
    for (const SkippedRecording& k : s.skipped) md << "| " << k.what << " | " << k.reason << " |\n";
  }
  for (const char* table : {"by_kind", "by_recording"}) {
    md << "\n| " << (std::string(table) == "by_kind" ? "kind" : "recording")
       << " | verified pairs | attempts | verified attempts | yield |\n|---|---:|---:|---:|---:|\n";
    for (auto it = sum[table].begin(); it != sum[table].end(); ++it)
      md << "| " << it.key() << " | " << (*it)["verified_pairs"].get<int>() << " / " << (*it)["pairs"].get<int>()
         << " | " << (*it)["attempts"].get<int>() << " | " << (*it)["verified_attempts"].get<int>() << " | "
         << fixed(100 * (*it)["yield"].get<double>(), 0) << " % |\n";
  }
  if (!sum["refusal_codes"].empty()) {
    md << "\n| generator refusal (code) | attempts |\n|---|---:|\n";
    for (auto it = sum["refusal_codes"].begin(); it != sum["refusal_codes"].end(); ++it)
      md << "| " << it.key() << " | " << it.value().get<int>() << " |\n";
  }
  if (!sum["verification_failure_codes"].empty()) {
    md << "\n| verification failure (code) | attempts |\n|---|---:|\n";
    for (auto it = sum["verification_failure_codes"].begin(); it != sum["verification_failure_codes"].end(); ++it)
      md << "| " << it.key() << " | " << it.value().get<int>() << " |\n";
  }
  if (!sum["failure_reasons"].empty()) {
    md << "\n| other failure (numbers left out) | attempts |\n|---|---:|\n";
    for (const Json& r : sum["failure_reasons"])
      md << "| " << r["reason"].get<std::string>() << " | " << r["count"].get<int>() << " |\n";
  }
  return md.str();
}

std::string html_number(const Json& v, int digits) {
  return v.is_number() ? fixed(v.get<double>(), digits) : "–";
}

std::string index_html(const CampaignSpec& s, const Json& sum, const std::vector<Pair>& pairs) {
  std::ostringstream h;
  h << "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>Campaign " << xml_escape(s.name)
    << "</title>\n<style>body{font-family:sans-serif;margin:1.5em;color:#222}"
       ".grid{display:flex;flex-wrap:wrap;gap:1em}.card{border:1px solid #ccc;border-radius:6px;padding:.5em;"
       "width:660px}.card img{width:100%}table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;"
       "padding:.2em .5em;font-size:90%}.ok{color:#080}.no{color:#a00}</style></head><body>\n";
  h << "<h1>Campaign " << xml_escape(s.name) << "</h1>\n<p>" << xml_escape(s.description) << "</p>\n";
  h << "<p>" << sum["verified_pairs"].get<int>() << " of " << sum["pairs"].get<int>()
    << " (recording, kind) pairs verified; " << sum["verified_attempts"].get<int>() << " of "
    << sum["attempts"].get<int>() << " attempts verified; CPU " << fixed(sum["cpu_s"].get<double>(), 0)
    << " s; spurious passes " << sum["spurious_passes"].get<int>() << ".</p>\n<h2>Verified scenarios</h2>\n"
    << "<div class=\"grid\">\n";
  for (const Pair& p : pairs)
    for (const Json& a : p.attempts) {
      if (!a.value("passed", false)) continue;
      const std::string dir = "scenarios/" + p.rec->name + "/" + p.kind + "/";
      h << "<div class=\"card\"><img src=\"" << xml_escape(dir + "critical.png")
        << "\" alt=\"before and after\"><br><b>" << xml_escape(p.rec->name) << " — " << xml_escape(p.kind) << "</b> ("
        << xml_escape(a.value("object_class", "")) << "), trigger frame " << a["window"]["trigger_frame"].get<int64_t>()
        << ", seed " << a["seed"].get<int64_t>() << "<br>intended min TTC "
        << html_number(a.value("intended_min_ttc_s", Json()), 2) << " s, achieved "
        << html_number(a.value("achieved_min_ttc_s", Json()), 2) << " s at frame "
        << html_number(a.value("achieved_at_frame", Json()), 0) << "; re-detected "
        << html_number(a.contains("redetection_rate") && a["redetection_rate"].is_number()
                           ? Json(100 * a["redetection_rate"].get<double>())
                           : Json(),
                       0)
        << " % of visible frames<br><a href=\"" << xml_escape(dir + "augmented.mp4") << "\">augmented</a> · <a href=\""
        << xml_escape(dir + "before_after.mp4") << "\">before/after</a> · <a href=\""
        << xml_escape(dir + "scenario.xosc") << "\">OpenSCENARIO</a> · <a href=\""
        << xml_escape(dir + "verification.json") << "\">verification</a></div>\n";
    }
  h << "</div>\n<h2>Attempts</h2>\n<table><tr><th>recording</th><th>kind</th><th>#</th><th>trigger</th>"
       "<th>frames</th><th>seed</th><th>class</th><th>result</th><th>intended TTC</th><th>achieved TTC</th>"
       "<th>CPU s</th><th>reasons</th></tr>\n";
  for (const Pair& p : pairs)
    for (const Json& a : p.attempts) {
      std::string reasons;
      for (const Json& r : a.value("reasons", Json::array()))
        reasons += (reasons.empty() ? "" : "<br>") + xml_escape(r.get<std::string>());
      const bool ok = a.value("passed", false);
      h << "<tr><td>" << xml_escape(p.rec->name) << "</td><td>" << xml_escape(p.kind) << "</td><td><a href=\""
        << xml_escape(a["folder"].get<std::string>()) << "/\">" << a["attempt"].get<int>() << "</a></td><td>"
        << a["window"]["trigger_frame"].get<int64_t>() << "</td><td>" << a["window"]["first_frame"].get<int64_t>()
        << "–" << a["window"]["last_frame"].get<int64_t>() << "</td><td>" << a["seed"].get<int64_t>() << "</td><td>"
        << xml_escape(a.value("object_class", "")) << "</td><td class=\"" << (ok ? "ok" : "no") << "\">"
        << xml_escape(a.value("outcome", "")) << "</td><td>" << html_number(a.value("intended_min_ttc_s", Json()), 2)
        << "</td><td>" << html_number(a.value("achieved_min_ttc_s", Json()), 2) << "</td><td>"
        << fixed(a.value("cpu_s", 0.0), 1) << "</td><td>" << reasons << "</td></tr>\n";
    }
  h << "</table>\n</body></html>\n";
  return h.str();
}

void write_reports(const CampaignSpec& s, const fs::path& out, const std::vector<Pair>& pairs,
                   const std::map<std::string, std::vector<CampaignWindow>>& windows, double scout_cpu,
                   double wall_s, bool final) {
  Json sum = summarize(pairs, scout_cpu, wall_s);
  Json index = {{"name", s.name},           {"description", s.description}, {"campaign", s.file.string()},
                {"complete", final},        {"budget", {{"attempts", s.attempts}, {"cpu_s", s.cpu_s}}},
                {"recordings", Json::array()}, {"attempts", Json::array()},    {"summary", sum}};
  for (const CampaignRecording& r : s.recordings) {
    Json wl = Json::array();
    if (auto it = windows.find(r.name); it != windows.end())
      for (const CampaignWindow& w : it->second) wl.push_back(to_json(w));
    index["recordings"].push_back({{"name", r.name}, {"config", r.config.string()}, {"set", r.set},
                                   {"windows", wl}});
  }
  index["skipped"] = Json::array();
  for (const SkippedRecording& k : s.skipped)
    index["skipped"].push_back({{"what", k.what}, {"reason", k.reason}});
  for (const Pair& p : pairs)
    for (const Json& a : p.attempts) index["attempts"].push_back(a);
  write_file_atomic(out / "index.json", json_text(index, 2) + "\n");
  write_file_atomic(out / "index.html", index_html(s, sum, pairs));
  write_file_atomic(out / "summary.md", summary_markdown(s, sum, pairs));
}

}  // namespace

std::optional<int> finished_run_exit_code(const fs::path& run) {
  const Json m = read_json_or_null(run / "manifest.json");
  const std::string status = m.is_object() ? m.value("status", "") : "";
  if (status == "completed" || status == "incomplete") return 0;
  if (status == "failed") return 1;
  return std::nullopt;
}

namespace {

// Plugins loaded, the kinds checked, the campaign file kept beside the results (a folder holds one campaign).
void prepare_campaign_folder(Host& host, CampaignSpec& spec, const CampaignOptions& o, const fs::path& out) {
  std::vector<std::string> load_errors = host.load_plugins();
  for (const auto& e : load_errors) std::cerr << "warning: " << e << "\n";
  const std::vector<std::string> registered = host.registry().component_names(kind::kHazardTemplate);
  if (spec.kinds.empty()) spec.kinds = registered;
  for (const std::string& k : spec.kinds)
    if (std::find(registered.begin(), registered.end(), k) == registered.end()) {
      std::string list;
      for (const auto& r : registered) list += (list.empty() ? "" : ", ") + r;
      throw Error(o.spec + ": kind '" + k + "' is not a registered hazard_template (registered: " + list +
                  ")");
    }
  fs::create_directories(out);
  // The campaign file beside its results, so a folder says what made it; a different one is refused.
  const Json this_spec = load_yaml_file(o.spec).value;
  const fs::path copy = out / "campaign.json";
  if (fs::exists(copy)) {
    const Json before = read_json_or_null(copy);
    if (before != this_spec)
      throw Error(out.string() + " holds a campaign of a different campaign file; use a new folder");
  } else {
    write_file_atomic(copy, json_text(this_spec, 2) + "\n");
  }
}

// Finished attempts of an earlier invocation: kept, never repeated. One whose campaign was killed before it
// could record it is waited for if it still runs, and read back from its folder if its run ended on its own.
void read_back_attempts(Pair& p, const std::vector<CampaignWindow>& windows, const CampaignSpec& spec,
                        const fs::path& out, bool quiet) {
  for (int n = 1;; ++n) {
    std::string why;
    auto next = plan_next(p, windows, spec, out, &why);
    if (!next) break;
    Json done = read_json_or_null(next->dir / "attempt.json");
    if (!done.is_object()) {
      wait_for_survivor(*next, out, quiet);
      const std::optional<int> code = finished_run_exit_code(next->dir);
      if (!code) break;
      std::error_code ec;
      fs::rename(next->dir.string() + ".log", next->dir / "run.log", ec);
      ChildExit ex;
      ex.exit_code = *code;
      const Json m = read_json_or_null(next->dir / "manifest.json");
      done = collect_attempt(p, *next, ex, m.value("wall_seconds", 0.0), out);
      done["read_back"] = true;  // no CPU time: the campaign that started it did not reap it
      if (done.value("passed", false)) done["scenario"] = fs::relative(publish(done, out), out).string();
      write_file_atomic(next->dir / "attempt.json", json_text(done, 2) + "\n");
    }
    p.attempts.push_back(done);
  }
}

// What the scouting passes give the attempts: the (recording, kind) pairs with their finished attempts, each
// recording's candidate windows and whether its generator takes feedback.
struct Scouting {
  std::vector<Pair> pairs;
  std::map<std::string, std::vector<CampaignWindow>> windows;
  std::map<std::string, bool> feedback_ok;
  double cpu_s = 0;
};

// Scouts every recording (a recording that cannot be scouted is left out, in spec.skipped).
Scouting scout_recordings(Host& host, CampaignSpec& spec, const CampaignOptions& o, const fs::path& out) {
  Scouting sc_out;
  for (const SkippedRecording& k : spec.skipped)
    std::cerr << "warning: campaign: left out " << k.what << ": " << k.reason << "\n";
  for (size_t i = 0; i < spec.recordings.size(); ++i) {
    const CampaignRecording& r = spec.recordings[i];
    if (!o.quiet) std::cerr << "campaign: scouting " << r.name << " (" << r.config.string() << ")\n";
    Scouted sc;
    try {
      sc = scout(host, spec, r, out / "recordings" / r.name, o);
    } catch (const Error& e) {
      // A recording that cannot be read (gone, corrupt, a graph its data does not fit) is left out, and
      // scouted again when the campaign runs again.
      if (o.interrupt && o.interrupt->load()) throw Error("interrupted while scouting " + r.name);
      spec.skipped.push_back({r.name, std::string("its scouting run failed: ") + redact_urls(e.what())});
      std::cerr << "warning: campaign: left out " << r.name << ": " << spec.skipped.back().reason << "\n";
      continue;
    }
    if (o.interrupt && o.interrupt->load()) throw Error("interrupted while scouting " + r.name);
    sc_out.cpu_s += sc.cpu_s;
    sc_out.feedback_ok[r.name] = sc.has_feedback;
    sc_out.windows[r.name] = candidate_windows(sc.frames, spec);
    if (!o.quiet)
      std::cerr << "campaign: " << r.name << ": " << sc.frames.size() << " frames, "
                << sc_out.windows[r.name].size() << " candidate trigger frames"
                << (sc.has_feedback ? "" : " (the generator takes no feedback)") << "\n";
    for (const std::string& k : spec.kinds) {
      Pair p;
      p.rec = &spec.recordings[i];
      p.kind = k;
      p.rec_index = i;
      p.recording_states = sc.states;
      p.appearances = sc.appearances;
      p.generator_prefers_appearances = sc.generator_prefers_appearances;
      p.perception = sc.perception;
      p.cached_detectors = sc.cached_detectors;
      read_back_attempts(p, sc_out.windows[r.name], spec, out, o.quiet);
      sc_out.pairs.push_back(std::move(p));
    }
  }
  return sc_out;
}

}  // namespace

int cmd_campaign(Host& host, const CampaignOptions& o) {
  CampaignSpec spec;
  try {
    spec = load_campaign(o.spec);
  } catch (const Error& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const fs::path out =
      fs::absolute(o.output_dir.empty() ? fs::path("runs") / spec.name : fs::path(o.output_dir));
  Scouting scouted;
  try {
    prepare_campaign_folder(host, spec, o, out);
    scouted = scout_recordings(host, spec, o, out);
  } catch (const Error& e) {
    std::cerr << "error: " << redact_urls(e.what()) << "\n";
    return 1;
  }
  std::vector<Pair>& pairs = scouted.pairs;
  std::map<std::string, std::vector<CampaignWindow>>& windows = scouted.windows;
  std::map<std::string, bool>& feedback_ok = scouted.feedback_ok;
  const double scout_cpu = scouted.cpu_s;
  if (pairs.empty()) {
    write_reports(spec, out, pairs, windows, scout_cpu,
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), false);
    std::cerr << "error: campaign: no recording could be scouted (" << spec.skipped.size()
              << " left out; see " << (out / "summary.md").string() << ")\n";
    return 1;
  }

  std::unique_ptr<Executor> exec;
  try {
    exec = o.executor == "slurm" ? slurm_executor(o.slurm, out / "slurm") : local_executor();
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  int started = 0;
  std::map<std::string, std::pair<Pair*, Planned>> running;
  std::map<std::string, std::chrono::steady_clock::time_point> started_at;
  std::vector<std::pair<std::string, fs::path>> unsubmitted;  // Slurm: tasks whose lock gets its job id
  const int jobs = std::max(1, o.jobs);
  bool interrupted = false;
  auto submit = [&] {
    exec->flush();
    for (const auto& [id, lock] : unsubmitted) write_file_atomic(lock, exec->holder(id) + "\n");
    unsubmitted.clear();
  };
  auto finish_one = [&] {
    submit();
    const TaskEnd te = exec->wait_any();
    if (te.id.empty()) return;
    auto it = running.find(te.id);
    if (it == running.end()) return;
    ChildExit ex;
    ex.exit_code = te.exit_code;
    ex.cpu_s = te.cpu_s;
    Pair& p = *it->second.first;
    const Planned a = it->second.second;
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_at[te.id]).count();
    running.erase(it);
    p.running = false;
    std::error_code ec;
    // A run that ended before it made its folder (it could not start: a broken install, a full disk) is
    // recorded in one all the same, with its log.
    fs::create_directories(a.dir, ec);
    fs::rename(a.dir.string() + ".log", a.dir / "run.log", ec);
    fs::remove(attempt_lock(a), ec);
    if (interrupted || ex.exit_code == 130) return;  // not finished: run again next time
    Json e = collect_attempt(p, a, ex, wall, out);
    if (e.value("passed", false)) e["scenario"] = fs::relative(publish(e, out), out).string();
    write_file_atomic(a.dir / "attempt.json", json_text(e, 2) + "\n");
    p.attempts.push_back(e);
    std::string reasons;
    for (const Json& r : e["reasons"]) reasons += "\n    - " + r.get<std::string>();
    std::cerr << "campaign: " << p.rec->name << " / " << p.kind << " #" << a.index << " (frame "
              << a.window.trigger << ", seed " << a.seed << "): " << e["outcome"].get<std::string>()
              << (e.contains("object_class") ? " (" + e["object_class"].get<std::string>() + ")" : "") << ", "
              << fixed(ex.cpu_s, 1) << " s CPU" << reasons << "\n";
    write_reports(spec, out, pairs, windows, scout_cpu,
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), false);
  };
  while (true) {
    if (o.interrupt && o.interrupt->load() && !interrupted) {
      interrupted = true;
      exec->interrupt_all();
    }
    Pair* next_pair = nullptr;
    Planned next;
    if (!interrupted && (o.max_attempts < 0 || started < o.max_attempts))
      for (Pair& p : pairs) {
        if (p.running || !p.stopped.empty()) continue;
        std::string why;
        auto a = plan_next(p, windows[p.rec->name], spec, out, &why);
        if (!a) {
          p.stopped = why;
          continue;
        }
        next_pair = &p;
        next = *a;
        break;
      }
    if (next_pair && static_cast<int>(running.size()) < jobs) {
      fs::path fb;
      if (feedback_ok[next_pair->rec->name] && !next_pair->attempts.empty()) {
        fb = pair_dir(out, *next_pair) / (next.id + ".feedback.json");
        fs::create_directories(fb.parent_path());
        write_file_atomic(fb, json_text(feedback_of(*next_pair), 2) + "\n");
      }
      fs::create_directories(next.dir.parent_path());
      wait_for_survivor(next, out, o.quiet);
      const fs::path lock = attempt_lock(next);
      const int lock_fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
      if (lock_fd < 0 || flock(lock_fd, LOCK_EX | LOCK_NB) != 0) {
        std::cerr << "error: " << lock.string() << ": cannot lock: " << std::strerror(errno) << "\n";
        return 1;
      }
      std::string id;
      try {
        id = exec->start(attempt_args(o, spec, *next_pair, next, fb), next.dir.string() + ".log", lock_fd);
      } catch (const Error&) {
        ::close(lock_fd);
        throw;
      }
      if (o.executor == "slurm") {
        unsubmitted.emplace_back(id, lock);  // its job id goes into the lock once sbatch gave one
      } else {
        const std::string holder = exec->holder(id);
        if (::write(lock_fd, holder.data(), holder.size()) < 0) {
        }
      }
      ::close(lock_fd);  // a local attempt holds the lock now, until it ends
      next_pair->running = true;
      running[id] = {next_pair, next};
      started_at[id] = std::chrono::steady_clock::now();
      ++started;
      if (!o.quiet)
        std::cerr << "campaign: " << next_pair->rec->name << " / " << next_pair->kind << " #" << next.index
                  << " started (frames " << next.window.first << "-" << next.window.last << ", trigger "
                  << next.window.trigger << ", seed " << next.seed << ")\n";
      continue;
    }
    if (running.empty()) break;
    finish_one();
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const bool complete = !interrupted && std::all_of(pairs.begin(), pairs.end(),
                                                    [](const Pair& p) { return !p.stopped.empty(); });
  write_reports(spec, out, pairs, windows, scout_cpu, wall, complete);
  std::ifstream md(out / "summary.md");
  std::cout << md.rdbuf();
  if (interrupted) {
    std::cerr << "campaign interrupted; finished attempts are kept and the campaign continues from them next time\n";
    return 130;
  }
  if (!complete)
    std::cerr << "campaign: stopped after " << started << " attempts (--max-attempts); run it again to go on\n";
  std::cerr << "campaign: -> " << (out / "index.html").string() << "\n";
  return 0;
}

}  // namespace hf::apps
