// hazardforge test: every (system, scenario, view) is a run of its own (`hazardforge run` on a generated
// config: the scenario source, the system's graph, the system_responses sink), started in parallel; the
// answers are then scored against the scenario package's labels into report.json, report.html and junit.xml.
#include "hazardforge/apps/system_test.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>

#include "hazardforge/apps/child_process.hpp"
#include "hazardforge/apps/scenarios.hpp"
#include "hazardforge/atomic_file.hpp"
#include "hazardforge/class_groups.hpp"
#include "hazardforge/core/scheduler.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/geometry.hpp"
#include "hazardforge/json_text.hpp"
#include "hazardforge/markup.hpp"
#include "hazardforge/number_text.hpp"
#include "hazardforge/output_path.hpp"
#include "hazardforge/yaml_json.hpp"

namespace hf::apps {

using namespace hf::core;  // the host's public interface
namespace fs = std::filesystem;

namespace {

struct System {
  std::string name;
  fs::path file;
  bool external = false;  // its `system` node is an external_program (started in the file's folder)
};

System read_system(const std::string& file) {
  System s;
  s.file = fs::absolute(file);
  const YamlDocument doc = load_yaml_file(s.file.string());
  const Json& v = doc.value;
  if (!v.is_object() || !v.contains("nodes") || !v["nodes"].is_array())
    throw Error(file + ": a system under test is a subgraph file (description, inputs: {frames}, nodes)");
  if (!v.contains("inputs") || !v["inputs"].is_object() || !v["inputs"].contains("frames"))
    throw Error(file + ": a system under test declares the input 'frames' (inputs: {frames: ...})");
  bool found = false;
  for (const Json& n : v["nodes"]) {
    if (n.is_object() && n.value("id", "") == "system") {
      found = true;
      s.external = n.value("stage", "") == "external_program";
    }
  }
  if (!found)
    throw Error(file +
                ": a system under test has a node with id 'system' whose output 'response' is its answer "
                "(stage external_program, or risk_response after a graph's detections and risk)");
  s.name = safe_path_component(s.file.stem().string());
  return s;
}


Json num(std::optional<double> v) {
  return v && std::isfinite(*v) ? Json(*v) : Json();
}

// The median of some values; none for none.
std::optional<double> median_of(const std::vector<double>& v) {
  return v.empty() ? std::nullopt : std::optional<double>(core::median(v));
}

}  // namespace

std::vector<SystemResponse> read_responses(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw Error("'" + file.string() + "' cannot be read");
  std::vector<SystemResponse> out;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    const std::string where = "'" + file.string() + "' line " + std::to_string(n);
    try {
      const Json j = Json::parse(line);
      SystemResponse r;
      r.frame_index = j.at("frame").get<int64_t>();
      if (j.contains("ttc_s") && j["ttc_s"].is_number()) r.ttc_s = j["ttc_s"].get<double>();
      r.warning = j.value("warning", false);
      r.brake = j.value("brake", false);
      for (const Json& d : j.value("detections", Json::array())) {
        Detection det;
        const Json& b = d.at("box");
        det.box = cv::Rect2f(b.at(0).get<float>(), b.at(1).get<float>(), b.at(2).get<float>(),
                             b.at(3).get<float>());
        det.label = d.value("label", "");
        det.score = d.value("score", 1.f);
        r.detections.push_back(det);
      }
      out.push_back(std::move(r));
    } catch (const nlohmann::json::exception& e) {
      throw Error(where + ": " + e.what());
    }
  }
  return out;
}

