// The allocator policy: freed frame-sized buffers are reused, not returned and faulted in again.
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <cstdlib>
#include <cstring>
#include <vector>

#include "hazardforge/process_memory.hpp"

// GCC says it builds with AddressSanitizer by __SANITIZE_ADDRESS__, clang by __has_feature.
#if defined(__SANITIZE_ADDRESS__)
#define HF_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define HF_TEST_ASAN 1
#endif
#endif

namespace hf {
namespace {

[[maybe_unused]] long minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt;
}

// Page faults of `rounds` cycles of what a stage does on a frame: 16 work buffers of 2 MiB (a 1600x900
// picture's planes and masks) allocated, written and all freed at the end; -1 when malloc fails.
[[maybe_unused]] long faults_of_cycles(int rounds) {
  const size_t bytes = 2u << 20;
  const long before = minor_faults();
  for (int i = 0; i < rounds; ++i) {
    std::vector<char*> v;
    for (int k = 0; k < 16; ++k) {
      auto* p = static_cast<char*>(std::malloc(bytes));
      if (!p) return -1;
      std::memset(p, i + k, bytes);
      v.push_back(p);
    }
    volatile char sink = v.back()[bytes / 2];  // keep the writes
    (void)sink;
    for (char* p : v) std::free(p);
  }
  return minor_faults() - before;
}

TEST(ProcessMemory, FreedFrameBuffersAreReusedWithoutFaultingTheirPagesInAgain) {
#if defined(HF_TEST_ASAN)
  GTEST_SKIP() << "the sanitizer's allocator is not glibc's";
#elif !defined(__GLIBC__)
  GTEST_SKIP() << "the policy is glibc's";
#else
  keep_freed_memory_for_reuse();
  faults_of_cycles(1);  // the heap grows once
  const long pages = static_cast<long>((32u << 20) / 4096);
  // Twenty more cycles fault in less than one cycle's pages (without the policy glibc returns the freed top
  // of the heap on every cycle: ~20 cycles' worth).
  const long faults = faults_of_cycles(20);
  EXPECT_GE(faults, 0) << "malloc failed";
  EXPECT_LT(faults, pages);
#endif
}

}  // namespace
}  // namespace hf
