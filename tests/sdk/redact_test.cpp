// URL redaction: userinfo and query strings go, everything else of a message stays.
#include <gtest/gtest.h>

#include "hazardforge/redact.hpp"

namespace {

TEST(Redact, UserinfoAndQueryAreReplaced) {
  EXPECT_EQ(hf::redact_urls("http://u:p@host:1/v1?key=k#frag"), "http://***@host:1/v1?***#frag");
  EXPECT_EQ(hf::redact_urls("https://token@api.example.com/v1"), "https://***@api.example.com/v1");
  EXPECT_EQ(hf::redact_urls("http://127.0.0.1:11434"), "http://127.0.0.1:11434");
}

TEST(Redact, WorksInsideMessagesAndLeavesOtherTextAlone) {
  EXPECT_EQ(
      hf::redact_urls("ollama: POST http://a:b@h:1/api/chat failed: Couldn't connect; see http://x/?q=1."),
      "ollama: POST http://***@h:1/api/chat failed: Couldn't connect; see http://x/?***");
  EXPECT_EQ(hf::redact_urls("a@b.c and ://odd and 3://x"), "a@b.c and ://odd and 3://x");
  EXPECT_EQ(hf::redact_urls("--set g.provider.host='http://u:p@h'"), "--set g.provider.host='http://***@h'");
}

TEST(Redact, EveryStringOfAJsonDocument) {
  const nlohmann::json j = {{"argv", {"run", "--set", "x.host=http://u:p@h:1"}},
                            {"config", {{"host", "http://u:p@h:1/v1?api_key=abc"}, {"n", 3}}}};
  const nlohmann::json r = hf::redact_json_urls(j);
  EXPECT_EQ(r["argv"][2], "x.host=http://***@h:1");
  EXPECT_EQ(r["config"]["host"], "http://***@h:1/v1?***");
  EXPECT_EQ(r["config"]["n"], 3);
}

}  // namespace
