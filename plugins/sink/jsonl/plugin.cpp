// Plugin entry: the JSON-lines / CSV sink.
#include "hazardforge/plugin.hpp"
#include "jsonl_sink.hpp"

HAZARDFORGE_PLUGIN("jsonl", "0.1.0", "Apache-2.0", "JSON lines per frame plus per-object and per-scene CSV") {
  reg.add<hf::sink::JsonlSink>();
}
