// An HDF5 file's object headers, checked before libhdf5 reads them.
//
// libhdf5 1.10 (Debian 12's 1.10.8) decodes metadata without bounds checks in many places, and
// fuzzing run.h5 found it crashing on damaged files: a buffer of the size a continuation message
// declared (malloc(2^64 − 1)), a use after free decoding an attribute message, an object header
// lost (leaked) when its chunk failed to load. Its defence against damage is the checksum that
// HDF5 ≥ 1.8's file format puts on every metadata block (superblock versions 2 and 3, version 2
// object headers "OHDR"/"OCHK", v2 B-trees, fractal heaps and their direct blocks, extensible and
// fixed arrays): damaged bytes fail their checksum before they are decoded. Stend's writer has
// always written that format (SWMR requires it). So Stend reads run stores in that format only:
//   - the superblock must be version 2 or 3 (versions 0 and 1, HDF5 1.6's layout — what
//     `h5repack` writes without `-L` — keep object headers, B-trees and heaps without checksums);
//   - every object header libhdf5 will load (the superblock extension's, the root group's, then
//     each linked object's, checked as the links are visited, before libhdf5 loads it) must be a
//     version 2 header whose chunks lie inside the file and match their checksums. libhdf5 would
//     take a header whose "OHDR" signature is damaged for an unchecked version 1 header, and it
//     allocates a chunk's declared size before it checks it against the end of the file.
// Format 1's global heap (variable-length strings, no checksum) is walked separately
// (hdf5_global_heap.hpp). Internal to stend_recording (hdf5_reader.cpp).
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

namespace stend::detail {

class Hdf5HeaderCheck {
 public:
  explicit Hdf5HeaderCheck(const std::filesystem::path& file);
  ~Hdf5HeaderCheck();
  Hdf5HeaderCheck(const Hdf5HeaderCheck&) = delete;
  Hdf5HeaderCheck& operator=(const Hdf5HeaderCheck&) = delete;

  // Before H5Fopen: the superblock and the object headers libhdf5 loads to open the file. Empty,
  // or what is wrong ("the object header at byte N: …").
  std::string at_open();
  // Before libhdf5 loads the object header at `address` (relative to the base address, as
  // H5L_info_t gives it). Empty, or what is wrong.
  std::string object(std::uint64_t address);
  // The object a hard link points to, before libhdf5 loads it: object(), and not one already
  // reached (the root group, or an earlier link's target). Stend's run stores link each object
  // once; a damaged link back to a group above it made libhdf5's link visit, which tracks only
  // objects of more than one link, recurse until the stack overflowed.
  std::string linked_object(std::uint64_t address);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace stend::detail
