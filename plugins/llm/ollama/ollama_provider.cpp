// Ollama /api/chat client (non-streaming, JSON-schema "format").
#include "ollama_provider.hpp"

#include <chrono>
#include <cstdlib>

#include <hazardforge/error.hpp>
#include <hazardforge/redact.hpp>

namespace hf::llm {

ComponentInfo OllamaProvider::describe() {
  ComponentInfo i;
  i.name = "ollama";
  i.kind = kind::kLlmProvider;
  i.summary = "Ollama server (/api/chat) with the reply JSON schema as 'format'";
  i.params = {
      ParamSpec::string("host", "").describe("server URL; empty = $OLLAMA_HOST, else http://127.0.0.1:11434"),
      ParamSpec::string("model", "llama3").describe("model tag as `ollama list` shows it"),
      ParamSpec::number("connect_timeout_s", 5.0).range(0.1, 600).describe("TCP connect timeout"),
      ParamSpec::number("read_timeout_s", 300.0).range(0.1, 7200).describe("limit for the whole reply"),
      ParamSpec::integer("max_reply_bytes", 1000000)
          .range(1000, 1000000000)
          .describe("largest response body accepted; a bigger one fails the call while it streams in"),
      ParamSpec::string("keep_alive", "")
          .describe("how long the server keeps the model loaded, e.g. '10m'; empty = server default"),
  };
  return i;
}

void OllamaProvider::open(const Params& p) {
  std::string host = p.get_string("host");
  if (host.empty())
    if (const char* env = std::getenv("OLLAMA_HOST"); env && *env) host = env;
  if (host.empty()) host = "http://127.0.0.1:11434";
  base_url_ = normalize_base_url(host);
  endpoint_ = base_url_ + "/api/chat";
  model_ = p.get_string("model");
  keep_alive_ = p.get_string("keep_alive");
  timeouts_ = {p.get_double("connect_timeout_s"), p.get_double("read_timeout_s")};
  max_reply_bytes_ = static_cast<size_t>(p.get_int("max_reply_bytes"));
  secrets_ = Secrets();
  secrets_.add_url_credentials(base_url_);
}

std::string OllamaProvider::describe_backend() const {
  return "ollama " + model_ + " @ " + redact_urls(base_url_);
}

LlmReply OllamaProvider::complete(const LlmRequest& r) {
  Json messages = Json::array();
  for (const LlmMessage& m : r.messages) messages.push_back({{"role", m.role}, {"content", m.content}});
  Json body = {
      {"model", model_},
      {"messages", messages},
      {"stream", false},
      {"options", {{"temperature", r.temperature}, {"seed", r.seed}, {"num_predict", r.max_tokens}}}};
  if (!r.response_schema.is_null() && !r.response_schema.empty()) body["format"] = r.response_schema;
  if (!keep_alive_.empty()) body["keep_alive"] = keep_alive_;

  auto t0 = std::chrono::steady_clock::now();
  HttpResponse res = post_json("ollama", endpoint_, body, {}, timeouts_, {max_reply_bytes_}, secrets_);
  LlmReply reply;
  reply.latency_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (res.status != 200) throw Error(http_status_error("ollama", endpoint_, res.status, res.body));
  // The body is scrubbed as text; its strings once more after parsing, for a secret written with escapes.
  reply.raw = secrets_.scrub(parse_response("ollama", endpoint_, res.body));
  const Json& j = reply.raw;
  if (!j.is_object() || !j.contains("message") || !j["message"].is_object() ||
      !j["message"].contains("content") || !j["message"]["content"].is_string())
    throw Error("ollama: POST " + redact_urls(endpoint_) + ": response has no message.content");
  if (j.contains("done") && j["done"].is_boolean() && !j["done"].get<bool>())
    throw Error("ollama: POST " + redact_urls(endpoint_) +
                ": response is not done (the server streamed although stream was false)");
  reply.content = j["message"]["content"].get<std::string>();
  reply.model = j.contains("model") && j["model"].is_string() ? j["model"].get<std::string>() : model_;
  return reply;
}

}  // namespace hf::llm