Json score_scenario(const scenario::Package& pkg, const std::vector<SystemResponse>& augmented,
                    const std::vector<SystemResponse>& control, const PassRule& rule) {
  std::map<int64_t, const SystemResponse*> aug, ctl;
  for (const auto& r : augmented) aug[r.frame_index] = &r;
  for (const auto& r : control) ctl[r.frame_index] = &r;
  const std::string cls = pkg.header.object_class;
  std::optional<double> t_first_visible, t_critical, t_warn, t_brake, t_detect;
  std::optional<double> range_at_detection, true_ttc_at_warning;
  int visible = 0, matched = 0, right_class = 0, overlapping = 0, answered = 0;
  std::vector<double> ttc_errors;
  Json timeline = Json::array();
  for (const auto& f : pkg.frames) {
    const auto it = aug.find(f.frame);
    const SystemResponse* r = it == aug.end() ? nullptr : it->second;
    if (r) ++answered;
    const bool placed = f.hazard.has_value();
    const bool vis = placed && f.hazard->visible;
    const std::optional<double> gt = placed ? f.hazard->ttc_s : std::nullopt;
    if (vis && !t_first_visible) t_first_visible = f.timestamp;
    if (gt && *gt < rule.critical_ttc_s && !t_critical) t_critical = f.timestamp;
    bool match = false;
    if (vis && r) {
      ++visible;
      double best = 0;
      const Detection* best_d = nullptr;
      for (const auto& d : r->detections) {
        const double v = box_iou(d.box, f.hazard->box);
        if (v > 0.1) ++overlapping;
        if (v > best) {
          best = v;
          best_d = &d;
        }
      }
      if (best >= rule.match_iou) {
        match = true;
        ++matched;
        if (best_d && ClassGroups(default_class_groups()).same(best_d->label, cls)) ++right_class;
        if (!t_detect) {
          t_detect = f.timestamp;
          range_at_detection = f.hazard->distance_m;
        }
        if (gt && r->ttc_s) ttc_errors.push_back(std::abs(*r->ttc_s - *gt));
      }
    } else if (vis) {
      ++visible;
    }
    // A warning counts for the hazard once it is in view; one before that answers the recording's traffic.
    if (r && t_first_visible && (r->warning || r->brake) && !t_warn) {
      t_warn = f.timestamp;
      true_ttc_at_warning = gt;
    }
    if (r && t_first_visible && r->brake && !t_brake) t_brake = f.timestamp;
    timeline.push_back({{"frame", f.frame},
                        {"t", f.timestamp},
                        {"true_ttc_s", num(gt)},
                        {"visible", vis},
                        {"system_ttc_s", r ? num(r->ttc_s) : Json()},
                        {"warning", r && r->warning},
                        {"brake", r && r->brake},
                        {"detected", match}});
  }
  int control_frames = 0;
  Json false_warnings = Json::array();
  for (const auto& f : pkg.frames) {
    const auto it = ctl.find(f.frame);
    if (it == ctl.end()) continue;
    ++control_frames;
    if (it->second->warning || it->second->brake) false_warnings.push_back(f.frame);
  }
  Json s;
  s["frames"] = pkg.frames.size();
  s["answered_frames"] = answered;
  s["detection"] = {{"detected", t_detect.has_value()},
                    {"first_detected_s", num(t_detect)},
                    {"range_at_first_detection_m", num(range_at_detection)},
                    {"visible_frames", visible},
                    {"matched_frames", matched},
                    {"recall", visible ? Json(double(matched) / visible) : Json()},
                    {"precision", overlapping ? Json(double(matched) / overlapping) : Json()},
                    {"right_class_frames", right_class},
                    {"median_ttc_error_s", num(median_of(ttc_errors))}};
  const std::optional<double> lead =
      t_warn && t_critical ? std::optional<double>(*t_critical - *t_warn) : std::nullopt;
  s["warning"] = {{"critical_at_s", num(t_critical)}, {"first_visible_s", num(t_first_visible)},
                  {"warned_at_s", num(t_warn)},       {"true_ttc_at_warning_s", num(true_ttc_at_warning)},
                  {"brake_at_s", num(t_brake)},       {"lead_s", num(lead)}};
  s["control"] = {{"frames", control_frames}, {"false_warning_frames", false_warnings}};
  std::string verdict, why;
  if (!t_critical) {
    verdict = "not_critical";
    why = "the hazard's true TTC never falls below " + num_text(rule.critical_ttc_s) + " s";
  } else if (!t_warn) {
    verdict = "failed";
    why = "no warning or brake request while the hazard was in view";
  } else if (*lead < rule.min_lead_s) {
    verdict = "failed";
    why = "warned " + num_text(*lead, 2) + " s before the true TTC fell below " +
          num_text(rule.critical_ttc_s) + " s; the rule asks " + num_text(rule.min_lead_s) + " s";
  } else {
    verdict = "passed";
    why = "warned " + num_text(*lead, 2) + " s before the true TTC fell below " +
          num_text(rule.critical_ttc_s) + " s";
  }
  s["verdict"] = verdict;
  s["why"] = why;
  s["control"]["verdict"] = control_frames == 0 ? "no_frames" : false_warnings.empty() ? "passed" : "failed";
  s["timeline"] = timeline;
  return s;
}

