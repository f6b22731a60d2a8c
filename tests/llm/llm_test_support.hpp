// Shared fixtures for the LLM tests: a synthetic safe scene, a scripted loopback model server and a stage
// runner with every provider and the built-in hazard templates registered.
#pragma once

#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <hazardforge/registry.hpp>
#include <hazardforge/testing/stage_runner.hpp>

#include "refusal_support.hpp"

#include "cut_in_template.hpp"
#include "llm_hazard_stage.hpp"
#include "offline_planner.hpp"
#include "ollama_provider.hpp"
#include "openai_provider.hpp"
#include "pedestrian_crossing_template.hpp"
#include "sudden_stop_template.hpp"

namespace hf::test {

// The scene description the generator tests state.
inline constexpr const char* kDescription = "Busy city street, peds on the sidewalk, two lanes each way";

// The error a run ends with, or "(no error)".
inline std::string run_error(testing::StageRunner& r) {
  try {
    r.run();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// nuScenes-like front camera: 1600x900, f = 1266 px, 1.5 m high, 1.5 m ahead of the rear axle, level.
inline CameraModel test_camera() {
  return CameraModel::pinhole(1600, 900, 1266, 1266, 800, 450, 1.5, 0.0, 1.5);
}

inline Frame make_frame(int64_t index, double t, const std::string& description) {
  Frame f;
  f.index = index;
  f.timestamp = t;
  f.camera = test_camera();
  f.ego.speed_mps = 10.0;
  f.origin.description = description;
  return f;
}

// A parked car in the right lane 40 m ahead; the ego drives at 10 m/s.
inline ObjectStates make_states(int64_t index, double t) {
  ObjectStates s;
  s.frame_index = index;
  s.timestamp = t;
  s.ego_speed_mps = 10.0;
  ObjectState car;
  car.track_id = 7;
  car.label = "car";
  car.distance_m = 40.0;
  car.lateral_m = -3.5;
  car.width_m = 1.85;
  car.length_m = 4.5;
  car.speed_mps = 0.0;
  car.velocity_rel = cv::Vec2d(-10.0, 0.0);
  s.objects.push_back(car);
  return s;
}

inline RiskAssessment make_risk(int64_t index, bool safe) {
  RiskAssessment r;
  r.frame_index = index;
  r.metric = "ttc";
  r.stage = "ttc_paper";
  r.unit = "s";
  r.threshold = 1.5;
  r.scene_value = safe ? kInf : 0.9;
  r.label = safe ? SafetyLabel::kSafe : SafetyLabel::kUnsafe;
  r.objects.push_back({7, safe ? kInf : 0.9, !safe});
  return r;
}

// Pushes `n` frames at 2 Hz; frames listed in `unsafe` are labelled Unsafe.
inline void push_scene(testing::StageRunner& r, int n, const std::string& description,
                       const std::vector<int>& unsafe = {}) {
  for (int i = 0; i < n; ++i) {
    const double t = 0.5 * i;
    const bool safe = std::find(unsafe.begin(), unsafe.end(), i) == unsafe.end();
    r.push("frames", make_frame(i, t, description), t);
    r.push("states", make_states(i, t), t);
    r.push("risk", make_risk(i, safe), t, "ttc");
  }
}

// Every provider and the three built-in templates, as a host with all plugins loaded would have them.
// Components are registered before build(): the runner keeps a pointer into its registry.
inline testing::StageRunner make_runner(const std::string& yaml, bool with_templates = true,
                                        void (*more)(Registrar&) = nullptr) {
  testing::StageRunner r;
  r.registrar().add<llm_hazard::LlmHazardGenerator>();
  r.registrar().add<llm::OllamaProvider>();
  r.registrar().add<llm::OpenAiProvider>();
  r.registrar().add<llm::OfflinePlanner>();
  if (with_templates) {
    r.registrar().add<PedestrianCrossingTemplate>();
    r.registrar().add<CutInTemplate>();
    r.registrar().add<SuddenStopTemplate>();
  }
  if (more) more(r.registrar());
  r.build(kind::kGenerator, "llm_hazard", yaml);
  return r;
}

// A pedestrian crossing from the right kerb that the template accepts in the scene above: the ego (10 m/s)
// reaches x = 48.6 m in 4.5 s, the person needs about 2.5 s to walk from the kerb into the path.
inline Json valid_reply() {
  return {{"kind", "pedestrian_crossing"},
          {"object_class", "person"},
          {"initial_distance_m", 48.6},
          {"lateral_offset_m", -5.75},
          {"side", "right"},
          {"speed_mps", 2.0},
          {"heading_deg", 90},
          {"motion", "steps off the right kerb and crosses to the left"},
          {"start_time_s", nullptr},
          {"deceleration_mps2", nullptr},
          {"target_ttc_s", 1.0},
          {"track_id", nullptr},
          {"under_way_s", nullptr},
          {"extra", {{"crossing_from", "right"}, {"final_speed_mps", nullptr}, {"brake_delay_s", nullptr}}},
          {"rationale", "sidewalks on both sides; a jogger crosses"}};
}

// What the generator hands the offline provider for one scene: the built-in templates configured as the
// generator configures them, its reply checker and the catalog of the allowed kinds.
class OfflineScene {
 public:
  OfflineScene(llm_hazard::SceneSettings s, const Frame& frame, const ObjectStates& states,
               const RiskAssessment& risk, void (*more)(Registrar&) = nullptr)
      : settings_(std::move(s)),
        limits_(LimitsTable::load(LimitsTable::default_path())),
        sizes_(ClassPriors::load(share_dir() + "/class_sizes.yaml")) {
    registry_.add<PedestrianCrossingTemplate>();
    registry_.add<CutInTemplate>();
    registry_.add<SuddenStopTemplate>();
    if (more) more(registry_);
    // The fixture's road is the scene's as stated (a config's scene block), so the templates get its lanes.
    hazard::RoadModel stated = settings_.road;
    stated.lanes_left_stated = stated.lanes_right_stated = stated.oncoming_stated = true;
    const Json params =
        llm_hazard::template_params(stated, settings_.ttc, settings_.horizon_s, settings_.max_under_way_s,
                                    limits_.file(), share_dir() + "/class_sizes.yaml");
    std::vector<HazardKindInfo> all;
    for (const std::string& k : registry_.component_names(kind::kHazardTemplate)) {
      templates_[k] = registry_.create<HazardTemplate>(kind::kHazardTemplate, k, params);
      all.push_back(templates_[k]->kind_info());
    }
    for (const std::string& k : settings_.allowed_kinds)
      settings_.kinds.push_back(templates_.at(k)->kind_info());
    summary_ = llm_hazard::summarize_scene(frame, states, {&risk}, settings_, limits_, sizes_);
    reply_.emplace(llm_hazard::reply_schema(
        llm_hazard::with_kind_fields(
            llm_hazard::load_schema_file(share_dir() + "/schemas/hazard_spec.schema.json"), all),
        settings_.allowed_kinds));
    checker_.emplace(
        *reply_, templates_, summary_.context,
        llm_hazard::feasibility_config(settings_, limits_, sizes_, frame.timestamp, std::nullopt));
    base_.emplace(llm_hazard::proposal_request(settings_, summary_.context));
    catalog_.emplace(*checker_, settings_.allowed_kinds, *base_, settings_.rules.recording_classes);
  }
  OfflineScene(const OfflineScene&) = delete;

  LlmRequest request(int64_t seed) const {
    LlmRequest r;
    r.messages = {{"user", "prompt"}};
    r.scene = summary_.scene;
    r.seed = seed;
    r.hazards = &*catalog_;
    return r;
  }
  const Json& scene() const { return summary_.scene; }
  Json& scene() { return summary_.scene; }
  const llm_hazard::ReplyChecker& checker() const { return *checker_; }
  const llm_hazard::TemplateCatalog& catalog() const { return *catalog_; }

 private:
  llm_hazard::SceneSettings settings_;
  LimitsTable limits_;
  ClassPriors sizes_;
  ComponentRegistry registry_;
  std::map<std::string, std::unique_ptr<HazardTemplate>> templates_;
  llm_hazard::SceneSummary summary_;
  std::optional<llm_hazard::SchemaValidator> reply_;
  std::optional<llm_hazard::ReplyChecker> checker_;
  std::optional<ProposalRequest> base_;
  std::optional<llm_hazard::TemplateCatalog> catalog_;
};

// A model server on 127.0.0.1 (any free port) that records each request body and answers from a script.
class ScriptedServer {
 public:
  using Handler = std::function<void(const httplib::Request&, httplib::Response&)>;

  explicit ScriptedServer(const std::string& path) {
    server_.Post(path, [this](const httplib::Request& req, httplib::Response& res) {
      Handler h;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        requests_.push_back(Json::parse(req.body));
        headers_.push_back(req.get_header_value("Authorization"));
        if (script_.empty()) {
          res.status = 599;
          res.set_content("{\"error\":\"script exhausted\"}", "application/json");
          return;
        }
        h = script_.front();
        script_.pop_front();
      }
      h(req, res);
    });
    port_ = server_.bind_to_any_port("127.0.0.1");
    thread_ = std::thread([this] { server_.listen_after_bind(); });
    // The socket already listens after bind; wait (bounded) for the accept loop so stop() finds it running.
    for (int i = 0; i < 2000 && !server_.is_running(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ~ScriptedServer() {
    server_.stop();
    thread_.join();
  }

  void then(Handler h) {
    std::lock_guard<std::mutex> lock(mutex_);
    script_.push_back(std::move(h));
  }
  // Ollama's /api/chat answer carrying `content`.
  void then_ollama(const std::string& content, const std::string& model = "llama3:8b") {
    then([content, model](const httplib::Request&, httplib::Response& res) {
      Json body = {{"model", model},
                   {"created_at", "2024-05-01T00:00:00Z"},
                   {"message", {{"role", "assistant"}, {"content", content}}},
                   {"done", true}};
      res.set_content(body.dump(), "application/json");
    });
  }
  // OpenAI's /chat/completions answer carrying `content`.
  void then_openai(const std::string& content, const std::string& model = "llama-3-8b-instruct") {
    then([content, model](const httplib::Request&, httplib::Response& res) {
      Json body = {{"id", "chatcmpl-1"},
                   {"object", "chat.completion"},
                   {"model", model},
                   {"choices",
                    {{{"index", 0},
                      {"message", {{"role", "assistant"}, {"content", content}}},
                      {"finish_reason", "stop"}}}}};
      res.set_content(body.dump(), "application/json");
    });
  }

  int port() const { return port_; }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_); }
  std::vector<Json> requests() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return requests_;
  }
  std::vector<std::string> auth_headers() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return headers_;
  }

 private:
  httplib::Server server_;
  std::thread thread_;
  int port_ = 0;
  mutable std::mutex mutex_;
  std::deque<Handler> script_;
  std::vector<Json> requests_;
  std::vector<std::string> headers_;
};

// A loopback port with nothing listening: bound, read, released.
inline int unused_port() {
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return ntohs(addr.sin_port);
}

inline std::vector<Json> read_jsonl(const std::filesystem::path& p) {
  std::vector<Json> out;
  std::ifstream in(p);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(Json::parse(line));
  return out;
}

inline Json read_json(const std::filesystem::path& p) {
  std::ifstream in(p);
  return Json::parse(in);
}

}  // namespace hf::test
