// ELF64 dynamic symbol lookup with every offset checked against the file size.
#include "hazardforge/core/elf_symbols.hpp"

#include <elf.h>

#include <cstring>
#include <fstream>

#include "hazardforge/error.hpp"

namespace hf::core {

namespace {

// Plugins are a few MB; a much larger "library" is not worth reading to find out it is not one.
constexpr std::uintmax_t kMaxLibraryBytes = 1ull << 30;

template <class T>
bool read_at(std::string_view image, uint64_t offset, T& out) {
  if (offset > image.size() || image.size() - offset < sizeof(T)) return false;
  std::memcpy(&out, image.data() + offset, sizeof(T));
  return true;
}

}  // namespace

bool elf_exports_symbol(std::string_view image, std::string_view symbol, const std::string& name) {
  auto refuse = [&](const std::string& why) { return Error(name + ": not a HazardForge plugin: " + why); };
  Elf64_Ehdr eh{};
  if (!read_at(image, 0, eh) || std::memcmp(eh.e_ident, ELFMAG, SELFMAG) != 0)
    throw refuse("not an ELF shared library");
  if (eh.e_ident[EI_CLASS] != ELFCLASS64) throw refuse("not a 64-bit ELF library");
  const unsigned char order = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ ? ELFDATA2LSB : ELFDATA2MSB;
  if (eh.e_ident[EI_DATA] != order) throw refuse("ELF library of the other byte order");
  if (eh.e_type != ET_DYN) throw refuse("ELF file is not a shared library");
  if (eh.e_shentsize != sizeof(Elf64_Shdr)) throw refuse("malformed ELF section header size");
  for (uint64_t i = 0; i < eh.e_shnum; ++i) {
    Elf64_Shdr sh{};
    if (!read_at(image, eh.e_shoff + i * sizeof(Elf64_Shdr), sh))
      throw refuse("ELF section table is cut off");
    if (sh.sh_type != SHT_DYNSYM) continue;
    Elf64_Shdr strtab{};
    if (sh.sh_link >= eh.e_shnum ||
        !read_at(image, eh.e_shoff + uint64_t{sh.sh_link} * sizeof(Elf64_Shdr), strtab))
      throw refuse("ELF dynamic symbol table names no string table");
    if (strtab.sh_offset > image.size() || image.size() - strtab.sh_offset < strtab.sh_size)
      throw refuse("ELF dynamic string table is cut off");
    const std::string_view strings = image.substr(strtab.sh_offset, strtab.sh_size);
    if (sh.sh_entsize != sizeof(Elf64_Sym)) throw refuse("malformed ELF symbol size");
    const uint64_t count = sh.sh_size / sizeof(Elf64_Sym);
    for (uint64_t k = 0; k < count; ++k) {
      Elf64_Sym s{};
      if (!read_at(image, sh.sh_offset + k * sizeof(Elf64_Sym), s))
        throw refuse("ELF symbol table is cut off");
      if (s.st_name >= strings.size() || s.st_shndx == SHN_UNDEF) continue;
      const unsigned bind = ELF64_ST_BIND(s.st_info);
      if (bind != STB_GLOBAL && bind != STB_WEAK) continue;
      const std::string_view rest = strings.substr(s.st_name);
      const size_t len = rest.find('\0');
      if (len != std::string_view::npos && rest.substr(0, len) == symbol) return true;
    }
  }
  return false;
}

bool elf_exports_symbol(const std::filesystem::path& library, std::string_view symbol) {
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(library, ec);
  if (ec) throw Error(library.string() + ": cannot read plugin library: " + ec.message());
  if (size > kMaxLibraryBytes)
    throw Error(library.string() + ": not a HazardForge plugin: larger than " +
                std::to_string(kMaxLibraryBytes >> 20) + " MB");
  std::ifstream in(library, std::ios::binary);
  std::string image(size, '\0');
  if (!in.read(image.data(), static_cast<std::streamsize>(size)))
    throw Error(library.string() + ": cannot read plugin library");
  return elf_exports_symbol(image, symbol, library.string());
}

}  // namespace hf::core
