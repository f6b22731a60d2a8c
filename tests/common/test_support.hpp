// Helpers shared by the tests: where the real data is, and skipping cleanly when it is absent.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace hf::test {

// A file's whole text ("" when it cannot be read).
inline std::string read_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// $HAZARDFORGE_SHARED, else ../shared beside the source checkout.
inline std::filesystem::path shared_dir() {
  if (const char* env = std::getenv("HAZARDFORGE_SHARED"); env && *env) return env;
  return std::filesystem::path(HF_DEFAULT_SHARED_DIR).lexically_normal();
}
inline std::filesystem::path shared_data(const std::string& rel) { return shared_dir() / "data" / rel; }
inline std::filesystem::path shared_model(const std::string& rel) { return shared_dir() / "models" / rel; }
inline std::filesystem::path source_dir() { return HF_SOURCE_DIR; }
inline std::filesystem::path binary_dir() { return HF_BINARY_DIR; }
inline std::filesystem::path plugin_dir() { return HF_PLUGIN_DIR; }
inline std::filesystem::path test_data(const std::string& rel) { return std::filesystem::path(HF_TEST_DATA_DIR) / rel; }

}  // namespace hf::test

// The real data is part of CI; its absence is a failure there, not a skip.
#define HF_REQUIRE_SHARED(path)                                                                  \
  ASSERT_TRUE(std::filesystem::exists(path)) << "missing shared data: " << (path)                \
                                             << " (set HAZARDFORGE_SHARED to the shared folder)"
