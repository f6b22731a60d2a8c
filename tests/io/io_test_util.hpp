// Helpers for the I/O tests: scratch folders and running a source stage to completion.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "hazardforge/testing/stage_runner.hpp"
#include "temp_dir.hpp"

namespace hf::test {

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
