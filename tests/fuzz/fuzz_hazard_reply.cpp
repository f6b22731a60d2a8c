// Fuzzes what a model's reply goes through: JSON extraction, the reply schema, and the spec conversion.
#include <cstdint>
#include <string>

#include "hazard_schema.hpp"
#include "hazardforge/json_text.hpp"
#include "hazardforge/llm/json.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const hf::llm_hazard::SchemaValidator* validator = [] {
    const hf::Json file = hf::llm_hazard::load_schema_file(std::string(HF_SOURCE_DIR) +
                                                           "/share/schemas/hazard_spec.schema.json");
    return new hf::llm_hazard::SchemaValidator(
        hf::llm_hazard::reply_schema(file, {"pedestrian_crossing", "cut_in", "sudden_stop"}));
  }();
  const std::string reply(reinterpret_cast<const char*>(data), size);
  try {
    const hf::Json doc = hf::llm::extract_json_object(reply);
    const std::vector<std::string> errors = validator->validate(doc);
    for (const std::string& e : errors) (void)hf::json_text(hf::Json(e));
    if (errors.empty()) {
      const hf::HazardSpec spec = hf::llm_hazard::spec_from_reply(doc, 1.0);
      (void)hf::json_text(hf::Json(spec));
    }
  } catch (const hf::Error&) {
  }
  return 0;
}
