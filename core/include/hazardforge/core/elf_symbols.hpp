// Reads a shared library's ELF dynamic symbol table without loading it, so no code of a non-plugin ever runs.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace hf::core {

// True when `library` (an ELF64 shared object for this machine's byte order) defines and exports `symbol` in
// its dynamic symbol table. Throws hf::Error "PATH: not a HazardForge plugin: <why>" for a file that is not
// such a library or whose tables are malformed; every offset is bounds-checked, so a hostile file cannot make
// the reader go astray.
bool elf_exports_symbol(const std::filesystem::path& library, std::string_view symbol);

// The same on a file already in memory (`name` only labels messages).
bool elf_exports_symbol(std::string_view image, std::string_view symbol, const std::string& name);

}  // namespace hf::core
