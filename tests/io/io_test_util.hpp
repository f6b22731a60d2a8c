// Helpers for the I/O tests: scratch folders and running a source stage to completion.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "hazardforge/testing/stage_runner.hpp"

namespace hf::test {

// A fresh folder below the system temp dir, removed when the object goes away.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "hf_io_test_XXXXXX").string();
    if (!mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
    path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& rel) const { return path_ / rel; }

 private:
  std::filesystem::path path_;
};

// Runs a source built from `yaml` and returns every frame it emitted.
template <class Source>
std::vector<Frame> run_source(const std::string& yaml, hf::testing::StageRunner* keep = nullptr) {
  auto r = hf::testing::StageRunner::create<Source>(yaml);
  r.run();
  auto frames = r.template collect<Frame>("frames");
  if (keep) *keep = std::move(r);
  return frames;
}

// The message of the hf::Error `fn` throws, or "" when it throws nothing.
template <class Fn>
std::string error_of(Fn&& fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace hf::test
