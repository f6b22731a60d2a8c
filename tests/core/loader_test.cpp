// Every plugin refusal, each with its exact message; and a good plugin's registration.
#include <gtest/gtest.h>

#include <fstream>

#include "hazardforge/core/elf_symbols.hpp"
#include "hazardforge/core/plugin_loader.hpp"
#include "temp_dir.hpp"
#include "test_support.hpp"

namespace hf::core {
namespace {

std::filesystem::path fixture(const std::string& name) {
  return std::filesystem::path(HF_FIXTURE_DIR) / name / ("lib" + name + ".so");
}

std::string load_error(const std::string& name, ComponentRegistry& reg) {
  PluginLoader loader(reg);
  try {
    loader.load(fixture(name));
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

const std::string kAbi = std::to_string(HF_SDK_ABI_MAJOR) + "." + std::to_string(HF_SDK_ABI_MINOR);

TEST(Loader, GoodPluginRegistersItsStageWithOrigin) {
  ComponentRegistry reg;
  PluginLoader loader(reg);
  loader.load(fixture("fixture_good_a"));
  ASSERT_EQ(loader.plugins().size(), 1u);
  EXPECT_EQ(loader.plugins()[0].name, "good_a");
  EXPECT_EQ(loader.plugins()[0].version, "1.2.3");
  const RegisteredComponent* c = reg.find("detector", "dup_detector");
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->library, fixture("fixture_good_a").string());
  EXPECT_TRUE(c->info.is_stage);
}

TEST(Loader, WrongAbiMajor) {
  ComponentRegistry reg;
  EXPECT_EQ(load_error("fixture_wrong_major", reg),
            fixture("fixture_wrong_major").string() + ": plugin built for SDK ABI " +
                std::to_string(HF_SDK_ABI_MAJOR + 1) + ".0, host has " + kAbi + " (major versions must match)");
}

TEST(Loader, NewerAbiMinor) {
  ComponentRegistry reg;
  EXPECT_EQ(load_error("fixture_newer_minor", reg),
            fixture("fixture_newer_minor").string() + ": plugin built for SDK ABI " + std::to_string(HF_SDK_ABI_MAJOR) +
                "." + std::to_string(HF_SDK_ABI_MINOR + 1) + ", host has " + kAbi + " (plugin needs a newer host)");
}

TEST(Loader, BadAbiTag) {
  ComponentRegistry reg;
  EXPECT_EQ(load_error("fixture_bad_tag", reg), fixture("fixture_bad_tag").string() +
                                                    ": ABI tag mismatch: plugin 'gcc9/cxx11abi0/c++17/opencv3.4', "
                                                    "host '" HF_ABI_TAG "'");
}

TEST(Loader, MissingEntrySymbol) {
  ComponentRegistry reg;
  EXPECT_EQ(load_error("fixture_no_entry", reg),
            fixture("fixture_no_entry").string() +
                ": not a HazardForge plugin: entry symbol 'hazardforge_plugin_entry' not found");
}

// The entry symbol is looked up in the ELF file before dlopen, so a non-plugin's constructors never run.
TEST(Loader, NonPluginConstructorsNeverRun) {
  hf::test::TempDir t;
  const auto marker = t / "constructor_ran";
  ::setenv("HF_CTOR_MARKER", marker.c_str(), 1);
  ComponentRegistry reg;
  EXPECT_EQ(load_error("fixture_constructor_no_entry", reg),
            fixture("fixture_constructor_no_entry").string() +
                ": not a HazardForge plugin: entry symbol 'hazardforge_plugin_entry' not found");
  ::unsetenv("HF_CTOR_MARKER");
  EXPECT_FALSE(std::filesystem::exists(marker));
}

TEST(Loader, FilesThatAreNotElfLibrariesAreRefusedUnread) {
  hf::test::TempDir t;
  std::ofstream(t / "libtext.so") << "#!/bin/sh\necho hi\n";
  ComponentRegistry reg;
  PluginLoader loader(reg);
  try {
    loader.load(t / "libtext.so");
    FAIL() << "loaded";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              (t / "libtext.so").string() + ": not a HazardForge plugin: not an ELF shared library");
  }
  // A cut-off ELF header: the reader stops at the end of the data.
  const std::string elf_start(
      "\x7f"
      "ELF\x02\x01\x01",
      7);
  EXPECT_THROW(elf_exports_symbol(elf_start, "x", "cut.so"), Error);
}

TEST(Loader, UnresolvedSymbolShowsDlerrorVerbatim) {
  ComponentRegistry reg;
  const std::string path = fixture("fixture_unresolved").string();
  EXPECT_EQ(load_error("fixture_unresolved", reg),
            "cannot load plugin " + path + ": " + path + ": undefined symbol: hf_fixture_symbol_nobody_defines");
}

TEST(Loader, ThrowingRegisterRegistersNothing) {
  ComponentRegistry reg;
  EXPECT_EQ(load_error("fixture_throwing", reg),
            fixture("fixture_throwing").string() + ": plugin 'throwing' failed to register: model zoo unreachable");
  EXPECT_TRUE(reg.all().empty());
}

TEST(Loader, DuplicateStageNamesBothLibraries) {
  ComponentRegistry reg;
  PluginLoader loader(reg);
  loader.load(fixture("fixture_good_a"));
  try {
    loader.load(fixture("fixture_good_b"));
    FAIL() << "expected a refusal";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "duplicate detector 'dup_detector': registered by " +
                                         fixture("fixture_good_a").string() + " and by " +
                                         fixture("fixture_good_b").string());
  }
  EXPECT_EQ(reg.all().size(), 1u);
  EXPECT_EQ(loader.plugins().size(), 1u);
}

TEST(Loader, MissingLibraryFile) {
  ComponentRegistry reg;
  PluginLoader loader(reg);
  try {
    loader.load("/nonexistent/libnothing.so");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "/nonexistent/libnothing.so: plugin library not found");
  }
}

TEST(Loader, LoadDirCollectsEveryRefusalAndKeepsGoing) {
  ComponentRegistry reg;
  PluginLoader loader(reg);
  std::vector<std::string> errors;
  for (const char* d : {"fixture_good_a", "fixture_bad_tag", "fixture_throwing"})
    loader.load_dir(std::filesystem::path(HF_FIXTURE_DIR) / d, errors);
  EXPECT_EQ(errors.size(), 2u);
  EXPECT_EQ(loader.plugins().size(), 1u);
}

TEST(Loader, SearchPathOrder) {
  setenv("HAZARDFORGE_PLUGIN_PATH", "/env/a:/env/b", 1);
  auto p = plugin_search_path({"/cli"}, {"/cfg"});
  unsetenv("HAZARDFORGE_PLUGIN_PATH");
  ASSERT_GE(p.size(), 5u);
  EXPECT_EQ(p[0], "/cli");
  EXPECT_EQ(p[1], "/env/a");
  EXPECT_EQ(p[2], "/env/b");
  EXPECT_EQ(p[3], "/cfg");
  EXPECT_EQ(p[4], (executable_dir() / ".." / "lib" / "hazardforge" / "plugins").lexically_normal());
}

}  // namespace
}  // namespace hf::core
