// Fuzzes the ELF dynamic-symbol reader the plugin loader runs on every candidate library before dlopen.
#include <cstdint>
#include <string_view>

#include "hazardforge/core/elf_symbols.hpp"
#include "hazardforge/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    (void)hf::core::elf_exports_symbol(std::string_view(reinterpret_cast<const char*>(data), size),
                                       "hazardforge_plugin_entry", "fuzz.so");
  } catch (const hf::Error&) {
  }
  return 0;
}