namespace {

struct Job {
  size_t system = 0, scenario = 0;
  bool augmented = true;
  fs::path config, dir;
};

std::string quoted(const std::string& s) {
  return json_text(Json(s));
}  // a YAML double-quoted scalar

// The generated config of one run: the scenario's frames through the system into system/responses.jsonl.
std::string run_config(const System& sys, const Scenario& sc, bool augmented) {
  std::ostringstream y;
  y << "# Generated by hazardforge test: " << sys.name << " on " << sc.id << " ("
    << (augmented ? "augmented" : "original, the control") << ")\n"
    << "name: " << quoted(sys.name) << "\n"
    << "description: " << quoted("system " + sys.name + " on scenario " + sc.id) << "\n"
    << "nodes:\n"
    << "  - id: source\n    stage: scenario\n    params: {path: " << quoted(sc.pkg.dir.string())
    << ", view: " << (augmented ? "augmented" : "original") << "}\n"
    << "  - include: " << quoted(sys.file.string()) << "\n    inputs: {frames: source.frames}\n"
    << "  - id: system_responses\n    stage: system_responses\n    inputs: {response: system.response}\n";
  return y.str();
}

// The run's first error, from its manifest (else its log's last line).
std::string run_error(const fs::path& dir, int exit_code) {
  std::error_code ec;
  if (fs::is_regular_file(dir / "manifest.json", ec)) {
    try {
      const Json m = read_json_file(dir / "manifest.json");
      if (m.contains("errors") && m["errors"].is_array() && !m["errors"].empty()) {
        const Json& e = m["errors"][0];
        return e.is_string() ? e.get<std::string>() : e.value("message", json_text(e));
      }
    } catch (const Error&) {
    }
  }
  std::ifstream log(dir.string() + ".log");
  std::string line, last;
  while (std::getline(log, line))
    if (!line.empty()) last = line;
  return last.empty() ? "the run ended with exit code " + std::to_string(exit_code) : last;
}

// The time a run spent in the system's own stages (every node but the scenario source and the responses
// sink): their median per frame times the frames, from the run's manifest; 0 when it has none.
double system_seconds(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_regular_file(dir / "manifest.json", ec)) return 0;
  double ms = 0;
  try {
    const Json m = read_json_file(dir / "manifest.json");
    for (const Json& t : m.value("timing", Json::array())) {
      if (t.value("kind", "") == "source" || t.value("node", "") == "system_responses") continue;
      ms += t.value("median_ms", 0.0) * t.value("frames", 0.0);
    }
  } catch (const std::exception&) {
    return 0;
  }
  return ms / 1000.0;
}

