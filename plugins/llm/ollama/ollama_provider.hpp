// LLM provider "ollama": a local Ollama server's /api/chat with the reply schema as structured output.
#pragma once

#include <string>

#include <hazardforge/stage.hpp>

#include "hazardforge/llm/http.hpp"

namespace hf::llm {

// OllamaProvider (llm_provider "ollama"). POSTs {model, messages, format: <schema>, stream: false,
// options: {temperature, seed, num_predict}} to <host>/api/chat and returns message.content.
// Params: host (empty = $OLLAMA_HOST, else http://127.0.0.1:11434), model (llama3), connect_timeout_s,
// read_timeout_s, keep_alive. Credentials in the host URL (user:password@, sent as Basic authorization) are
// scrubbed from everything the provider returns or throws (a server may echo them).
class OllamaProvider : public LlmProvider {
 public:
  static ComponentInfo describe();
  void open(const Params& params) override;
  LlmReply complete(const LlmRequest& request) override;
  std::string describe_backend() const override;

  const std::string& endpoint() const { return endpoint_; }

 private:
  std::string base_url_;
  std::string endpoint_;
  std::string model_;
  std::string keep_alive_;
  HttpTimeouts timeouts_;
  size_t max_reply_bytes_ = 1000000;
  Secrets secrets_;  // user:password in the host URL and their Basic form, scrubbed from all it returns
};

}  // namespace hf::llm
