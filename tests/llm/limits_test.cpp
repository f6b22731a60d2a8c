// Hostile model servers: deep JSON, oversized and endless replies, retries that would snowball, Ctrl-C during
// a call, credentials in the server URL and bytes that are not UTF-8.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <future>
#include <thread>

#include "hazardforge/llm/http.hpp"
#include "hazardforge/llm/json.hpp"
#include "llm_test_support.hpp"

namespace hf {
namespace {

using test::ScriptedServer;

using test::kDescription;

using test::run_error;

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(LlmLimits, NestingDepthIsMeasuredOutsideStrings) {
  EXPECT_EQ(llm::json_nesting_depth(R"({"a": {"b": [1, 2]}})"), 3);
  EXPECT_EQ(llm::json_nesting_depth(R"({"a": "[[[[{{{{"})"), 1);
  EXPECT_EQ(llm::json_nesting_depth(R"({"a": "\"[[["})"), 1);
  EXPECT_EQ(llm::json_nesting_depth("no json"), 0);
}

// Found by fuzz_hazard_reply: nlohmann reports a number too large for a double as out_of_range, not as a
// parse error, and it escaped the extraction (and with it the retry loop).
TEST(LlmLimits, ANumberTooLargeForADoubleIsAReplyErrorNotACrash) {
  try {
    llm::extract_json_object(R"({"speed_mps": 1e11011})");
    FAIL() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "reply is not valid JSON: number overflow parsing '1e11011'");
  }
  try {
    llm::parse_response("ollama", "http://u:p@h/api/chat", R"({"done": 1e11011})");
    FAIL() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "ollama: POST http://***@h/api/chat: response is not JSON: number overflow parsing '1e11011'");
  }
}

TEST(LlmLimits, AReplyNestedDeeperThanTheLimitIsRejectedBeforeParsing) {
  ScriptedServer srv("/api/chat");
  const int levels = 100000;
  srv.then_ollama(std::string(levels, '[') + std::string(levels, ']'));
  auto r = test::make_runner("provider: {name: ollama, host: '" + srv.url() +
                             "'}\nmax_retries: 0\ntrigger: frame\ntrigger_frame: 5\n");
  test::push_scene(r, 6, kDescription);
  EXPECT_EQ(run_error(r), "no valid hazard spec after 1 attempt(s) from ollama llama3 @ " + srv.url() +
                              "; last errors: reply nests JSON 100000 levels deep (at most 64)");
  const auto calls = test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl");
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_EQ(calls[0]["errors"], Json::array({"reply nests JSON 100000 levels deep (at most 64)"}));
}

TEST(LlmLimits, AResponseBodyNestedTooDeeplyFailsTheCallWithARecord) {
  ScriptedServer srv("/api/chat");
  srv.then([](const httplib::Request&, httplib::Response& res) {
    res.set_content(std::string(100000, '[') + std::string(100000, ']'), "application/json");
  });
  auto r = test::make_runner("provider: {name: ollama, host: '" + srv.url() + "'}\n");
  test::push_scene(r, 6, kDescription);
  const std::string msg =
      "ollama: POST " + srv.url() + "/api/chat: response nests JSON 100000 levels deep (at most 64)";
  EXPECT_EQ(run_error(r), msg);
  const auto calls = test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl");
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_EQ(calls[0]["transport_error"], msg);
}

TEST(LlmLimits, AReplyLargerThanTheLimitFailsTheCall) {
  ScriptedServer srv("/api/chat");
  srv.then_ollama(std::string(50000, 'x'));
  auto r = test::make_runner("provider: {name: ollama, host: '" + srv.url() + "', max_reply_bytes: 10000}\n");
  test::push_scene(r, 6, kDescription);
  const std::string msg =
      "ollama: POST " + srv.url() + "/api/chat failed: the response is larger than max_reply_bytes = 10000";
  EXPECT_EQ(run_error(r), msg);
  EXPECT_EQ(srv.requests().size(), 1u);
  EXPECT_EQ(test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl").at(0)["transport_error"], msg);
}

TEST(LlmLimits, AnEndlessBodyIsCutAtTheLimit) {
  ScriptedServer srv("/v1/chat/completions");
  srv.then([](const httplib::Request&, httplib::Response& res) {
    // Chunked, no Content-Length: only the streaming cap can stop it.
    res.set_chunked_content_provider("application/json", [](size_t, httplib::DataSink& sink) {
      static const std::string chunk(64 * 1024, ' ');
      return sink.write(chunk.data(), chunk.size());
    });
  });
  auto r = test::make_runner("provider: {name: openai, base_url: '" + srv.url() +
                             "/v1', max_reply_bytes: 200000}\n");
  test::push_scene(r, 6, kDescription);
  EXPECT_EQ(run_error(r),
            "openai: POST " + srv.url() +
                "/v1/chat/completions failed: the response is larger than max_reply_bytes = 200000");
}

TEST(LlmLimits, RetriesEchoOnlyTheBeginningOfAHugeReply) {
  ScriptedServer srv("/api/chat");
  srv.then_ollama(std::string(20000, 'x'));
  srv.then_ollama(test::valid_reply().dump());
  auto r = test::make_runner("provider: {name: ollama, host: '" + srv.url() + "'}\nmax_retries: 1\n");
  test::push_scene(r, 6, kDescription);
  r.run();
  ASSERT_EQ(r.outputs("hazard").size(), 1u);
  const auto got = srv.requests();
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[1]["messages"][1]["content"],
            std::string(8000, 'x') + "\n[... reply cut here: 20000 bytes in all]");
}

TEST(LlmLimits, StopRequestAbortsACallInProgressWithinASecond) {
  ScriptedServer srv("/api/chat");
  std::promise<void> received, release;
  std::shared_future<void> released = release.get_future().share();
  srv.then([&received, released](const httplib::Request&, httplib::Response& res) {
    received.set_value();
    released.wait_for(std::chrono::seconds(60));
    res.set_content("{}", "application/json");
  });
  auto r = test::make_runner("provider: {name: ollama, host: '" + srv.url() + "', read_timeout_s: 60}\n");
  test::push_scene(r, 6, kDescription);
  std::chrono::steady_clock::time_point stopped_at;
  std::thread stopper([&] {
    received.get_future().wait();
    stopped_at = std::chrono::steady_clock::now();
    r.request_stop();
  });
  r.run();
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - stopped_at).count();
  stopper.join();
  release.set_value();
  EXPECT_LT(waited, 1.5);
  RecordProperty("seconds_from_stop_to_return", std::to_string(waited));
  EXPECT_TRUE(r.outputs("hazard").empty());
  const auto calls = test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl");
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_EQ(calls[0]["cancelled"], true);
  EXPECT_EQ(calls[0]["transport_error"],
            "ollama: POST " + srv.url() + "/api/chat cancelled: the run is stopping");
  const auto& log = r.log();
  EXPECT_NE(std::find(log.begin(), log.end(),
                      "warning: no hazard generated: ollama: POST " + srv.url() +
                          "/api/chat cancelled: the run is stopping"),
            log.end());
}

TEST(LlmLimits, CredentialsInTheServerUrlNeverReachTheRecords) {
  ScriptedServer srv("/api/chat");
  srv.then_ollama(test::valid_reply().dump());
  const std::string host = "http://alice:s3cret@127.0.0.1:" + std::to_string(srv.port());
  auto r = test::make_runner("provider: {name: ollama, host: '" + host + "'}\n");
  test::push_scene(r, 6, kDescription);
  r.run();
  ASSERT_EQ(r.outputs("hazard").size(), 1u);
  const std::string shown = "ollama llama3 @ http://***@127.0.0.1:" + std::to_string(srv.port());
  EXPECT_EQ(r.collect<HazardSpec>("hazard")[0].provenance["backend"], shown);
  for (const char* f : {"hazard_spec.json", "llm/calls.jsonl"}) {
    const std::string text = slurp(r.output_dir() / f);
    EXPECT_EQ(text.find("s3cret"), std::string::npos) << f;
    EXPECT_EQ(text.find("alice"), std::string::npos) << f;
  }
  for (const std::string& line : r.log()) EXPECT_EQ(line.find("s3cret"), std::string::npos) << line;
}

TEST(LlmLimits, CredentialsAreRedactedFromTransportErrors) {
  const std::string host = "http://alice:s3cret@127.0.0.1:" + std::to_string(test::unused_port());
  auto r = test::make_runner("provider: {name: openai, base_url: '" + host + "/v1?key=k3y'}\n");
  test::push_scene(r, 6, kDescription);
  const std::string e = run_error(r);
  EXPECT_EQ(e.find("s3cret"), std::string::npos) << e;
  EXPECT_EQ(e.find("k3y"), std::string::npos) << e;
  EXPECT_NE(e.find("openai: POST http://***@127.0.0.1:"), std::string::npos) << e;
}

// A server that echoes the request's Authorization header, in a reply the generator accepts and beside it.
void then_echoing_auth(ScriptedServer& srv, bool openai) {
  srv.then([openai](const httplib::Request& req, httplib::Response& res) {
    const std::string auth = req.get_header_value("Authorization");
    Json reply = test::valid_reply();
    reply["rationale"] = "you sent " + auth;
    const Json message = {{"role", "assistant"}, {"content", reply.dump()}};
    const Json body = openai ? Json{{"model", "m"},
                                    {"choices", {{{"index", 0}, {"message", message}}}},
                                    {"echo", {{"authorization", auth}}}}
                             : Json{{"model", "m"}, {"message", message}, {"done", true}, {"echo", auth}};
    res.set_content(body.dump(), "application/json");
  });
}

// Every file the stage wrote, and the spec it sent on (what the host's sinks put into hazards.jsonl).
std::string everything_written(testing::StageRunner& r) {
  std::string all;
  for (const auto& e : std::filesystem::recursive_directory_iterator(r.output_dir()))
    if (e.is_regular_file()) all += slurp(e.path()) + "\n";
  for (const HazardSpec& s : r.collect<HazardSpec>("hazard")) all += Json(s).dump() + "\n";
  for (const std::string& line : r.log()) all += line + "\n";
  return all;
}

TEST(LlmLimits, AnApiKeyEchoedByTheServerNeverReachesTheRecordsOrTheSpec) {
  ScriptedServer srv("/v1/chat/completions");
  then_echoing_auth(srv, true);
  ::setenv("HF_TEST_ECHO_KEY", "sk-echo-5f3a9c71", 1);
  auto r = test::make_runner("provider: {name: openai, base_url: '" + srv.url() +
                             "/v1', api_key_env: HF_TEST_ECHO_KEY}\n");
  test::push_scene(r, 6, kDescription);
  r.run();
  ::unsetenv("HF_TEST_ECHO_KEY");
  ASSERT_EQ(srv.auth_headers().at(0), "Bearer sk-echo-5f3a9c71");  // the server did get the key
  ASSERT_EQ(r.outputs("hazard").size(), 1u);
  const std::string all = everything_written(r);
  EXPECT_EQ(all.find("sk-echo-5f3a9c71"), std::string::npos) << all;
  EXPECT_NE(all.find("you sent Bearer ***"), std::string::npos) << all;
}

TEST(LlmLimits, AnApiKeyEchoedInAnErrorNeverReachesTheErrorOrTheRecords) {
  ScriptedServer srv("/v1/chat/completions");
  srv.then([](const httplib::Request& req, httplib::Response& res) {
    res.status = 401;
    res.set_content(Json{{"error", {{"message", "invalid " + req.get_header_value("Authorization")}}}}.dump(),
                    "application/json");
  });
  ::setenv("HF_TEST_ECHO_KEY", "sk-echo-5f3a9c71", 1);
  auto r = test::make_runner("provider: {name: openai, base_url: '" + srv.url() +
                             "/v1', api_key_env: HF_TEST_ECHO_KEY}\n");
  test::push_scene(r, 6, kDescription);
  const std::string e = run_error(r);
  ::unsetenv("HF_TEST_ECHO_KEY");
  EXPECT_EQ(e, "openai: POST " + srv.url() + "/v1/chat/completions returned HTTP 401: invalid Bearer ***");
  const std::string all = everything_written(r);
  EXPECT_EQ(all.find("sk-echo-5f3a9c71"), std::string::npos) << all;
}

TEST(LlmLimits, BasicCredentialsEchoedByTheServerNeverReachTheRecordsOrTheSpec) {
  ScriptedServer srv("/api/chat");
  then_echoing_auth(srv, false);
  const std::string host = "http://alice:s3cret@127.0.0.1:" + std::to_string(srv.port());
  auto r = test::make_runner("provider: {name: ollama, host: '" + host + "'}\n");
  test::push_scene(r, 6, kDescription);
  r.run();
  ASSERT_EQ(srv.auth_headers().at(0), "Basic YWxpY2U6czNjcmV0");  // base64 of alice:s3cret
  ASSERT_EQ(r.outputs("hazard").size(), 1u);
  const std::string all = everything_written(r);
  EXPECT_EQ(all.find("YWxpY2U6czNjcmV0"), std::string::npos) << all;
  EXPECT_EQ(all.find("s3cret"), std::string::npos) << all;
  EXPECT_NE(all.find("you sent Basic ***"), std::string::npos) << all;
}

TEST(LlmLimits, RepliesThatAreNotUtf8AreRecordedAndSentBack) {
  ScriptedServer srv("/api/chat");
  srv.then([](const httplib::Request&, httplib::Response& res) {
    // The body is JSON-escaped text with a raw 0xFF byte in the content string.
    res.set_content(std::string(R"({"model":"m","message":{"role":"assistant","content":"caf)") + '\xff' +
                        R"( no json"},"done":true})",
                    "application/json");
  });
  srv.then_ollama(test::valid_reply().dump());
  auto r = test::make_runner("provider: {name: ollama, host: '" + srv.url() + "'}\nmax_retries: 1\n");
  test::push_scene(r, 6, kDescription);
  const std::string e = run_error(r);
  // nlohmann refuses invalid UTF-8 inside strings: the body is reported as not JSON, with a record.
  EXPECT_NE(e.find("ollama: POST " + srv.url() + "/api/chat: response is not JSON: "), std::string::npos)
      << e;
  const auto calls = test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl");
  ASSERT_EQ(calls.size(), 1u);
}

}  // namespace
}  // namespace hf