std::string svg_timeline(const Json& scen_per_system, const std::vector<std::string>& names) {
  // x: time; y: TTC 0..6 s. The true TTC in black, each system's TTC in its colour, its warnings as ticks.
  static const char* colours[] = {"#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"};
  const double W = 520, H = 160, L = 36, B = 20, ymax = 6.0;
  double t0 = 1e18, t1 = -1e18;
  for (const auto& n : names)
    if (scen_per_system.contains(n))
      for (const Json& p : scen_per_system[n].value("timeline", Json::array())) {
        t0 = std::min(t0, p["t"].get<double>());
        t1 = std::max(t1, p["t"].get<double>());
      }
  if (!(t1 > t0)) return "";
  auto X = [&](double t) { return L + (W - L - 8) * (t - t0) / (t1 - t0); };
  auto Y = [&](double v) { return 8 + (H - B - 8) * (1 - std::min(v, ymax) / ymax); };
  std::ostringstream s;
  s << "<svg width='" << W << "' height='" << H << "' xmlns='http://www.w3.org/2000/svg' font-size='10'>";
  s << "<rect x='" << L << "' y='8' width='" << W - L - 8 << "' height='" << H - B - 8
    << "' fill='none' stroke='#999'/>";
  for (int v = 0; v <= 6; v += 2) s << "<text x='4' y='" << Y(v) + 3 << "'>" << v << " s</text>";
  s << "<line x1='" << L << "' x2='" << W - 8 << "' y1='" << Y(1.5) << "' y2='" << Y(1.5)
    << "' stroke='#bbb' stroke-dasharray='4 3'/>";
  s << "<text x='" << L + 2 << "' y='" << H - 6 << "'>" << fixed_text(t0, 1) << " s</text><text x='" << W - 50
    << "' y='" << H - 6 << "'>" << fixed_text(t1, 1) << " s</text>";
  auto polyline = [&](const Json& tl, const char* key, const char* colour, double width) {
    std::string pts;
    for (const Json& p : tl) {
      if (!p[key].is_number()) {
        if (!pts.empty())
          s << "<polyline fill='none' stroke='" << colour << "' stroke-width='" << width << "' points='"
            << pts << "'/>";
        pts.clear();
        continue;
      }
      pts += fixed_text(X(p["t"].get<double>()), 1) + "," + fixed_text(Y(p[key].get<double>()), 1) + " ";
    }
    if (!pts.empty())
      s << "<polyline fill='none' stroke='" << colour << "' stroke-width='" << width << "' points='" << pts
        << "'/>";
  };
  bool truth_drawn = false;
  for (size_t k = 0; k < names.size(); ++k) {
    if (!scen_per_system.contains(names[k])) continue;
    const Json tl = scen_per_system[names[k]].value("timeline", Json::array());
    if (!truth_drawn) {
      polyline(tl, "true_ttc_s", "#000", 2.5);
      truth_drawn = true;
    }
    const char* c = colours[k % 6];
    polyline(tl, "system_ttc_s", c, 1.2);
    for (const Json& p : tl)
      if (p.value("warning", false) || p.value("brake", false)) {
        const double x = X(p["t"].get<double>());
        const double y0 = H - B - 4 - 5.0 * static_cast<double>(k);
        s << "<line x1='" << x << "' x2='" << x << "' y1='" << y0 << "' y2='" << y0 - 4 << "' stroke='" << c
          << "' stroke-width='" << (p.value("brake", false) ? 3 : 1.5) << "'/>";
      }
  }
  s << "</svg>";
  return s.str();
}

