// stend/core/memory.hpp: prefault leaves a buffer's pages resident (mincore) and its bytes as they
// were; keep_freed_memory lets a freed large block be handed out again in place of a fresh mapping.
#include "stend/core/memory.hpp"

#include <gtest/gtest.h>

#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace stend {
namespace {

// Pages of [p, p + bytes) resident in memory.
std::size_t resident_pages(void* p, std::size_t bytes) {
  const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  std::vector<unsigned char> in((bytes + page - 1) / page);
  if (mincore(p, bytes, in.data()) != 0) return 0;
  std::size_t n = 0;
  for (unsigned char c : in) n += c & 1u;
  return n;
}

TEST(Memory, PrefaultMakesEveryPageResidentAndKeepsTheBytes) {
  const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  const std::size_t bytes = 256 * page;
  void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(p, MAP_FAILED);
  auto* b = static_cast<unsigned char*>(p);
  b[0] = 7;  // one page touched before
  ASSERT_EQ(resident_pages(p, bytes), 1u);
  if (madvise(p, page, MADV_POPULATE_WRITE) != 0 && errno == EINVAL) {
    munmap(p, bytes);
    GTEST_SKIP() << "this kernel has no MADV_POPULATE_WRITE (Linux < 5.14): prefault does nothing here";
  }
  prefault(p, bytes);
  EXPECT_EQ(resident_pages(p, bytes), 256u);
  EXPECT_EQ(b[0], 7);
  for (std::size_t i = 1; i < bytes; i += page / 2) ASSERT_EQ(b[i], 0) << i;
  munmap(p, bytes);
}

TEST(Memory, PrefaultOfLessThanAPageOrNothingIsHarmless) {
  std::vector<unsigned char> small(100, 3);
  prefault(small.data(), small.size());
  prefault(nullptr, 0);
  for (unsigned char c : small) EXPECT_EQ(c, 3);
}

TEST(Memory, AFreedLargeBlockIsReusedNotUnmapped) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's allocator holds freed blocks back on purpose";
#endif
  keep_freed_memory();
  const std::size_t bytes = std::size_t{4} << 20;  // above glibc's default 128 KiB threshold
  void* a = std::malloc(bytes);
  ASSERT_NE(a, nullptr);
  std::memset(a, 1, bytes);
  std::free(a);
  void* b = std::malloc(bytes);  // from the heap's free block: its pages already resident
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(a, b);
  std::free(b);
}

long minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt;
}

bool kernel_populates() {
  void* p = mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  const bool ok = p != MAP_FAILED && madvise(p, 4096, MADV_POPULATE_WRITE) == 0;
  if (p != MAP_FAILED) munmap(p, 4096);
  return ok;
}

TEST(Memory, AWarmedHeapServesTheNextAllocationsWithoutPageFaults) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's allocator does not reuse the warmed block";
#endif
  if (!kernel_populates()) GTEST_SKIP() << "this kernel has no MADV_POPULATE_WRITE (Linux < 5.14)";
  keep_freed_memory();
  const std::size_t bytes = std::size_t{8} << 20;
  warm_heap(bytes);
  const long before = minor_faults();
  std::vector<unsigned char*> blocks;
  for (int i = 0; i < 6; ++i) {  // 6 MiB in blocks of 1 MiB, each written whole
    blocks.push_back(static_cast<unsigned char*>(std::malloc(std::size_t{1} << 20)));
    ASSERT_NE(blocks.back(), nullptr);
    std::memset(blocks.back(), i + 1, std::size_t{1} << 20);
  }
  const long faults = minor_faults() - before;
  for (unsigned char* b : blocks) std::free(b);
  EXPECT_LT(faults, 64) << "about 1 536 without the warm-up";
}

}  // namespace
}  // namespace stend
