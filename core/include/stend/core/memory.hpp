#pragma once
// How a short command takes its memory from the kernel. Each 4 KiB page a process first touches
// costs a page fault (on the project's VM ~2–4 µs, a tenth of a calibration's 45 ms in ~4 000 of
// them), so a buffer about to be written whole is faulted in by one call, and freed buffers stay
// in the process for the next instead of going back to the kernel.
#include <cstddef>

namespace stend {

// Faults in the pages wholly inside [data, data + bytes) by one call (madvise
// MADV_POPULATE_WRITE, Linux ≥ 5.14); a no-op where the kernel cannot.
void prefault(void* data, std::size_t bytes);

// Makes the next `bytes` of heap allocations free of page faults: a block of that size taken,
// prefaulted and given back to the heap (where keep_freed_memory keeps it) for them to reuse.
void warm_heap(std::size_t bytes);

// Keeps freed blocks of up to 32 MiB in the process for reuse (glibc: mallopt M_MMAP_THRESHOLD,
// M_TRIM_THRESHOLD) instead of returning each block ≥ 128 KiB to the kernel at once.
void keep_freed_memory();

}  // namespace stend
