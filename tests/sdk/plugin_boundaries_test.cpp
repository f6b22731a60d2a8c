// The house's rule, checked on the tree: a plugin uses the SDK and the kits (installed libraries with
// namespaced headers), never another plugin's folder — by include, include path or link.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "temp_dir.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

bool is_source(const fs::path& p) {
  const std::string e = p.extension().string();
  return e == ".cpp" || e == ".hpp" || e == ".h" || e == ".cc";
}

// Every way a folder under plugins/ reaches outside itself other than through the SDK and the kits:
// - `#include "X"` that is neither a namespaced header (hazardforge/...) nor a file of the folder itself;
// - a CMakeLists.txt naming a path above the folder (`..`, ${CMAKE_SOURCE_DIR}) or linking another plugin's
//   implementation library (hf_<name>_impl).
// Kits (plugins/<kind>/common) follow the same rules: they are libraries, not a back door.
std::vector<std::string> boundary_violations(const fs::path& root) {
  std::vector<std::string> found;
  const std::regex quoted_include(R"re(^\s*#\s*include\s*"([^"]+)")re");
  const std::regex impl_target(R"(\bhf_([a-z0-9_]+)_impl\b)");
  const std::regex outside_path(R"(\$\{CMAKE_SOURCE_DIR\}|\$\{PROJECT_SOURCE_DIR\}|\.\./|/\.\.(\)|\s|$))");
  for (const fs::directory_entry& kind : fs::directory_iterator(root / "plugins")) {
    if (!kind.is_directory()) continue;
    for (const fs::directory_entry& folder : fs::directory_iterator(kind.path())) {
      if (!folder.is_directory()) continue;
      const fs::path dir = folder.path();
      const std::string name = dir.filename().string();
      const std::string where = fs::relative(dir, root).string();
      std::set<std::string> own_files;
      for (const fs::directory_entry& f : fs::recursive_directory_iterator(dir))
        if (f.is_regular_file()) own_files.insert(f.path().filename().string());
      for (const fs::directory_entry& f : fs::recursive_directory_iterator(dir)) {
        if (!f.is_regular_file()) continue;
        const std::string rel = fs::relative(f.path(), root).string();
        if (is_source(f.path())) {
          std::istringstream text(test::read_file(f.path()));
          std::string line;
          for (int n = 1; std::getline(text, line); ++n) {
            std::smatch m;
            if (!std::regex_search(line, m, quoted_include)) continue;
            const std::string inc = m[1];
            if (inc.rfind("hazardforge/", 0) == 0) continue;
            const bool own = inc.find("..") == std::string::npos &&
                             (fs::exists(f.path().parent_path() / inc) || fs::exists(dir / inc) ||
                              own_files.count(fs::path(inc).filename().string()) != 0);
            if (!own)
              found.push_back(rel + ":" + std::to_string(n) + ": includes \"" + inc + "\", not a file of " +
                              where + " nor a namespaced SDK or kit header (hazardforge/...)");
          }
        } else if (f.path().filename() == "CMakeLists.txt") {
          const std::string cmake = test::read_file(f.path());
          std::set<std::string> own_impl;  // the implementation libraries of the plugins this file declares
          const std::regex declares(R"(hazardforge_add_plugin\(\s*(hf_[a-z0-9_]+))");
          for (std::sregex_iterator it(cmake.begin(), cmake.end(), declares), end; it != end; ++it)
            own_impl.insert((*it)[1].str() + "_impl");
          std::istringstream text(cmake);
          std::string line;
          for (int n = 1; std::getline(text, line); ++n) {
            const std::string code = line.substr(0, line.find('#'));
            const std::string at = rel + ":" + std::to_string(n);
            if (std::regex_search(code, outside_path))
              found.push_back(at + ": names a path outside " + where + ": " + line);
            for (std::sregex_iterator it(code.begin(), code.end(), impl_target), end; it != end; ++it) {
              if (own_impl.count(it->str())) continue;
              found.push_back(at +
                              (name == "common" ? ": a kit links a plugin's implementation "
                                                : ": links another plugin's implementation ") +
                              it->str() + " (share code through a kit instead)");
            }
          }
        }
      }
    }
  }
  return found;
}

// The host library (core/src, core/include) knows nothing of the CLI's applications (core/apps): no file of
// it includes an apps header (the apps library links the host, not the other way round).
std::vector<std::string> host_violations(const fs::path& root) {
  std::vector<std::string> found;
  const std::regex apps_include(R"re(^\s*#\s*include\s*[<"]hazardforge/apps/)re");
  for (const char* dir : {"core/src", "core/include"}) {
    if (!fs::exists(root / dir)) continue;
    for (const fs::directory_entry& e : fs::recursive_directory_iterator(root / dir)) {
      if (!e.is_regular_file() || !is_source(e.path())) continue;
      std::ifstream in(e.path());
      std::string line;
      for (int n = 1; std::getline(in, line); ++n)
        if (std::regex_search(line, apps_include))
          found.push_back(fs::relative(e.path(), root).string() + ":" + std::to_string(n) +
                          ": the host includes an application header");
    }
  }
  return found;
}

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const std::string& x : v) s += x + "\n";
  return s;
}