void write_reports(const fs::path& out, const Json& report) {
  write_file_atomic(out / "report.json", json_text(report, 2) + "\n");
  std::vector<std::string> names;
  for (const Json& s : report["systems"]) names.push_back(s["name"].get<std::string>());
  // JUnit XML: a suite per system; per scenario a case for the hazard and one for the control.
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"hazardforge test\">\n";
  for (const Json& sys : report["systems"]) {
    int tests = 0, failures = 0, errors = 0, skipped = 0;
    std::ostringstream cases;
    for (const Json& sc : sys["scenarios"]) {
      const std::string cls = "hazardforge." + sys["name"].get<std::string>();
      const std::string id = sc["id"].get<std::string>();
      const std::string verdict = sc.value("verdict", "error");
      ++tests;
      cases << "    <testcase classname=\"" << xml_escape(cls) << "\" name=\"" << xml_escape(id + " hazard")
            << "\">\n";
      if (verdict == "error") {
        ++errors;
        cases << "      <error message=\"" << xml_escape(sc.value("error", "")) << "\"/>\n";
      } else if (verdict == "failed") {
        ++failures;
        cases << "      <failure message=\"" << xml_escape(sc.value("why", "")) << "\"/>\n";
      } else if (verdict == "not_critical") {
        ++skipped;
        cases << "      <skipped message=\"" << xml_escape(sc.value("why", "")) << "\"/>\n";
      }
      cases << "    </testcase>\n";
      if (verdict == "error") continue;
      ++tests;
      cases << "    <testcase classname=\"" << xml_escape(cls) << "\" name=\"" << xml_escape(id + " control")
            << "\">\n";
      const std::string cv = sc["control"].value("verdict", "no_frames");
      if (cv == "failed") {
        ++failures;
        cases << "      <failure message=\""
              << xml_escape("warned on " + std::to_string(sc["control"]["false_warning_frames"].size()) +
                            " frames of the original recording (false warnings)")
              << "\"/>\n";
      } else if (cv == "no_frames") {
        ++skipped;
        cases << "      <skipped message=\"no control frames\"/>\n";
      }
      cases << "    </testcase>\n";
    }
    x << "  <testsuite name=\"" << xml_escape(sys["name"].get<std::string>()) << "\" tests=\"" << tests
      << "\" failures=\"" << failures << "\" errors=\"" << errors << "\" skipped=\"" << skipped << "\">\n"
      << cases.str() << "  </testsuite>\n";
  }
  x << "</testsuites>\n";
  write_file_atomic(out / "junit.xml", x.str());

  // HTML: the pooled numbers side by side, then per scenario each system's verdict and one timeline.
  std::ostringstream h;
  h << "<!doctype html><html><head><meta charset='utf-8'><title>hazardforge test</title><style>"
       "body{font-family:sans-serif;margin:1.5em}table{border-collapse:collapse}td,th{border:1px solid #ccc;"
       "padding:3px 7px;font-size:13px}.passed{color:#1a7f37}.failed{color:#cf222e}.error{color:#9a6700}"
       "</style></head><body><h1>System test</h1>";
  h << "<p>Pass rule: a warning or brake request at least "
    << num_text(report["rule"]["min_lead_s"].get<double>()) << " s before the hazard's true TTC falls below "
    << num_text(report["rule"]["critical_ttc_s"].get<double>())
    << " s; a detection is the hazard at IoU &ge; " << num_text(report["rule"]["match_iou"].get<double>())
    << ". The control run (original frames) should give no warning.</p>";
  h << "<table><tr><th>system</th><th>scenarios</th><th>passed</th><th>failed</th><th>errors</th>"
       "<th>detected</th><th>recall</th><th>median lead</th><th>control frames warned</th>"
       "<th>time in the system</th></tr>";
  for (const Json& sys : report["systems"]) {
    const Json& p = sys["pooled"];
    h << "<tr><td>" << xml_escape(sys["name"].get<std::string>()) << "</td><td>" << p["scenarios"]
      << "</td><td>" << p["passed"] << "</td><td>" << p["failed"] << "</td><td>" << p["errors"] << "</td><td>"
      << p["detected"] << "</td><td>"
      << (p["recall"].is_number() ? fixed_text(p["recall"].get<double>(), 2) : "-") << "</td><td>"
      << (p["median_lead_s"].is_number() ? fixed_text(p["median_lead_s"].get<double>(), 2) + " s" : "-")
      << "</td><td>" << p["control_false_warning_frames"] << " / " << p["control_frames"] << "</td><td>"
      << (p["overhead_share"].is_number()
              ? fixed_text(100.0 * (1.0 - p["overhead_share"].get<double>()), 0) + " % of " +
                    fixed_text(p["runs_wall_s"].get<double>(), 1) + " s"
              : "-")
      << "</td></tr>";
  }
  h << "</table><h2>Scenarios</h2><p>Timelines: the hazard's true TTC in black, each system's TTC in its "
       "colour "
       "(the dashed line: the critical TTC), its warnings as ticks along the bottom (thick: brake).</p>";
  std::map<std::string, Json> per_scenario;
  std::vector<std::string> order;
  for (const Json& sys : report["systems"])
    for (const Json& sc : sys["scenarios"]) {
      const std::string id = sc["id"].get<std::string>();
      if (!per_scenario.count(id)) order.push_back(id);
      per_scenario[id][sys["name"].get<std::string>()] = sc;
    }
  for (const auto& id : order) {
    const Json& by = per_scenario[id];
    h << "<h3>" << xml_escape(id)
      << "</h3><table><tr><th>system</th><th>verdict</th><th>why</th>"
         "<th>first detected</th><th>recall</th><th>lead</th><th>control</th></tr>";
    for (const auto& n : names) {
      if (!by.contains(n)) continue;
      const Json& sc = by[n];
      const std::string v = sc.value("verdict", "error");
      h << "<tr><td>" << xml_escape(n) << "</td><td class='" << (v == "not_critical" ? "" : v) << "'>" << v
        << "</td><td>" << xml_escape(v == "error" ? sc.value("error", "") : sc.value("why", "")) << "</td>";
      if (v == "error") {
        h << "<td colspan=4></td></tr>";
        continue;
      }
      const Json& d = sc["detection"];
      h << "<td>"
        << (d["first_detected_s"].is_number()
                ? fixed_text(d["first_detected_s"].get<double>(), 2) + " s at " +
                      (d["range_at_first_detection_m"].is_number()
                           ? fixed_text(d["range_at_first_detection_m"].get<double>(), 1) + " m"
                           : std::string("?"))
                : std::string("never"))
        << "</td><td>" << (d["recall"].is_number() ? fixed_text(d["recall"].get<double>(), 2) : "-")
        << "</td><td>"
        << (sc["warning"]["lead_s"].is_number() ? fixed_text(sc["warning"]["lead_s"].get<double>(), 2) + " s"
                                                : "-")
        << "</td><td>" << sc["control"]["false_warning_frames"].size() << " false warnings</td></tr>";
    }
    h << "</table>" << svg_timeline(by, names);
  }
  h << "</body></html>\n";
  write_file_atomic(out / "report.html", h.str());
}

}  // namespace

