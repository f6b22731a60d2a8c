// Parameter validation and YAML location tracking.
#include <gtest/gtest.h>

#include <cstdlib>

#include "hazardforge/params.hpp"
#include "hazardforge/yaml_json.hpp"

namespace hf {
namespace {

std::vector<ParamSpec> specs() {
  return {ParamSpec::number("conf", 0.25).range(0, 1).describe("confidence"),
          ParamSpec::integer("threads", 2).range(1, 64),
          ParamSpec::string("mode", "fast").one_of({"fast", "accurate"}),
          ParamSpec::path("model", std::nullopt),
          ParamSpec::string_list("classes", {"car"})};
}

TEST(Params, DefaultsFilledAndTypesNormalised) {
  std::vector<Diagnostic> d;
  Json v = validate_params(specs(), Json{{"conf", 1}, {"model", "m.onnx"}}, "stage 'x'", {}, {}, d);
  ASSERT_TRUE(d.empty()) << format_diagnostics(d);
  EXPECT_TRUE(v["conf"].is_number_float());
  EXPECT_EQ(v["threads"], 2);
  Params p(v, "/cfg");
  EXPECT_EQ(p.get_path("model"), std::filesystem::path("/cfg/m.onnx"));
  EXPECT_EQ(p.get_strings("classes"), std::vector<std::string>{"car"});
}

TEST(Params, EveryProblemReportedWithLocation) {
  YamlDocument doc = parse_yaml("conff: 0.3\nthreads: 0\nmode: fsat\n", "c.yaml");
  ParamLocations locs;
  for (auto it = doc.value.begin(); it != doc.value.end(); ++it) locs[it.key()] = doc.at("/" + it.key());
  std::vector<Diagnostic> d;
  Json v = validate_params(specs(), doc.value, "stage 'yolo'", {"c.yaml", 1, 1}, locs, d);
  EXPECT_TRUE(v.is_null());
  ASSERT_EQ(d.size(), 4u) << format_diagnostics(d);
  EXPECT_EQ(d[0].str(), "c.yaml:1:8: error: stage 'yolo' has no parameter 'conff'; did you mean 'conf'?");
  EXPECT_EQ(d[1].str(), "c.yaml:2:10: error: stage 'yolo': parameter 'threads' = 0 is out of range [1, 64]");
  EXPECT_EQ(d[2].str(),
            "c.yaml:3:7: error: stage 'yolo': parameter 'mode' = 'fsat' is not one of: fast, accurate; did you "
            "mean 'fast'?");
  EXPECT_EQ(d[3].str(), "c.yaml:1:1: error: stage 'yolo': required parameter 'model' (path) is missing");
}

TEST(Params, WrongTypeNamesExpectedType) {
  std::vector<Diagnostic> d;
  validate_params(specs(), Json{{"model", "m"}, {"threads", "two"}}, "stage 'x'", {}, {}, d);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].message, "stage 'x': parameter 'threads' expects int, got \"two\"");
}

TEST(Yaml, ScalarsTypedAndQuotedStaysString) {
  YamlDocument doc = parse_yaml("a: 1\nb: 1.5\nc: true\nd: '1'\ne: ~\nf: hello\n", "x.yaml");
  EXPECT_TRUE(doc.value["a"].is_number_integer());
  EXPECT_TRUE(doc.value["b"].is_number_float());
  EXPECT_TRUE(doc.value["c"].is_boolean());
  EXPECT_TRUE(doc.value["d"].is_string());
  EXPECT_TRUE(doc.value["e"].is_null());
  EXPECT_EQ(doc.value["f"], "hello");
}

TEST(Yaml, SyntaxErrorNamesFileLineColumn) {
  try {
    parse_yaml("a: [1, 2\nb: 3\n", "bad.yaml");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("bad.yaml:", 0), 0u) << e.what();
  }
}

