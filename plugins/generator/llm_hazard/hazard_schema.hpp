// The hazard spec JSON Schema: loading it, deriving the schema a model must answer with, and validating
// replies with valijson into messages that name the field (JSON pointer), its value and what is allowed.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <hazardforge/stage.hpp>

namespace hf::llm_hazard {

// Reads share/schemas/hazard_spec.schema.json (or another file). Throws hf::Error naming the file.
Json load_schema_file(const std::string& path);
// A JSON file; `what` names it in the messages ("PATH: cannot open <what>", "PATH: not valid JSON: ...").
Json load_json_file(const std::string& path, const std::string& what);

// The spec schema with the kinds' own `extra` fields (HazardKindInfo::extra_fields) added, each described as
// "<kind>: <doc>.", and no other extra field allowed. Throws hf::Error when two kinds declare a field with
// different schemas.
Json with_kind_fields(const Json& spec_schema, const std::vector<HazardKindInfo>& kinds);

// The schema a model answers with: schema_version and provenance dropped (the generator writes them),
// every property of every object required (fields that do not apply are null, as OpenAI strict mode
// wants) and "kind" restricted to `kinds`.
Json reply_schema(const Json& spec_schema, const std::vector<std::string>& kinds);

// A compiled draft-07 schema. Messages look like
//   /speed_mps = 5.5 is outside the allowed range [0, 3]
//   /kind = "flying_car" is not one of "cut_in", "sudden_stop"
//   /extra/crossing_from is missing (required)
class SchemaValidator {
 public:
  explicit SchemaValidator(Json schema);
  ~SchemaValidator();
  SchemaValidator(SchemaValidator&&) noexcept;
  SchemaValidator& operator=(SchemaValidator&&) noexcept;

  std::vector<std::string> validate(const Json& document) const;
  const Json& schema() const { return schema_; }

 private:
  struct Compiled;
  Json schema_;
  std::unique_ptr<Compiled> compiled_;
};

// A reply that passed the reply schema as a HazardSpec: null start_time_s -> `default_start_time_s`,
// null deceleration -> none, null entries of extra dropped.
HazardSpec spec_from_reply(const Json& reply, double default_start_time_s);

// Compact text of a JSON value for messages (long strings shortened).
std::string show_value(const Json& v);

}  // namespace hf::llm_hazard
