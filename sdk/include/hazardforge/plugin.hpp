// The plugin entry point: one exported C symbol returning a plain descriptor the host checks before anything else.
//
//   HAZARDFORGE_PLUGIN("my_plugin", "1.0.0", "MIT", "What it adds") {
//     reg.add<MyDetector>();
//   }
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <type_traits>

#include "hazardforge/abi.hpp"
#include "hazardforge/stage.hpp"

extern "C" {

// Plain C so the host can read it without trusting anything C++ about the library.
struct hf_plugin_descriptor {
  uint32_t struct_size;  // sizeof(hf_plugin_descriptor) as the plugin saw it
  uint32_t abi_major;
  uint32_t abi_minor;
  const char* abi_tag;  // HF_ABI_TAG as the plugin was compiled
  const char* name;
  const char* version;
  const char* license;
  const char* description;
  // Called only after the handshake passed. Returns 0 on success; otherwise writes a message into `err`.
  int (*register_components)(void* registrar, char* err, size_t err_len);
};

typedef const struct hf_plugin_descriptor* (*hf_plugin_entry_fn)(void);
}

#define HF_PLUGIN_ENTRY_SYMBOL "hazardforge_plugin_entry"

HF_SDK_BEGIN
namespace hf {

using ComponentMaker = std::unique_ptr<Component> (*)();

// Receives the components a plugin offers. Implemented by the host (and by the test harness).
class Registrar {
 public:
  virtual ~Registrar();
  virtual void add_component(ComponentInfo info, ComponentMaker make) = 0;

  // T provides `static hf::ComponentInfo describe()` and a default constructor.
  template <class T>
  void add() {
    static_assert(std::is_base_of_v<Component, T>, "registered types derive from hf::Component");
    ComponentInfo info = T::describe();
    info.is_stage = std::is_base_of_v<Stage, T>;
    info.is_source = std::is_base_of_v<SourceStage, T>;
    add_component(std::move(info), []() -> std::unique_ptr<Component> { return std::make_unique<T>(); });
  }
};

namespace detail {
inline int run_register(void (*fn)(Registrar&), void* reg, char* err, size_t err_len) {
  auto write = [&](const char* msg) {
    if (err && err_len > 0) {
      std::strncpy(err, msg, err_len - 1);
      err[err_len - 1] = '\0';
    }
  };
  try {
    fn(*static_cast<Registrar*>(reg));
    return 0;
  } catch (const std::exception& e) {
    write(e.what());
  } catch (...) {
    write("unknown exception");
  }
  return 1;
}
}  // namespace detail
}  // namespace hf
HF_SDK_END

#define HAZARDFORGE_PLUGIN(NAME, VERSION, LICENSE, DESCRIPTION)                                          \
  static void hf_plugin_register_(::hf::Registrar& reg);                                                  \
  static int hf_plugin_register_c_(void* r, char* err, size_t n) {                                        \
    return ::hf::detail::run_register(&hf_plugin_register_, r, err, n);                                   \
  }                                                                                                       \
  extern "C" HF_EXPORT const hf_plugin_descriptor* hazardforge_plugin_entry(void) {                       \
    static const hf_plugin_descriptor d = {sizeof(hf_plugin_descriptor), HF_SDK_ABI_MAJOR, HF_SDK_ABI_MINOR, \
                                           HF_ABI_TAG, NAME, VERSION, LICENSE, DESCRIPTION,               \
                                           &hf_plugin_register_c_};                                       \
    return &d;                                                                                            \
  }                                                                                                       \
  static void hf_plugin_register_(::hf::Registrar& reg)