int cmd_test(Host& /*host*/, const SystemTestOptions& o) {
  std::vector<System> systems;
  std::vector<Scenario> scenarios;
  try {
    for (const auto& f : o.systems) systems.push_back(read_system(f));
    std::set<std::string> names;
    for (auto& s : systems) {
      const std::string base = s.name;
      for (int n = 2; names.count(s.name); ++n) s.name = base + "-" + std::to_string(n);
      names.insert(s.name);
    }
    scenarios = find_scenarios(o.scenarios);
  } catch (const Error& e) {
    std::cerr << "test: " << e.what() << "\n";
    return 2;
  }
  if (scenarios.empty()) {
    std::cerr << "test: no scenario to test\n";
    return 2;
  }
  const fs::path out = fs::absolute(o.output_dir.empty() ? "runs/test" : o.output_dir);
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_empty(out, ec) && !fs::exists(out / "report.json", ec) &&
      !fs::exists(out / "runs", ec)) {
    std::cerr << "test: '" << out.string() << "' holds files that are not a test's; give an empty folder\n";
    return 2;
  }
  fs::create_directories(out / "runs");
  std::vector<Job> jobs;
  for (size_t i = 0; i < systems.size(); ++i)
    for (size_t k = 0; k < scenarios.size(); ++k)
      for (bool aug : {true, false}) {
        Job j;
        j.system = i;
        j.scenario = k;
        j.augmented = aug;
        const fs::path base = out / "runs" / systems[i].name / scenarios[k].id;
        fs::create_directories(base);
        j.dir = base / (aug ? "augmented" : "control");
        j.config = base / (aug ? "augmented.yaml" : "control.yaml");
        write_file_atomic(j.config, run_config(systems[i], scenarios[k], aug));
        jobs.push_back(std::move(j));
      }
  const std::string exe = (executable_dir() / "hazardforge").string();
  std::map<pid_t, size_t> running;
  std::vector<int> codes(jobs.size(), -1);
  std::vector<double> cpu(jobs.size(), 0.0), wall(jobs.size(), 0.0);
  std::vector<std::chrono::steady_clock::time_point> started(jobs.size());
  size_t next = 0;
  auto reap_one = [&] {
    const ChildExit ex = wait_any_child();
    if (ex.pid <= 0) return;
    const auto it = running.find(ex.pid);
    if (it == running.end()) return;
    codes[it->second] = ex.exit_code;
    cpu[it->second] = ex.cpu_s;
    wall[it->second] =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started[it->second]).count();
    const Job& j = jobs[it->second];
    std::cerr << "test: " << systems[j.system].name << " on " << scenarios[j.scenario].id << " ("
              << (j.augmented ? "augmented" : "control") << ") "
              << (ex.exit_code == 0 ? "done" : "FAILED, see " + j.dir.string() + ".log") << "\n";
    running.erase(it);
  };
  bool interrupted = false;
  while (next < jobs.size() || !running.empty()) {
    if (o.interrupt && o.interrupt->load()) {
      for (auto& [pid, i] : running) kill(pid, SIGINT);
      while (!running.empty()) reap_one();
      interrupted = true;
      break;
    }
    if (next < jobs.size() && running.size() < static_cast<size_t>(std::max(1, o.jobs))) {
      const Job& j = jobs[next];
      std::vector<std::string> args = {exe};
      for (const auto& p : o.plugin_paths) args.insert(args.end(), {"--plugin-path", p});
      args.insert(args.end(), {"run", j.config.string(), "-o", j.dir.string(), "-q", "--overwrite"});
      if (systems[j.system].external)
        args.insert(args.end(),
                    {"--set", "system.working_dir=" + systems[j.system].file.parent_path().string()});
      started[next] = std::chrono::steady_clock::now();
      running[spawn_logged(args, j.dir.string() + ".log")] = next;
      ++next;
      continue;
    }
    reap_one();
  }
  PassRule rule{o.critical_ttc_s, o.min_lead_s, o.match_iou};
  Json report = {{"schema", "hazardforge-test/1"},
                 {"rule",
                  {{"critical_ttc_s", rule.critical_ttc_s},
                   {"min_lead_s", rule.min_lead_s},
                   {"match_iou", rule.match_iou}}},
                 {"systems", Json::array()}};
  for (size_t i = 0; i < systems.size(); ++i) {
    Json sys = {{"name", systems[i].name}, {"file", systems[i].file.string()}, {"scenarios", Json::array()}};
    int passed = 0, failed = 0, errors = 0, detected = 0, ctl_frames = 0, ctl_warned = 0, vis = 0,
        matched = 0;
    double system_cpu = 0, runs_wall = 0, system_s = 0;
    std::vector<double> leads;
    for (size_t k = 0; k < scenarios.size(); ++k) {
      const Scenario& sc = scenarios[k];
      const Job& ja = jobs[(i * scenarios.size() + k) * 2];
      const Job& jc = jobs[(i * scenarios.size() + k) * 2 + 1];
      const int ia = static_cast<int>((i * scenarios.size() + k) * 2);
      system_cpu += cpu[ia] + cpu[ia + 1];
      runs_wall += wall[ia] + wall[ia + 1];
      system_s += system_seconds(ja.dir) + system_seconds(jc.dir);
      Json entry;
      std::string error;
      for (const Job* j : {&ja, &jc})
        if (codes[static_cast<size_t>(j - jobs.data())] != 0 && error.empty())
          error = "scenario " + sc.id + " (" + (j->augmented ? "augmented" : "control") + "): " +
                  (codes[static_cast<size_t>(j - jobs.data())] < 0
                       ? std::string("not run (interrupted)")
                       : run_error(j->dir, codes[static_cast<size_t>(j - jobs.data())]));
      if (error.empty()) {
        try {
          entry = score_scenario(sc.pkg, read_responses(ja.dir / "system" / "responses.jsonl"),
                                 read_responses(jc.dir / "system" / "responses.jsonl"), rule);
        } catch (const Error& e) {
          error = "scenario " + sc.id + ": " + e.what();
        }
      }
      if (!error.empty()) entry = {{"verdict", "error"}, {"error", error}};
      entry["id"] = sc.id;
      entry["kind"] = sc.pkg.header.kind;
      entry["object_class"] = sc.pkg.header.object_class;
      entry["recording"] = sc.recording;
      entry["runs"] = {{"augmented", fs::relative(ja.dir, out).string()},
                       {"control", fs::relative(jc.dir, out).string()}};
      const std::string v = entry["verdict"];
      passed += v == "passed";
      failed += v == "failed";
      errors += v == "error";
      if (v != "error") {
        detected += entry["detection"]["detected"].get<bool>();
        vis += entry["detection"]["visible_frames"].get<int>();
        matched += entry["detection"]["matched_frames"].get<int>();
        ctl_frames += entry["control"]["frames"].get<int>();
        ctl_warned += static_cast<int>(entry["control"]["false_warning_frames"].size());
        if (entry["warning"]["lead_s"].is_number()) leads.push_back(entry["warning"]["lead_s"].get<double>());
      }
      sys["scenarios"].push_back(entry);
    }
    sys["pooled"] = {{"scenarios", scenarios.size()},
                     {"passed", passed},
                     {"failed", failed},
                     {"errors", errors},
                     {"detected", detected},
                     {"recall", vis ? Json(double(matched) / vis) : Json()},
                     {"median_lead_s", num(median_of(leads))},
                     {"control_frames", ctl_frames},
                     {"control_false_warning_frames", ctl_warned},
                     {"cpu_s", system_cpu},
                     {"runs_wall_s", runs_wall},
                     {"system_s", system_s},
                     {"overhead_share", runs_wall > 0 ? Json(1.0 - system_s / runs_wall) : Json()}};
    report["systems"].push_back(sys);
    std::cerr << "test: " << systems[i].name << ": " << passed << " passed, " << failed << " failed, "
              << errors << " errors of " << scenarios.size() << " scenarios; control: " << ctl_warned
              << " of " << ctl_frames << " frames warned\n";
  }
  write_reports(out, report);
  std::cerr << "test: report in " << (out / "report.html").string() << ", " << (out / "junit.xml").string()
            << "\n";
  if (interrupted) return 130;
  for (const Json& s : report["systems"])
    if (s["pooled"]["errors"].get<int>() > 0) return 3;
  return 0;
}

}  // namespace hf::apps
