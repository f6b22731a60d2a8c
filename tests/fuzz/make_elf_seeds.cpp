// Writes the seed corpus of fuzz_elf_symbols into a folder: two ELF64 headers the reader must refuse (one with no
// section table at all, one whose section table lies far beyond the file) and copies of real shared libraries of
// this build, so the fuzzer starts from valid dynamic symbol tables.
//
//   make_elf_seeds OUT_DIR LIBRARY...
#include <elf.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>

namespace {

Elf64_Ehdr header() {
  Elf64_Ehdr h;
  std::memset(&h, 0, sizeof h);
  std::memcpy(h.e_ident, ELFMAG, SELFMAG);
  h.e_ident[EI_CLASS] = ELFCLASS64;
  h.e_ident[EI_DATA] = ELFDATA2LSB;
  h.e_ident[EI_VERSION] = EV_CURRENT;
  h.e_type = ET_DYN;
  h.e_machine = EM_X86_64;
  h.e_version = EV_CURRENT;
  h.e_ehsize = sizeof(Elf64_Ehdr);
  h.e_shentsize = sizeof(Elf64_Shdr);
  h.e_shnum = 1;
  return h;
}

void write(const std::filesystem::path& file, const Elf64_Ehdr& h) {
  std::ofstream(file, std::ios::binary).write(reinterpret_cast<const char*>(&h), sizeof h);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: make_elf_seeds OUT_DIR LIBRARY...\n";
    return 2;
  }
  const std::filesystem::path out = argv[1];
  std::filesystem::create_directories(out);
  Elf64_Ehdr h = header();
  h.e_shoff = sizeof(Elf64_Ehdr);  // a section table that starts where the 64-byte file ends
  write(out / "header_only.bin", h);
  h.e_shoff = 0xffffffffffff0000ULL;  // far beyond any file
  write(out / "bad_shoff.bin", h);
  for (int i = 2; i < argc; ++i)
    std::filesystem::copy_file(argv[i], out / std::filesystem::path(argv[i]).filename(),
                               std::filesystem::copy_options::overwrite_existing);
  return 0;
}
