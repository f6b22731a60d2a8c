// LLM provider "openai": any OpenAI-compatible /chat/completions server (OpenAI, llama.cpp server, vLLM).
#pragma once

#include <string>

#include <hazardforge/stage.hpp>

#include "hazardforge/llm/http.hpp"

namespace hf::llm {

// OpenAiProvider (llm_provider "openai"). POSTs {model, messages, temperature, seed, max_tokens,
// response_format} to <base_url>/chat/completions and returns choices[0].message.content.
// response_format is {type: json_schema, json_schema: {name, schema, strict: true}}, or {type: json_object}
// with param response_format = json_object for servers without schema support. The API key is read from the
// environment variable named by api_key_env (never from the config); unset = no Authorization header, which
// local servers accept. The key and any user:password in base_url are scrubbed from everything the provider
// returns or throws (a server may echo them).
class OpenAiProvider : public LlmProvider {
 public:
  static ComponentInfo describe();
  void open(const Params& params) override;
  LlmReply complete(const LlmRequest& request) override;
  std::string describe_backend() const override;

 private:
  std::string base_url_;
  std::string endpoint_;
  std::string model_;
  std::string api_key_env_;
  std::string response_format_;
  std::string schema_name_;
  HttpTimeouts timeouts_;
  size_t max_reply_bytes_ = 1000000;
  Secrets url_secrets_;  // user:password in base_url; the key is added per call (read from the environment)
};

}  // namespace hf::llm
