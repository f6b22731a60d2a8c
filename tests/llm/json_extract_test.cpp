// JSON extraction from model replies: bare, prose, fences, and the messages for replies that hold no object.
#include <gtest/gtest.h>

#include "hazardforge/llm/hash.hpp"
#include "hazardforge/llm/json.hpp"

namespace hf::llm {
namespace {

std::string error_of(const std::string& reply) {
  try {
    extract_json_object(reply);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(JsonExtract, BareObject) {
  EXPECT_EQ(extract_json_object(" {\"a\": 1}\n")["a"], 1);
}

TEST(JsonExtract, ObjectInsideProse) {
  Json j = extract_json_object(
      "Sure! Here is the hazard: {\"kind\": \"cut_in\", \"note\": \"a } in a string\"} Hope it helps.");
  EXPECT_EQ(j["kind"], "cut_in");
  EXPECT_EQ(j["note"], "a } in a string");
}

TEST(JsonExtract, FencedWithLanguageTag) {
  Json j = extract_json_object(
      "Here you go:\n```json\n{\"kind\": \"sudden_stop\", \"x\": {\"y\": [1, 2]}}\n```\nDone.");
  EXPECT_EQ(j["kind"], "sudden_stop");
  EXPECT_EQ(j["x"]["y"][1], 2);
}

TEST(JsonExtract, SkipsBracesThatAreNotJson) {
  Json j = extract_json_object("Use {placeholders} like this: {\"kind\": \"cut_in\"}");
  EXPECT_EQ(j["kind"], "cut_in");
}

TEST(JsonExtract, ClearMessages) {
  EXPECT_EQ(error_of("   \n"), "reply is empty");
  EXPECT_EQ(error_of("I cannot help with that."),
            "reply contains no JSON object (it begins \"I cannot help with that.\")");
  EXPECT_EQ(error_of("[{\"kind\": \"cut_in\"}]"), "reply is a JSON array, not an object");
  EXPECT_EQ(error_of("{\"kind\": \"cut_in\", \"speed_mps\": 3"),
            "reply JSON object is cut off: the '{' at character 0 is never closed");
  EXPECT_EQ(
      error_of("{\"kind\": cut_in}"),
      "reply is not valid JSON: parse error at line 1, column 10: syntax error while parsing value - invalid "
      "literal; last read: '\"kind\": c'");
}

TEST(Sha256, KnownDigest) {
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
}

}  // namespace
}  // namespace hf::llm