TEST(Yaml, MergeKeysTakeTheAnchorsKeysUnlessStatedAndKeepTheirPositions) {
  const YamlDocument doc = parse_yaml(
      "base: &b {x: 1, y: 2}\nmore: &m {z: 3}\none: {<<: *b, y: 5}\ntwo:\n  <<: [*b, *m]\n  w: 0\n",
      "m.yaml");
  EXPECT_EQ(doc.value["one"], (Json{{"x", 1}, {"y", 5}}));
  EXPECT_EQ(doc.value["two"], (Json{{"x", 1}, {"y", 2}, {"z", 3}, {"w", 0}}));
  EXPECT_FALSE(doc.value["one"].contains("<<"));
  // A merged value is where the anchor states it.
  EXPECT_EQ(doc.at("/one/x").str(), doc.at("/base/x").str());
  EXPECT_EQ(doc.at("/one/y").line, 3);
  try {
    parse_yaml("a: {<<: 5}\n", "bad.yaml");
    FAIL() << "a merge of a scalar was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml:1:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'<<' merges mappings only"), std::string::npos) << e.what();
  }
}

TEST(Yaml, DuplicateKeyRejected) {
  EXPECT_THROW(parse_yaml("a: 1\na: 2\n", "dup.yaml"), Error);
}

// Six nested anchors of ten aliases each copy a million values: more than a config's aliases may expand to.
TEST(Yaml, AliasExpansionIsBoundedAndNamesWhereItHappens) {
  std::string y =
      "ok: &ok {a: 1}\nuse: {<<: *ok, b: 2}\nlaughs:\n  a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol, "
      "lol]\n";
  for (char c = 'b'; c <= 'f'; ++c) {
    y += std::string("  ") + c + ": &" + c + " [";
    for (int i = 0; i < 10; ++i) y += std::string(i ? ", " : "") + "*" + static_cast<char>(c - 1);
    y += "]\n";
  }
  try {
    parse_yaml(y, "bomb.yaml");
    FAIL() << "accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("bomb.yaml:", 0), 0u) << what;
    EXPECT_NE(what.find("YAML aliases expand to more than 100000 values"), std::string::npos) << what;
  }
  // A few aliases and merge keys stay fine.
  const YamlDocument doc =
      parse_yaml("ok: &ok {a: 1}\nuse: {<<: *ok, b: 2}\nlist: [*ok, *ok]\n", "fine.yaml");
  EXPECT_EQ(doc.value["use"], (Json{{"a", 1}, {"b", 2}}));
  EXPECT_EQ(doc.value["list"].size(), 2u);
}

// A variable whose name marks a secret is refused: expanded, its value would reach the manifest and, in a
// scene text, the LLM prompt and its records.
TEST(Vars, VariablesNamingSecretsAreNotExpanded) {
  ::setenv("HF_TEST_SERVICE_TOKEN", "t0k3n-value", 1);
  ::setenv("HF_TEST_PLAIN_DIR", "/data", 1);
  EXPECT_EQ(expand_vars("${HF_TEST_PLAIN_DIR}/x"), "/data/x");
  try {
    expand_vars("scene ${HF_TEST_SERVICE_TOKEN}");
    FAIL() << "expanded";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("${HF_TEST_SERVICE_TOKEN} is not expanded"), std::string::npos) << what;
    EXPECT_EQ(what.find("t0k3n-value"), std::string::npos) << what;
  }
  // Named by the caller (e.g. CONFIG_DIR), a variable is the caller's business.
  EXPECT_EQ(expand_vars("${MY_KEY_DIR}", {{"MY_KEY_DIR", "/k"}}), "/k");
  ::unsetenv("HF_TEST_SERVICE_TOKEN");
  ::unsetenv("HF_TEST_PLAIN_DIR");
}

TEST(Nearest, SuggestsCloseNamesOnly) {
  EXPECT_EQ(nearest_name("DETECTION", {"detections", "frames"}), "detections");
  EXPECT_EQ(nearest_name("zzzzzz", {"detections", "frames"}), "");
}

}  // namespace
}  // namespace hf
