// OpenAI-compatible chat completions client with JSON-schema response format.
#include "openai_provider.hpp"

#include <chrono>
#include <cstdlib>

#include <hazardforge/error.hpp>
#include <hazardforge/redact.hpp>

namespace hf::llm {

ComponentInfo OpenAiProvider::describe() {
  ComponentInfo i;
  i.name = "openai";
  i.kind = kind::kLlmProvider;
  i.summary = "OpenAI-compatible /chat/completions (OpenAI, llama.cpp server, vLLM) with a JSON-schema reply";
  i.params = {
      ParamSpec::string("base_url", "http://127.0.0.1:8080/v1")
          .describe("API root; /chat/completions is appended"),
      ParamSpec::string("model", "llama3").describe("model name the server expects"),
      ParamSpec::string("api_key_env", "OPENAI_API_KEY")
          .describe("NAME of the environment variable holding the API key (unset = no key)"),
      ParamSpec::string("response_format", "json_schema")
          .one_of({"json_schema", "json_object"})
          .describe("json_schema (strict) or json_object for servers without schema support"),
      ParamSpec::string("schema_name", "hazard_spec").describe("json_schema.name sent with the schema"),
      ParamSpec::number("connect_timeout_s", 5.0).range(0.1, 600).describe("TCP connect timeout"),
      ParamSpec::number("read_timeout_s", 300.0).range(0.1, 7200).describe("limit for the whole reply"),
      ParamSpec::integer("max_reply_bytes", 1000000)
          .range(1000, 1000000000)
          .describe("largest response body accepted; a bigger one fails the call while it streams in"),
  };
  return i;
}

void OpenAiProvider::open(const Params& p) {
  base_url_ = normalize_base_url(p.get_string("base_url"));
  endpoint_ = base_url_ + "/chat/completions";
  model_ = p.get_string("model");
  api_key_env_ = p.get_string("api_key_env");
  response_format_ = p.get_string("response_format");
  schema_name_ = p.get_string("schema_name");
  timeouts_ = {p.get_double("connect_timeout_s"), p.get_double("read_timeout_s")};
  max_reply_bytes_ = static_cast<size_t>(p.get_int("max_reply_bytes"));
  url_secrets_ = Secrets();
  url_secrets_.add_url_credentials(base_url_);
}

std::string OpenAiProvider::describe_backend() const {
  return "openai " + model_ + " @ " + redact_urls(base_url_);
}

LlmReply OpenAiProvider::complete(const LlmRequest& r) {
  Json messages = Json::array();
  for (const LlmMessage& m : r.messages) messages.push_back({{"role", m.role}, {"content", m.content}});
  Json body = {{"model", model_}, {"messages", messages},       {"temperature", r.temperature},
               {"seed", r.seed},  {"max_tokens", r.max_tokens}, {"stream", false}};
  if (response_format_ == "json_schema" && !r.response_schema.is_null() && !r.response_schema.empty())
    body["response_format"] = {
        {"type", "json_schema"},
        {"json_schema", {{"name", schema_name_}, {"schema", r.response_schema}, {"strict", true}}}};
  else
    body["response_format"] = {{"type", "json_object"}};

  std::vector<std::string> headers;
  Secrets secrets = url_secrets_;
  if (const char* key = std::getenv(api_key_env_.c_str()); key && *key) {
    headers.push_back(std::string("Authorization: Bearer ") + key);
    secrets.add(key);
  }

  auto t0 = std::chrono::steady_clock::now();
  HttpResponse res = post_json("openai", endpoint_, body, headers, timeouts_, {max_reply_bytes_}, secrets);
  LlmReply reply;
  reply.latency_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (res.status != 200) throw Error(http_status_error("openai", endpoint_, res.status, res.body));
  // The body is scrubbed as text; its strings once more after parsing, for a secret written with escapes.
  reply.raw = secrets.scrub(parse_response("openai", endpoint_, res.body));
  const Json& j = reply.raw;
  const Json::json_pointer content_ptr("/choices/0/message/content");
  if (!j.is_object() || !j.contains(content_ptr) || !j.at(content_ptr).is_string()) {
    // A refusal comes back as message.refusal with a null content.
    const Json::json_pointer refusal("/choices/0/message/refusal");
    if (j.is_object() && j.contains(refusal) && j.at(refusal).is_string())
      throw Error("openai: POST " + redact_urls(endpoint_) +
                  ": the model refused: " + j.at(refusal).get<std::string>());
    throw Error("openai: POST " + redact_urls(endpoint_) + ": response has no choices[0].message.content");
  }
  reply.content = j.at(content_ptr).get<std::string>();
  reply.model = j.contains("model") && j["model"].is_string() ? j["model"].get<std::string>() : model_;
  return reply;
}

}  // namespace hf::llm
