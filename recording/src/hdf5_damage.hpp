// The damage checks of run.h5 made before libhdf5 reads what they guard: the global heap of a
// format 1 file (hdf5_global_heap.hpp), each linked object's header (hdf5_metadata.hpp), and the
// sample chunks a truncated file still holds. Internal to stend_recording.
#pragma once

#include "hdf5_common.hpp"
#include "hdf5_metadata.hpp"

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>

namespace stend::detail {

// What Stend reads from the file may be damaged: before any variable-length value is read (format
// 1's string attributes live in the global heap), the file's global heap collections are walked
// once (hdf5_global_heap.hpp); a damaged one is an error, never a read that loops for ever.
class GlobalHeapGuard {
 public:
  GlobalHeapGuard(std::filesystem::path file, hid_t h5) : file_(std::move(file)), h5_(h5) {}
  // Empty, or what is damaged ("FILE: the global heap collection at byte N … is damaged: …").
  const std::string& damage();
  // Throws InputError with the damage, if any.
  void check();

 private:
  // Whether byte `at` lies inside a chunk of one of the file's datasets (recorded samples that
  // happen to spell "GCOL"); asked only about collections that fail the walk.
  bool inside_a_chunk(std::uint64_t at) const;

  std::filesystem::path file_;
  hid_t h5_;
  bool checked_ = false;
  std::string damage_;
};

// Index of the first chunk of `ds` that does not lie whole inside the file of `file_size` bytes
// (chunks are appended in address order), `chunks` when every one does.
hsize_t first_missing_chunk(hid_t ds, hsize_t chunks, std::uint64_t file_size);

// Every object linked from the root, recursively, checked before libhdf5 loads its header: the
// link visit hands each link to the callback before it loads the object the link points to, and
// stops when the callback does. Empty, or what is wrong.
std::string check_linked_headers(hid_t root, Hdf5HeaderCheck& headers);

}  // namespace stend::detail
