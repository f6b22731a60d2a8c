// Fuzzes the YAML graph loader and validator: any bytes give a graph or hf::Error, never a crash or a hang.
#include <cstdint>

#include "fuzz_input_file.hpp"
#include "hazardforge/core/graph.hpp"
#include "hazardforge/json_text.hpp"
#include "test_stages.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static hf::ComponentRegistry* registry = [] {
    auto* r = new hf::ComponentRegistry();
    hf::test::register_test_stages(*r);
    return r;
  }();
  const auto file = hf::fuzz::write_input(data, size, "graph.yaml");
  try {
    hf::core::GraphConfig cfg = hf::core::load_graph_config(file);
    hf::core::Graph g = hf::core::build_graph(cfg, *registry);
    (void)g.to_dot();
    (void)hf::json_text(g.resolved());
  } catch (const hf::Error&) {
  }
  return 0;
}
