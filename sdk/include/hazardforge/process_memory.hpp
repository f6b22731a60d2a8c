// Process-wide memory policy for programs that push frames through stages (the host, the benchmarks).
#pragma once

#include "hazardforge/abi.hpp"

HF_SDK_BEGIN
namespace hf {

// Stages allocate and free frame-sized buffers (a 1600x900 BGR picture is 4.3 MB) on every frame. glibc
// maps large allocations afresh and unmaps them on free, and gives the freed top of its heaps back to the
// system, so every frame faults its buffers' pages in again (40 % of the realism measurement of a car 8 m
// ahead, docs/performance.md). After this call allocations up to 64 MiB come from the heap, and up to 256 MiB
// of freed memory stays there for reuse. Call it once, at the start of main(), before threads start. Without
// glibc it does nothing.
void keep_freed_memory_for_reuse();

}  // namespace hf
HF_SDK_END
