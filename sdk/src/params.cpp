// Parameter declarations, validation against YAML-given values, and typed access for stages.
#include "hazardforge/params.hpp"
#include "hazardforge/json_text.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <set>
#include <sstream>

#include "hazardforge/geometry.hpp"
#include "hazardforge/number_text.hpp"

namespace hf {

const char* param_type_name(ParamType t) {
  switch (t) {
    case ParamType::kBool:
      return "bool";
    case ParamType::kInt:
      return "int";
    case ParamType::kDouble:
      return "number";
    case ParamType::kString:
      return "string";
    case ParamType::kPath:
      return "path";
    case ParamType::kIntList:
      return "list of int";
    case ParamType::kDoubleList:
      return "list of number";
    case ParamType::kStringList:
      return "list of string";
    case ParamType::kObject:
      return "mapping";
  }
  return "?";
}

namespace {
ParamSpec make(std::string name, ParamType t, Json def) {
  ParamSpec s;
  s.name = std::move(name);
  s.type = t;
  s.default_value = std::move(def);
  return s;
}
}  // namespace

ParamSpec ParamSpec::boolean(std::string name, bool def) {
  return make(std::move(name), ParamType::kBool, def);
}
ParamSpec ParamSpec::integer(std::string name, std::optional<long long> def) {
  return make(std::move(name), ParamType::kInt, def ? Json(*def) : Json());
}
ParamSpec ParamSpec::number(std::string name, std::optional<double> def) {
  return make(std::move(name), ParamType::kDouble, def ? Json(*def) : Json());
}
ParamSpec ParamSpec::string(std::string name, std::optional<std::string> def) {
  return make(std::move(name), ParamType::kString, def ? Json(*def) : Json());
}
ParamSpec ParamSpec::path(std::string name, std::optional<std::string> def) {
  return make(std::move(name), ParamType::kPath, def ? Json(*def) : Json());
}
ParamSpec ParamSpec::int_list(std::string name, std::vector<long long> def) {
  return make(std::move(name), ParamType::kIntList, Json(def));
}
ParamSpec ParamSpec::number_list(std::string name, std::vector<double> def) {
  return make(std::move(name), ParamType::kDoubleList, Json(def));
}
ParamSpec ParamSpec::string_list(std::string name, std::vector<std::string> def) {
  return make(std::move(name), ParamType::kStringList, Json(def));
}
ParamSpec ParamSpec::object(std::string name, Json def) {
  return make(std::move(name), ParamType::kObject, def.is_null() ? Json::object() : std::move(def));
}
ParamSpec& ParamSpec::range(std::optional<double> lo, std::optional<double> hi) {
  min = lo;
  max = hi;
  return *this;
}
ParamSpec& ParamSpec::one_of(std::vector<std::string> values) {
  choices = std::move(values);
  return *this;
}
ParamSpec& ParamSpec::describe(std::string text) {
  doc = std::move(text);
  return *this;
}

ParamSpec& ParamSpec::from_scene(std::string key) {
  scene_key = std::move(key);
  return *this;
}

// ---- Params
// ----------------------------------------------------------------------------------------------------

Params::Params(Json values, std::filesystem::path base_dir)
    : values_(std::move(values)), base_dir_(std::move(base_dir)) {
  if (!values_.is_object()) values_ = Json::object();
}

bool Params::has(const std::string& name) const {
  return values_.contains(name) && !values_[name].is_null();
}

const Json& Params::raw(const std::string& name) const {
  auto it = values_.find(name);
  if (it == values_.end()) throw Error("parameter '" + name + "' is not declared");
  return *it;
}

namespace {
[[noreturn]] void type_error(const std::string& name, const char* want, const Json& v) {
  throw Error("parameter '" + name + "' should be " + want + ", got " + hf::json_text(v));
}
}  // namespace

bool Params::get_bool(const std::string& name) const {
  const Json& v = raw(name);
  if (!v.is_boolean()) type_error(name, "a bool", v);
  return v.get<bool>();
}
long long Params::get_int(const std::string& name) const {
  const Json& v = raw(name);
  if (!v.is_number_integer()) type_error(name, "an int", v);
  return v.get<long long>();
}
double Params::get_double(const std::string& name) const {
  const Json& v = raw(name);
  if (!v.is_number()) type_error(name, "a number", v);
  return v.get<double>();
}
std::string Params::get_string(const std::string& name) const {
  const Json& v = raw(name);
  if (v.is_null()) return {};
  if (!v.is_string()) type_error(name, "a string", v);
  return v.get<std::string>();
}
std::filesystem::path Params::get_path(const std::string& name) const {
  std::string s = expand_vars(get_string(name));
  if (s.empty()) return {};
  std::filesystem::path p(s);
  if (p.is_relative() && !base_dir_.empty()) p = base_dir_ / p;
  return p.lexically_normal();
}
std::vector<double> Params::get_doubles(const std::string& name) const {
  std::vector<double> out;
  for (const Json& v : raw(name)) out.push_back(v.get<double>());
  return out;
}
std::vector<long long> Params::get_ints(const std::string& name) const {
  std::vector<long long> out;
  for (const Json& v : raw(name)) out.push_back(v.get<long long>());
  return out;
}
std::vector<std::string> Params::get_strings(const std::string& name) const {
  std::vector<std::string> out;
  for (const Json& v : raw(name)) out.push_back(v.get<std::string>());
  return out;
}

// ---- validation
// --------------------------------------------------------------------------------------------------

std::string nearest_name(const std::string& name, const std::vector<std::string>& candidates) {
  auto lower = [](std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
  };
  const std::string a = lower(name);
  std::string best;
  size_t best_d = std::string::npos;
  for (const std::string& cand : candidates) {
    const std::string b = lower(cand);
    std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
      cur[0] = i;
      for (size_t j = 1; j <= b.size(); ++j)
        cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      std::swap(prev, cur);
    }
    size_t d = prev[b.size()];
    if (d < best_d) {
      best_d = d;
      best = cand;
    }
  }
  const size_t limit = std::max<size_t>(2, name.size() / 3);
  return best_d <= limit ? best : std::string();
}

