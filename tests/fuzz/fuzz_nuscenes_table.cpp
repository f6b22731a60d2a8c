// Fuzzes loading a nuScenes table and reading every typed field of every record the way the source does.
#include <cstdint>

#include "fuzz_input_file.hpp"
#include "nuscenes_tables.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using hf::source::nuscenes::Table;
  const auto file = hf::fuzz::write_input(data, size, "table.json");
  try {
    const Table t = Table::load(file);
    for (const hf::Json& rec : t.records()) {
      auto guarded = [](auto&& f) {
        try {
          f();
        } catch (const hf::Error&) {
        }
      };
      guarded([&] { (void)t.str(rec, "token"); });
      guarded([&] { (void)t.at(t.str(rec, "next"), "fuzz"); });
      guarded([&] { (void)t.i64(rec, "timestamp"); });
      guarded([&] { (void)t.num(rec, "width"); });
      guarded([&] { (void)t.boolean(rec, "is_key_frame"); });
      guarded([&] { (void)t.nums(rec, "translation", 3); });
      guarded([&] { (void)t.rotation(rec, "rotation"); });
    }
  } catch (const hf::Error&) {
  }
  return 0;
}