TEST(PluginBoundaries, NoPluginReachesIntoAnotherPluginsFolder) {
  const std::vector<std::string> found = boundary_violations(test::source_dir());
  EXPECT_TRUE(found.empty()) << joined(found);
}

TEST(HostBoundary, TheHostLibraryDoesNotKnowTheApplications) {
  const std::vector<std::string> found = host_violations(test::source_dir());
  EXPECT_TRUE(found.empty()) << joined(found);
  EXPECT_TRUE(fs::exists(test::source_dir() / "core/apps/src/campaign.cpp"));
}

void write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << text;
}

TEST(HostBoundary, TheCheckFindsAnApplicationHeaderInTheHost) {
  test::TempDir t;
  write(t.path() / "core/src/host.cpp", "#include \"hazardforge/core/host.hpp\"\n");
  ASSERT_TRUE(host_violations(t.path()).empty());
  write(t.path() / "core/src/scheduler.cpp",
        "#include \"hazardforge/core/scheduler.hpp\"\n  #  include <hazardforge/apps/campaign.hpp>\n");
  EXPECT_EQ(host_violations(t.path()),
            std::vector<std::string>{"core/src/scheduler.cpp:2: the host includes an application header"});
}

TEST(PluginBoundaries, TheCheckFindsEachWayOfReachingIn) {
  test::TempDir t;
  const fs::path root = t.path();
  write(root / "plugins/detector/a/a.hpp", "#pragma once\n");
  write(root / "plugins/detector/a/a.cpp", "#include \"a.hpp\"\n#include \"hazardforge/stage.hpp\"\n");
  write(root / "plugins/detector/a/CMakeLists.txt",
        "hazardforge_add_plugin(hf_a ENTRY plugin.cpp SOURCES a.cpp)  # no ${CMAKE_SOURCE_DIR} here\n");
  ASSERT_TRUE(boundary_violations(root).empty()) << joined(boundary_violations(root));

  write(root / "plugins/tracker/b/b.cpp",
        "#include \"b.hpp\"\n#include \"a.hpp\"\n#include \"../common/x.hpp\"\n");
  write(root / "plugins/tracker/b/b.hpp", "#pragma once\n");
  write(root / "plugins/tracker/b/CMakeLists.txt",
        "hazardforge_add_plugin(hf_b ENTRY plugin.cpp SOURCES b.cpp LIBRARIES hf_a_impl)\n"
        "target_include_directories(hf_b_impl PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/..)\n"
        "target_include_directories(hf_b_impl PUBLIC ${CMAKE_SOURCE_DIR}/plugins/detector/a)\n");
  write(root / "plugins/tracker/common/CMakeLists.txt",
        "add_library(hf_t STATIC t.cpp)\n"
        "target_link_libraries(hf_t PUBLIC hf_b_impl)\n");
  const std::vector<std::string> found = boundary_violations(root);
  const std::string all = joined(found);
  ASSERT_EQ(found.size(), 6u) << all;
  EXPECT_NE(all.find("plugins/tracker/b/b.cpp:2: includes \"a.hpp\""), std::string::npos) << all;
  EXPECT_NE(all.find("plugins/tracker/b/b.cpp:3: includes \"../common/x.hpp\""), std::string::npos) << all;
  EXPECT_NE(all.find("plugins/tracker/b/CMakeLists.txt:1: links another plugin's implementation hf_a_impl"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("plugins/tracker/b/CMakeLists.txt:2: names a path outside"), std::string::npos) << all;
  EXPECT_NE(all.find("plugins/tracker/b/CMakeLists.txt:3: names a path outside"), std::string::npos) << all;
  EXPECT_NE(
      all.find("plugins/tracker/common/CMakeLists.txt:2: a kit links a plugin's implementation hf_b_impl"),
      std::string::npos)
      << all;
}

}  // namespace
}  // namespace hf