namespace {

std::string range_text(const ParamSpec& s) {
  if (s.min && s.max) return "[" + general_text(*s.min) + ", " + general_text(*s.max) + "]";
  if (s.min) return ">= " + general_text(*s.min);
  if (s.max) return "<= " + general_text(*s.max);
  return "";
}

bool type_ok(ParamType t, const Json& v) {
  auto all_of = [&](auto pred) {
    if (!v.is_array()) return false;
    return std::all_of(v.begin(), v.end(), pred);
  };
  switch (t) {
    case ParamType::kBool:
      return v.is_boolean();
    case ParamType::kInt:
      return v.is_number_integer();
    case ParamType::kDouble:
      return v.is_number();
    case ParamType::kString:
    case ParamType::kPath:
      return v.is_string();
    case ParamType::kIntList:
      return all_of([](const Json& e) { return e.is_number_integer(); });
    case ParamType::kDoubleList:
      return all_of([](const Json& e) { return e.is_number(); });
    case ParamType::kStringList:
      return all_of([](const Json& e) { return e.is_string(); });
    case ParamType::kObject:
      return v.is_object();
  }
  return false;
}

}  // namespace

Json validate_params(const std::vector<ParamSpec>& specs, const Json& given, const std::string& what,
                     const SourceLocation& owner_loc, const ParamLocations& locs,
                     std::vector<Diagnostic>& diags) {
  const size_t before = diags.size();
  auto err = [&](const std::string& key, std::string msg) {
    auto it = locs.find(key);
    diags.push_back(
        {Diagnostic::Severity::kError, it != locs.end() ? it->second : owner_loc, std::move(msg)});
  };
  Json out = Json::object();
  if (!given.is_null() && !given.is_object()) {
    err("", what + ": params must be a mapping");
    return Json();
  }
  std::vector<std::string> names;
  for (const ParamSpec& s : specs) names.push_back(s.name);
  if (given.is_object()) {
    for (auto it = given.begin(); it != given.end(); ++it) {
      if (std::find(names.begin(), names.end(), it.key()) == names.end()) {
        std::string near = nearest_name(it.key(), names);
        err(it.key(), what + " has no parameter '" + it.key() + "'" +
                          (near.empty() ? std::string() : "; did you mean '" + near + "'?"));
      }
    }
  }
  for (const ParamSpec& s : specs) {
    const bool present = given.is_object() && given.contains(s.name) && !given[s.name].is_null();
    if (!present) {
      if (s.required()) {
        diags.push_back(
            {Diagnostic::Severity::kError, owner_loc,
             what + ": required parameter '" + s.name + "' (" + param_type_name(s.type) + ") is missing"});
      } else {
        out[s.name] = s.default_value;
      }
      continue;
    }
    Json v = given[s.name];
    // An integer given where a number is declared is fine; keep it a double so stages read one type.
    if (s.type == ParamType::kDouble && v.is_number()) v = v.get<double>();
    if (s.type == ParamType::kDoubleList && v.is_array()) {
      for (Json& e : v)
        if (e.is_number()) e = e.get<double>();
    }
    if (!type_ok(s.type, v)) {
      err(s.name, what + ": parameter '" + s.name + "' expects " + param_type_name(s.type) + ", got " +
                      hf::json_text(v));
      continue;
    }
    auto check_range = [&](double x) {
      if ((s.min && x < *s.min) || (s.max && x > *s.max)) {
        err(s.name,
            what + ": parameter '" + s.name + "' = " + general_text(x) + " is out of range " + range_text(s));
        return false;
      }
      return true;
    };
    if (v.is_number()) {
      if (!check_range(v.get<double>())) continue;
    } else if (v.is_array()) {
      bool ok = true;
      for (const Json& e : v)
        if (e.is_number() && !check_range(e.get<double>())) {
          ok = false;
          break;
        }
      if (!ok) continue;
    }
    if (!s.choices.empty()) {
      auto bad = [&](const std::string& x) {
        if (std::find(s.choices.begin(), s.choices.end(), x) != s.choices.end()) return false;
        std::string list;
        for (const auto& c : s.choices) list += (list.empty() ? "" : ", ") + c;
        std::string near = nearest_name(x, s.choices);
        err(s.name, what + ": parameter '" + s.name + "' = '" + x + "' is not one of: " + list +
                        (near.empty() ? std::string() : "; did you mean '" + near + "'?"));
        return true;
      };
      if (v.is_string() && bad(v.get<std::string>())) continue;
      if (v.is_array()) {
        bool any_bad = false;
        for (const Json& e : v)
          if (e.is_string() && bad(e.get<std::string>())) any_bad = true;
        if (any_bad) continue;
      }
    }
    out[s.name] = v;
  }
  return diags.size() == before ? out : Json();
}

}  // namespace hf

