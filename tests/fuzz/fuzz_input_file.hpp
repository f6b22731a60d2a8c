// Fuzz inputs for readers that take a path: the bytes written to a per-process file in /tmp.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace hf::fuzz {

inline std::filesystem::path write_input(const uint8_t* data, size_t size, const std::string& name) {
  const auto file =
      std::filesystem::temp_directory_path() / ("hf_fuzz_" + std::to_string(::getpid()) + "_" + name);
  std::ofstream(file, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return file;
}

}  // namespace hf::fuzz
