// Fuzzes the KITTI tracking label and calibration readers with the same bytes.
#include <cstdint>

#include "fuzz_input_file.hpp"
#include "hazardforge/error.hpp"
#include "kitti_files.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto file = hf::fuzz::write_input(data, size, "kitti.txt");
  try {
    (void)hf::source::kitti::read_labels(file);
  } catch (const hf::Error&) {
  }
  try {
    const auto c = hf::source::kitti::read_calibration(file);
    (void)c.cam0_to_cam2();
  } catch (const hf::Error&) {
  }
  return 0;
}
