// Parameter declarations (type, default, range, doc) and the validated values a stage reads when it opens.
#pragma once

#include "hazardforge/abi.hpp"

#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hazardforge/error.hpp"

HF_SDK_BEGIN
namespace hf {

using Json = nlohmann::json;

enum class ParamType { kBool, kInt, kDouble, kString, kPath, kIntList, kDoubleList, kStringList, kObject };

const char* param_type_name(ParamType t);

// One declared parameter. A parameter without a default is required.
struct ParamSpec {
  std::string name;
  ParamType type = ParamType::kString;
  Json default_value;  // null = required
  std::optional<double> min;
  std::optional<double> max;
  std::vector<std::string> choices;  // for strings: the allowed values (empty = any)
  std::string doc;
  // A scene fact this parameter stands for ("road.lanes_left", hazardforge/scene.hpp): when the config's
  // `scene:` block states it, the host fills the parameter from there, and giving it on the node too is an
  // error (a fact is stated once). Empty = not bound.
  std::string scene_key;

  bool required() const { return default_value.is_null(); }

  // Fluent builders: hf::ParamSpec::number("conf", 0.25).range(0, 1).describe("...").
  static ParamSpec boolean(std::string name, bool def);
  static ParamSpec integer(std::string name, std::optional<long long> def);
  static ParamSpec number(std::string name, std::optional<double> def);
  static ParamSpec string(std::string name, std::optional<std::string> def);
  // A file or folder. Relative values are resolved against the config file's folder.
  static ParamSpec path(std::string name, std::optional<std::string> def);
  static ParamSpec int_list(std::string name, std::vector<long long> def);
  static ParamSpec number_list(std::string name, std::vector<double> def);
  static ParamSpec string_list(std::string name, std::vector<std::string> def);
  // Free-form nested mapping (e.g. a provider's own parameters), validated by whoever consumes it.
  static ParamSpec object(std::string name, Json def = Json::object());

  ParamSpec& range(std::optional<double> lo, std::optional<double> hi);
  ParamSpec& one_of(std::vector<std::string> values);
  ParamSpec& describe(std::string text);
  ParamSpec& from_scene(std::string key);
};

// Where each given value came from, keyed by parameter name, so validation errors point at the YAML.
using ParamLocations = std::map<std::string, SourceLocation>;

// Validated parameter values: every declared parameter is present (given or default), types are normalised.
class Params {
 public:
  Params() = default;
  explicit Params(Json values, std::filesystem::path base_dir = {});

  bool has(const std::string& name) const;
  const Json& raw(const std::string& name) const;
  const Json& all() const { return values_; }

  bool get_bool(const std::string& name) const;
  long long get_int(const std::string& name) const;
  double get_double(const std::string& name) const;
  std::string get_string(const std::string& name) const;
  // ${VAR}s are expanded, then relative paths are resolved against the config file's folder; empty stays empty.
  std::filesystem::path get_path(const std::string& name) const;
  std::vector<double> get_doubles(const std::string& name) const;
  std::vector<long long> get_ints(const std::string& name) const;
  std::vector<std::string> get_strings(const std::string& name) const;
  const std::filesystem::path& base_dir() const { return base_dir_; }
  // Whether the value was stated (on the node, by the scene block or on the command line) rather than left at
  // its default: lets a stage tell "estimate it" from "the user said 0".
  bool stated(const std::string& name) const { return stated_.count(name) > 0; }
  void set_stated(std::set<std::string> names) { stated_ = std::move(names); }

 private:
  Json values_ = Json::object();
  std::filesystem::path base_dir_;
  std::set<std::string> stated_;
};

// Checks `given` against `specs`: unknown names (with the nearest suggestion), wrong types, out-of-range values,
// values not among the choices, missing required ones. Appends one diagnostic per problem; returns the
// normalised values (defaults filled in) when there were none. `what` names the owner, e.g. "stage 'yolo'".
Json validate_params(const std::vector<ParamSpec>& specs, const Json& given, const std::string& what,
                     const SourceLocation& owner_loc, const ParamLocations& locs,
                     std::vector<Diagnostic>& diags);

// Expands ${VAR} and ${VAR:-default} from `vars`, then the environment. HAZARDFORGE_SHARED and HAZARDFORGE_SHARE
// are always defined (see shared_root() / share_dir()). Throws hf::Error naming an undefined variable, and
// one not in `vars` whose name marks a secret: a word of it (split at every character that is not a letter)
// is KEY, TOKEN, SECRET, PASSWORD, PASS, PASSWD, AUTH, CRED, CREDENTIAL, PRIVATE, APIKEY or a plural of them
// ("OPENAI_API_KEY" is refused, "MONKEY_DIR" is not): its value would reach manifests and prompts.
std::string expand_vars(const std::string& text, const std::map<std::string, std::string>& vars = {});

// The shared data folder (data/, models/, schemas/): $HAZARDFORGE_SHARED, else the first folder named `shared`
// holding `data/` found beside the current directory or one of its parents, else beside the SDK library's
// ancestors. Empty if none.
std::string shared_root();

// Levenshtein-nearest candidate within a small distance, or "" if nothing is close.
std::string nearest_name(const std::string& name, const std::vector<std::string>& candidates);

}  // namespace hf
HF_SDK_END
