// The allocator policy of frame-processing programs.
#include "hazardforge/process_memory.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace hf {

void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
#endif
}

}  // namespace hf
