// See stend/core/memory.hpp.
#include "stend/core/memory.hpp"

#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>

namespace stend {

void prefault(void* data, std::size_t bytes) {
#ifdef MADV_POPULATE_WRITE
  static const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t lo = (begin + page - 1) & ~(page - 1), hi = (begin + bytes) & ~(page - 1);
  if (hi > lo) (void)madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_POPULATE_WRITE);  // EINVAL before 5.14
#else
  (void)data;
  (void)bytes;
#endif
}

void warm_heap(std::size_t bytes) {
  void* block = std::malloc(bytes);
  if (block == nullptr) return;
  prefault(block, bytes);
  std::free(block);
}

void keep_freed_memory() {
  constexpr int kKeptBytes = 32 << 20;
  mallopt(M_MMAP_THRESHOLD, kKeptBytes);
  mallopt(M_TRIM_THRESHOLD, 2 * kKeptBytes);
}

}  // namespace stend