// ---- variables
// ---------------------------------------------------------------------------------------------------

namespace hf {

std::string shared_root() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("HAZARDFORGE_SHARED"); env && *env) return env;
  auto search_up = [](fs::path start) -> std::string {
    std::error_code ec;
    for (fs::path p = fs::absolute(start, ec); !p.empty(); p = p.parent_path()) {
      if (fs::is_directory(p / "shared" / "data", ec)) return (p / "shared").string();
      if (p == p.parent_path()) break;
    }
    return {};
  };
  if (std::string s = search_up(fs::current_path()); !s.empty()) return s;
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&shared_root), &info) && info.dli_fname)
    if (std::string s = search_up(fs::path(info.dli_fname).parent_path()); !s.empty()) return s;
  return {};
}

namespace {

// The word of a variable name that marks it as a secret, upper-cased; empty when there is none.
std::string secret_word(const std::string& name) {
  static const std::set<std::string> kSecretWords = {
      "KEY",  "KEYS",   "APIKEY",  "TOKEN", "TOKENS", "SECRET", "SECRETS",    "PASSWORD",
      "PASS", "PASSWD", "PRIVATE", "AUTH",  "CRED",   "CREDS",  "CREDENTIAL", "CREDENTIALS"};
  std::string word;
  for (size_t i = 0; i <= name.size(); ++i) {
    const char c = i < name.size() ? name[i] : '_';
    if (std::isalpha(static_cast<unsigned char>(c))) {
      word += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    } else {
      if (kSecretWords.count(word)) return word;
      word.clear();
    }
  }
  return {};
}

}  // namespace

std::string expand_vars(const std::string& text, const std::map<std::string, std::string>& vars) {
  std::string out;
  size_t i = 0;
  while (i < text.size()) {
    if (text[i] == '$' && i + 1 < text.size() && text[i + 1] == '{') {
      const size_t close = text.find('}', i + 2);
      if (close == std::string::npos) throw Error("unterminated ${ in '" + text + "'");
      std::string body = text.substr(i + 2, close - i - 2);
      std::string name = body, def;
      bool has_def = false;
      if (auto p = body.find(":-"); p != std::string::npos) {
        name = body.substr(0, p);
        def = body.substr(p + 2);
        has_def = true;
      }
      std::string value;
      bool found = false;
      if (auto it = vars.find(name); it != vars.end()) {
        value = it->second;
        found = true;
      } else if (const std::string word = secret_word(name); !word.empty()) {
        throw Error("${" + name + "} is not expanded: its name marks a secret ('" + word +
                    "'); a secret is read only by the component that needs it (the openai provider's "
                    "api_key_env), never written into a config, its manifest or a prompt");
      } else if (const char* env = std::getenv(name.c_str()); env && *env) {
        value = env;
        found = true;
      } else if (name == "HAZARDFORGE_SHARED") {
        value = shared_root();
        found = !value.empty();
      } else if (name == "HAZARDFORGE_SHARE") {
        value = share_dir();
        found = true;
      }
      if (!found) {
        if (!has_def)
          throw Error(
              "undefined variable ${" + name + "}" +
              (name == "HAZARDFORGE_SHARED" ? " (set it to the folder holding data/ and models/)" : ""));
        value = def;
      }
      out += value;
      i = close + 1;
    } else {
      out += text[i++];
    }
  }
  return out;
}

}  // namespace hf
