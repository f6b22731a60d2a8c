// Test helpers for exported XML: unique temporary folders, xmllint schema validation.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "test_support.hpp"

namespace hf::test {

// A fresh folder for this test in this process: <tmp>/hf_<suite>_<test>_<pid>_<n>.
inline std::filesystem::path unique_temp_dir() {
  static std::atomic<int> counter{0};
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "_" + info->name() : "test";
  for (char& c : name)
    if (c == '/') c = '_';
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      ("hf_" + name + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

inline std::filesystem::path xosc_schema() {
  return shared_dir() / "schemas" / "OpenSCENARIOv1.2.xsd";
}
inline std::filesystem::path xodr_schema() {
  return shared_dir() / "schemas" / "OpenDRIVE_1.6" / "opendrive_16_core.xsd";
}

struct Validation {
  int status = -1;
  std::string output;
  bool ok() const { return status == 0 && output.find("validates") != std::string::npos; }
};

// xmllint --noout --schema XSD FILE, as a user would run it.
inline Validation validate_xml(const std::filesystem::path& file, const std::filesystem::path& xsd) {
  const std::filesystem::path log = file.string() + ".xmllint.txt";
  const std::string cmd =
      "xmllint --noout --schema '" + xsd.string() + "' '" + file.string() + "' > '" + log.string() + "' 2>&1";
  Validation v;
  const int rc = std::system(cmd.c_str());
  v.status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  std::ifstream in(log);
  v.output.assign(std::istreambuf_iterator<char>(in), {});
  return v;
}

inline void write_text(const std::filesystem::path& file, const std::string& text) {
  std::ofstream(file) << text;
}

}  // namespace hf::test
