// valijson-backed validation of hazard specs with field-precise messages.
#include "hazard_schema.hpp"

#include <fstream>
#include <map>
#include <sstream>

#include <hazardforge/error.hpp>
#include <hazardforge/json_text.hpp>
#include <valijson/adapters/nlohmann_json_adapter.hpp>
#include <valijson/schema.hpp>
#include <valijson/schema_parser.hpp>
#include <valijson/validator.hpp>

namespace hf::llm_hazard {

namespace {

void require_all(Json& node) {
  if (!node.is_object()) return;
  if (node.contains("properties") && node["properties"].is_object()) {
    Json required = Json::array();
    for (auto it = node["properties"].begin(); it != node["properties"].end(); ++it) {
      required.push_back(it.key());
      require_all(it.value());
    }
    node["required"] = std::move(required);
    node["additionalProperties"] = false;
  }
  if (node.contains("items")) require_all(node["items"]);
}

std::string escape_pointer_token(const std::string& t) {
  std::string out;
  for (char c : t) {
    if (c == '~')
      out += "~0";
    else if (c == '/')
      out += "~1";
    else
      out += c;
  }
  return out;
}

// valijson's context is {"<root>", "[name]", "[3]", ...}; strip the brackets.
std::vector<std::string> context_tokens(const std::vector<std::string>& context) {
  std::vector<std::string> tokens;
  for (const std::string& c : context) {
    if (c == "<root>") continue;
    if (c.size() >= 2 && c.front() == '[' && c.back() == ']')
      tokens.push_back(c.substr(1, c.size() - 2));
    else
      tokens.push_back(c);
  }
  return tokens;
}

std::string pointer_of(const std::vector<std::string>& tokens) {
  std::string p;
  for (const std::string& t : tokens) p += "/" + escape_pointer_token(t);
  return p;
}

const Json* schema_at(const Json& schema, const std::vector<std::string>& tokens) {
  const Json* node = &schema;
  for (const std::string& t : tokens) {
    if (!node->is_object()) return nullptr;
    if (node->contains("properties") && (*node)["properties"].contains(t))
      node = &(*node)["properties"][t];
    else if (node->contains("items"))
      node = &(*node)["items"];
    else
      return nullptr;
  }
  return node;
}

const Json* value_at(const Json& doc, const std::vector<std::string>& tokens) {
  const Json* node = &doc;
  for (const std::string& t : tokens) {
    if (node->is_object() && node->contains(t))
      node = &(*node)[t];
    else if (node->is_array()) {
      size_t i = std::stoul(t);
      if (i >= node->size()) return nullptr;
      node = &(*node)[i];
    } else {
      return nullptr;
    }
  }
  return node;
}

std::string json_type(const Json& v) {
  if (v.is_null()) return "null";
  if (v.is_boolean()) return "boolean";
  if (v.is_number_integer() || v.is_number_unsigned()) return "integer";
  if (v.is_number()) return "number";
  if (v.is_string()) return "string";
  if (v.is_array()) return "array";
  return "object";
}

std::string join_values(const Json& list, const std::string& sep = ", ") {
  std::string out;
  for (const Json& v : list) out += (out.empty() ? "" : sep) + (v.is_string() ? json_text(v) : show_value(v));
  return out;
}

// The property name valijson quotes at the end of its message: "...: 'name'." or "... 'name'.".
std::string last_quoted(const std::string& text) {
  size_t e = text.rfind('\'');
  if (e == std::string::npos || e == 0) return {};
  size_t b = text.rfind('\'', e - 1);
  return b == std::string::npos ? std::string() : text.substr(b + 1, e - b - 1);
}

bool starts_with(const std::string& s, const char* prefix) {
  return s.rfind(prefix, 0) == 0;
}

}  // namespace

std::string show_value(const Json& v) {
  constexpr size_t kMax = 60;
  std::string s = json_text(v);
  if (s.size() > kMax) s = s.substr(0, kMax) + "...";
  return s;
}

Json load_schema_file(const std::string& path) {
  return load_json_file(path, "the hazard spec schema");
}

Json load_json_file(const std::string& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open " + what);
  std::stringstream ss;
  ss << in.rdbuf();
  try {
    return Json::parse(ss.str());
  } catch (const Json::parse_error& e) {
    throw Error(path + ": not valid JSON: " + e.what());
  }
}

Json with_kind_fields(const Json& spec_schema, const std::vector<HazardKindInfo>& kinds) {
  Json s = spec_schema;
  if (!s.contains("properties") || !s["properties"].contains("extra") || !s["properties"]["extra"].is_object())
    throw Error("hazard spec schema has no properties.extra");
  Json& extra = s["properties"]["extra"];
  if (!extra.contains("properties")) extra["properties"] = Json::object();
  Json& props = extra["properties"];
  std::map<std::string, std::string> declared_by;
  for (const HazardKindInfo& k : kinds)
    for (const HazardField& f : k.extra_fields) {
      Json field = f.schema;
      const std::string text = k.kind + ": " + f.doc + ".";
      if (!props.contains(f.name)) {
        field["description"] = text;
        props[f.name] = std::move(field);
        declared_by[f.name] = k.kind;
        continue;
      }
      Json existing = props[f.name];
      const std::string before = existing.value("description", "");
      existing.erase("description");
      if (existing != field)
        throw Error("hazard kinds '" + (declared_by.count(f.name) ? declared_by[f.name] : std::string("(schema file)")) +
                    "' and '" + k.kind + "' declare extra." + f.name + " differently: " + existing.dump() + " vs " +
                    field.dump());
      props[f.name]["description"] = before + (before.empty() ? "" : " ") + text;
    }
  extra["additionalProperties"] = false;
  return s;
}

Json reply_schema(const Json& spec_schema, const std::vector<std::string>& kinds) {
  Json s = spec_schema;
  if (!s.contains("properties") || !s["properties"].contains("kind"))
    throw Error("hazard spec schema has no properties.kind");
  s["properties"].erase("schema_version");
  s["properties"].erase("provenance");
  s["properties"].erase("road");
  s["properties"]["kind"]["enum"] = kinds;
  require_all(s);
  // Backends take the schema as-is; drop the keywords that only matter for the file on disk.
  s.erase("$id");
  return s;
}

HazardSpec spec_from_reply(const Json& reply, double default_start_time_s) {
  HazardSpec spec;
  spec.kind = reply.at("kind").get<std::string>();
  spec.object_class = reply.at("object_class").get<std::string>();
  spec.initial_distance_m = reply.at("initial_distance_m").get<double>();
  spec.lateral_offset_m = reply.at("lateral_offset_m").get<double>();
  spec.side = reply.at("side").get<std::string>();
  spec.speed_mps = reply.at("speed_mps").get<double>();
  spec.heading_deg = reply.at("heading_deg").get<double>();
  spec.motion = reply.at("motion").get<std::string>();
  const Json& start = reply.at("start_time_s");
  spec.start_time_s = start.is_null() ? default_start_time_s : start.get<double>();
  if (const Json& d = reply.at("deceleration_mps2"); !d.is_null()) spec.deceleration_mps2 = d.get<double>();
  spec.target_ttc_s = reply.at("target_ttc_s").get<double>();
  if (const Json& t = reply.at("track_id"); !t.is_null()) spec.track_id = t.get<int64_t>();
  if (const Json& u = reply.at("under_way_s"); !u.is_null()) spec.under_way_s = u.get<double>();
  spec.extra = Json::object();
  for (auto it = reply.at("extra").begin(); it != reply.at("extra").end(); ++it)
    if (!it.value().is_null()) spec.extra[it.key()] = it.value();
  spec.rationale = reply.at("rationale").get<std::string>();
  return spec;
}

struct SchemaValidator::Compiled {
  valijson::Schema schema;
};

SchemaValidator::SchemaValidator(Json schema)
    : schema_(std::move(schema)), compiled_(std::make_unique<Compiled>()) {
  valijson::SchemaParser parser(valijson::SchemaParser::kDraft7);
  valijson::adapters::NlohmannJsonAdapter adapter(schema_);
  try {
    parser.populateSchema(adapter, compiled_->schema);
  } catch (const std::exception& e) {
    throw Error(std::string("hazard spec schema is not a usable draft-07 schema: ") + e.what());
  }
}
SchemaValidator::~SchemaValidator() = default;
SchemaValidator::SchemaValidator(SchemaValidator&&) noexcept = default;
SchemaValidator& SchemaValidator::operator=(SchemaValidator&&) noexcept = default;

std::vector<std::string> SchemaValidator::validate(const Json& document) const {
  valijson::Validator validator;  // strict types: 1 is an integer and a number, "1" is neither
  valijson::ValidationResults results;
  valijson::adapters::NlohmannJsonAdapter adapter(document);
  if (validator.validate(compiled_->schema, adapter, &results)) return {};

  std::vector<std::string> messages;
  valijson::ValidationResults::Error err;
  while (results.popError(err)) {
    const std::string& d = err.description;
    // Parents repeat their children's failures; the child's own message is the useful one.
    if (starts_with(d, "Failed to validate against schema associated with property") ||
        starts_with(d, "Failed to validate item"))
      continue;
    std::vector<std::string> tokens = context_tokens(err.context);
    const Json* sch = schema_at(schema_, tokens);
    const Json* val = value_at(document, tokens);
    std::string where = tokens.empty() ? "/" : pointer_of(tokens);
    std::string shown = val ? where + " = " + show_value(*val) : where;

    std::string msg;
    if (starts_with(d, "Missing required property")) {
      std::string name = last_quoted(d);
      tokens.push_back(name);
      msg = pointer_of(tokens) + " is missing (required)";
    } else if (starts_with(d, "Object contains a property that could not be validated")) {
      std::string name = last_quoted(d);
      tokens.push_back(name);
      std::string allowed;
      if (sch && sch->contains("properties"))
        for (auto it = (*sch)["properties"].begin(); it != (*sch)["properties"].end(); ++it)
          allowed += (allowed.empty() ? "" : ", ") + it.key();
      msg = pointer_of(tokens) + " is not an allowed field (allowed: " + allowed + ")";
    } else if (d.find("less than") != std::string::npos || d.find("greater than") != std::string::npos) {
      std::string lo = sch && sch->contains("minimum") ? show_value((*sch)["minimum"]) : "-inf";
      std::string hi = sch && sch->contains("maximum") ? show_value((*sch)["maximum"]) : "inf";
      msg = shown + " is outside the allowed range [" + lo + ", " + hi + "]";
    } else if (starts_with(d, "Value type not permitted")) {
      std::string types;
      if (sch && sch->contains("type")) {
        const Json& t = (*sch)["type"];
        if (t.is_string())
          types = t.get<std::string>();
        else
          for (const Json& one : t) types += (types.empty() ? "" : " or ") + one.get<std::string>();
      }
      msg = shown + " has type " + (val ? json_type(*val) : "?") + ", expected " + types;
    } else if (starts_with(d, "Failed to match against any enum values")) {
      msg = shown + " is not one of " +
            (sch && sch->contains("enum") ? join_values((*sch)["enum"]) : "the allowed values");
    } else {
      msg = shown + ": " + d;
    }
    messages.push_back(std::move(msg));
  }
  return messages;
}

}  // namespace hf::llm_hazard
