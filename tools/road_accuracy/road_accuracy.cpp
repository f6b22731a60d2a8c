// How well a run read the road: its road record (the generator's road.jsonl) against facts labelled by eye per
// stretch of frames (tests/data/road_labels/*.yaml). One row per fact: frames labelled, frames read right, and
// what the reading rested on (stated, measured from the footage, the scene's words, a default).
//
//   hf_road_accuracy --labels tests/data/road_labels/shared_recordings.yaml --recording udacity-highway
//       runs/udacity/road.jsonl [--json]
#include <CLI/CLI.hpp>
#include <hazardforge/error.hpp>
#include <hazardforge/json_text.hpp>
#include <hazardforge/types.hpp>
#include <hazardforge/yaml_json.hpp>

#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace {

using hf::Json;

struct Record {
  int64_t frame;
  hf::RoadLayout road;
};

std::vector<Record> read_road(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw hf::Error(file + ": cannot open the road record");
  std::vector<Record> out;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    try {
      const Json j = Json::parse(line);
      out.push_back({j.at("frame").get<int64_t>(), j.at("road").get<hf::RoadLayout>()});
    } catch (const std::exception& e) {
      throw hf::Error(file + ":" + std::to_string(n) + ": not a road record: " + e.what());
    }
  }
  if (out.empty()) throw hf::Error(file + ": no road record (was the generator's road_file off?)");
  return out;
}

// One fact's tally.
struct Tally {
  int labelled = 0, right = 0;
  std::map<std::string, int> from;  // what the compared readings rested on
};

// A labelled value, or nullopt for "unknown" (not compared).
std::optional<Json> known(const Json& stretch, const std::string& key) {
  if (!stretch.contains(key)) return std::nullopt;
  const Json& v = stretch.at(key);
  if (v.is_null() || (v.is_string() && v.get<std::string>() == "unknown")) return std::nullopt;
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Scene reading against road labels: accuracy per fact"};
  std::string labels_file, recording, road_file;
  bool as_json = false;
  app.add_option("--labels", labels_file, "road labels (YAML: recordings: NAME: stretches: [...])")->required();
  app.add_option("--recording", recording, "the recording's name in the labels")->required();
  app.add_option("road", road_file, "the run's road.jsonl")->required();
  app.add_flag("--json", as_json, "print JSON instead of a Markdown table");
  CLI11_PARSE(app, argc, argv);
  try {
    const hf::YamlDocument labels = hf::load_yaml_file(labels_file);
    const Json& recs = labels.value.at("recordings");
    if (!recs.contains(recording))
      throw hf::Error(labels_file + ": no recording '" + recording + "' among the labelled ones");
    const std::vector<Record> road = read_road(road_file);

    const std::vector<std::string> facts = {"driving_side", "lanes_same_left", "lanes_same_right",
                                            "lanes_oncoming", "sidewalks", "intersection", "road_type"};
    std::map<std::string, Tally> tally;
    int frames = 0, unread = 0;
    for (const Json& st : recs.at(recording).at("stretches")) {
      const auto range = st.at("frames");
      for (int64_t f = range.at(0).get<int64_t>(); f <= range.at(1).get<int64_t>(); ++f) {
        // The road in force at frame f: the last record at or before it.
        const Record* at = nullptr;
        for (const Record& r : road)
          if (r.frame <= f) at = &r;
        if (!at) {
          ++unread;
          continue;
        }
        ++frames;
        const hf::RoadLayout& r = at->road;
        auto compare = [&](const std::string& fact, const Json& truth, const Json& read, const std::string& source) {
          Tally& t = tally[fact];
          ++t.labelled;
          if (truth == read) ++t.right;
          ++t.from[r.source(source).from];
        };
        if (auto v = known(st, "driving_side")) compare("driving_side", *v, r.driving_side, "driving_side");
        if (auto v = known(st, "lanes_same_left")) compare("lanes_same_left", *v, r.same_direction_lanes(1), "lanes_left");
        if (auto v = known(st, "lanes_same_right"))
          compare("lanes_same_right", *v, r.same_direction_lanes(-1), "lanes_right");
        if (auto v = known(st, "lanes_oncoming")) compare("lanes_oncoming", *v, r.oncoming_lanes, "oncoming_lanes");
        // A pavement on either side (the layout has one fact for both); unknown when neither is known true and
        // one is unknown.
        const auto l = known(st, "sidewalk_left"), rr = known(st, "sidewalk_right");
        if ((l && *l == true) || (rr && *rr == true))
          compare("sidewalks", true, r.sidewalks, "sidewalks");
        else if (l && rr)
          compare("sidewalks", false, r.sidewalks, "sidewalks");
        if (auto v = known(st, "intersection")) compare("intersection", *v, r.intersection, "intersection");
        if (auto v = known(st, "road_type")) compare("road_type", *v, r.road_type, "road_type");
      }
    }
    Json out = {{"recording", recording}, {"road_file", road_file}, {"frames_compared", frames},
                {"frames_before_the_first_record", unread}, {"facts", Json::object()}};
    for (const std::string& fact : facts) {
      const Tally& t = tally[fact];
      out["facts"][fact] = {{"labelled_frames", t.labelled}, {"right", t.right}, {"from", t.from}};
    }
    if (as_json) {
      std::cout << hf::json_text(out, 2) << "\n";
      return 0;
    }
    std::cout << "| fact | labelled frames | read right | accuracy | the reading rested on |\n"
              << "| --- | ---: | ---: | ---: | --- |\n";
    for (const std::string& fact : facts) {
      const Tally& t = tally[fact];
      std::string from;
      for (const auto& [k, n] : t.from) from += (from.empty() ? "" : ", ") + k + " " + std::to_string(n);
      std::cout << "| " << fact << " | " << t.labelled << " | " << t.right << " | "
                << (t.labelled ? std::to_string(static_cast<int>(100.0 * t.right / t.labelled + 0.5)) + " %" : "-")
                << " | " << from << " |\n";
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
