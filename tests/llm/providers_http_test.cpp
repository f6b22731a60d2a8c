// ollama and openai providers against loopback servers speaking each wire format.
#include <gtest/gtest.h>

#include <cstdlib>

#include "llm_test_support.hpp"

namespace hf::llm {
namespace {

using test::ScriptedServer;

LlmRequest sample_request() {
  LlmRequest r;
  r.messages = {{"user", "Describe a hazard."}};
  r.response_schema = {{"type", "object"},
                       {"properties", {{"kind", {{"type", "string"}, {"enum", {"cut_in"}}}}}}};
  r.temperature = 0.3;
  r.seed = 1234;
  r.max_tokens = 512;
  return r;
}

std::unique_ptr<OllamaProvider> ollama(const std::string& host, double read_timeout = 5.0) {
  auto p = std::make_unique<OllamaProvider>();
  p->open(Params(Json{{"host", host},
                      {"model", "llama3"},
                      {"connect_timeout_s", 2.0},
                      {"read_timeout_s", read_timeout},
                      {"max_reply_bytes", 1000000},
                      {"keep_alive", ""}}));
  return p;
}

std::unique_ptr<OpenAiProvider> openai(const std::string& base, const std::string& format = "json_schema") {
  auto p = std::make_unique<OpenAiProvider>();
  p->open(Params(Json{{"base_url", base + "/v1"},
                      {"model", "llama-3-8b"},
                      {"api_key_env", "HF_TEST_LLM_KEY"},
                      {"response_format", format},
                      {"schema_name", "hazard_spec"},
                      {"connect_timeout_s", 2.0},
                      {"read_timeout_s", 5.0},
                      {"max_reply_bytes", 1000000}}));
  return p;
}

std::string error_of(LlmProvider& p, const LlmRequest& r) {
  try {
    p.complete(r);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(OllamaProvider, SendsModelSchemaSeedAndReturnsContent) {
  ScriptedServer srv("/api/chat");
  srv.then_ollama("{\"kind\": \"cut_in\"}");
  auto p = ollama(srv.url());
  LlmReply reply = p->complete(sample_request());
  EXPECT_EQ(reply.content, "{\"kind\": \"cut_in\"}");
  EXPECT_EQ(reply.model, "llama3:8b");
  EXPECT_EQ(reply.raw["done"], true);
  ASSERT_EQ(srv.requests().size(), 1u);
  Json got = srv.requests()[0];
  EXPECT_EQ(got["model"], "llama3");
  EXPECT_EQ(got["stream"], false);
  EXPECT_EQ(got["format"], sample_request().response_schema);
  EXPECT_EQ(got["options"]["seed"], 1234);
  EXPECT_EQ(got["options"]["temperature"], 0.3);
  EXPECT_EQ(got["options"]["num_predict"], 512);
  EXPECT_EQ(got["messages"], Json::parse(R"([{"role":"user","content":"Describe a hazard."}])"));
  EXPECT_FALSE(got.contains("keep_alive"));
  EXPECT_EQ(p->describe_backend(), "ollama llama3 @ " + srv.url());
}

TEST(OllamaProvider, HostFromEnvironmentWithoutScheme) {
  ScriptedServer srv("/api/chat");
  srv.then_ollama("{}");
  ::setenv("OLLAMA_HOST", ("127.0.0.1:" + std::to_string(srv.port())).c_str(), 1);
  auto p = ollama("");
  ::unsetenv("OLLAMA_HOST");
  EXPECT_EQ(p->endpoint(), srv.url() + "/api/chat");
  EXPECT_EQ(p->complete(sample_request()).content, "{}");
}

TEST(OllamaProvider, TransportAndProtocolFailures) {
  ScriptedServer srv("/api/chat");
  srv.then([](const httplib::Request&, httplib::Response& res) {
    res.status = 500;
    res.set_content(R"({"error":"model \"llama3\" not found, try pulling it first"})", "application/json");
  });
  srv.then([](const httplib::Request&, httplib::Response& res) {
    res.set_content("<html>proxy</html>", "text/html");
  });
  srv.then([](const httplib::Request&, httplib::Response& res) {
    res.set_content(R"({"model":"llama3","done":true})", "application/json");
  });
  auto p = ollama(srv.url());
  const std::string ep = "ollama: POST " + srv.url() + "/api/chat";
  EXPECT_EQ(error_of(*p, sample_request()),
            ep + " returned HTTP 500: model \"llama3\" not found, try pulling it first");
  EXPECT_EQ(error_of(*p, sample_request()), ep + ": response is not JSON: parse error at line 1, column 1: "
                                                 "syntax error while parsing value - invalid "
                                                 "literal; last read: '<'");
  EXPECT_EQ(error_of(*p, sample_request()), ep + ": response has no message.content");

  const int dead = test::unused_port();
  auto refused = ollama("http://127.0.0.1:" + std::to_string(dead));
  EXPECT_EQ(error_of(*refused, sample_request()), "ollama: POST http://127.0.0.1:" + std::to_string(dead) +
                                                      "/api/chat failed: Couldn't connect to server");
}

TEST(OpenAiProvider, SendsStrictJsonSchemaAndKeyFromNamedVariable) {
  ScriptedServer srv("/v1/chat/completions");
  srv.then_openai("```json\n{\"kind\": \"cut_in\"}\n```");
  srv.then_openai("{}");
  ::setenv("HF_TEST_LLM_KEY", "sk-test-123", 1);
  auto p = openai(srv.url());
  LlmReply reply = p->complete(sample_request());
  ::unsetenv("HF_TEST_LLM_KEY");
  EXPECT_EQ(reply.content, "```json\n{\"kind\": \"cut_in\"}\n```");
  EXPECT_EQ(reply.model, "llama-3-8b-instruct");
  Json got = srv.requests()[0];
  EXPECT_EQ(got["model"], "llama-3-8b");
  EXPECT_EQ(got["seed"], 1234);
  EXPECT_EQ(got["temperature"], 0.3);
  EXPECT_EQ(got["max_tokens"], 512);
  EXPECT_EQ(got["response_format"]["type"], "json_schema");
  EXPECT_EQ(got["response_format"]["json_schema"]["name"], "hazard_spec");
  EXPECT_EQ(got["response_format"]["json_schema"]["strict"], true);
  EXPECT_EQ(got["response_format"]["json_schema"]["schema"], sample_request().response_schema);
  EXPECT_EQ(srv.auth_headers()[0], "Bearer sk-test-123");
  // Without the variable, no Authorization header (local servers need none).
  p->complete(sample_request());
  EXPECT_EQ(srv.auth_headers()[1], "");
}

TEST(OpenAiProvider, JsonObjectFallbackAndErrors) {
  ScriptedServer srv("/v1/chat/completions");
  srv.then_openai("{}");
  srv.then([](const httplib::Request&, httplib::Response& res) {
    res.status = 401;
    res.set_content(R"({"error":{"message":"Incorrect API key provided","type":"invalid_request_error"}})",
                    "application/json");
  });
  srv.then([](const httplib::Request&, httplib::Response& res) {
    res.set_content(
        R"({"choices":[{"message":{"role":"assistant","content":null,"refusal":"I can't help with that."}}]})",
        "application/json");
  });
  auto p = openai(srv.url(), "json_object");
  p->complete(sample_request());
  EXPECT_EQ(srv.requests()[0]["response_format"], (Json{{"type", "json_object"}}));
  const std::string ep = "openai: POST " + srv.url() + "/v1/chat/completions";
  EXPECT_EQ(error_of(*p, sample_request()), ep + " returned HTTP 401: Incorrect API key provided");
  EXPECT_EQ(error_of(*p, sample_request()), ep + ": the model refused: I can't help with that.");
}

}  // namespace
}  // namespace hf::llm
