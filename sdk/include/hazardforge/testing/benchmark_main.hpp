// main() for Google Benchmark programs that time stages: the host's allocator policy first, so that the
// numbers are the ones the host would see. Use HF_BENCHMARK_MAIN() instead of BENCHMARK_MAIN().
#pragma once

#include <benchmark/benchmark.h>

#include "hazardforge/process_memory.hpp"

#define HF_BENCHMARK_MAIN()                                           \
  int main(int argc, char** argv) {                                   \
    hf::keep_freed_memory_for_reuse();                                \
    benchmark::Initialize(&argc, argv);                               \
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1; \
    benchmark::RunSpecifiedBenchmarks();                              \
    benchmark::Shutdown();                                            \
    return 0;                                                         \
  }                                                                   \
  static_assert(true, "")
