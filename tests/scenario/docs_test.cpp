// docs/writing-a-hazard-template.md prints the out-of-tree example verbatim; keep the page and the files in
// step.
#include <gtest/gtest.h>

#include "scenario_support.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

TEST(HazardTemplateDoc, ShowsTheOutOfTreeExampleVerbatim) {
  const std::string doc =
      test::read_text((test::source_dir() / "docs" / "writing-a-hazard-template.md").string());
  ASSERT_FALSE(doc.empty());
  for (const char* f : {"jaywalker_diagonal.cpp", "CMakeLists.txt", "jaywalker_diagonal_test.cpp"}) {
    const std::string text =
        test::read_text((test::source_dir() / "tests" / "scenario" / "jaywalker_diagonal" / f).string());
    ASSERT_FALSE(text.empty()) << f;
    EXPECT_NE(doc.find("```" + std::string(f[0] == 'C' ? "cmake" : "cpp") + "\n" + text + "```"),
              std::string::npos)
        << f << " differs from its copy in the page";
  }
}

}  // namespace
}  // namespace hf
