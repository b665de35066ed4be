// Whole chunks of a run.h5 sample column encoded by Stend as the dataset's own filter pipeline
// encodes them (shuffle, deflate, Fletcher-32: docs/recording-format.md) and written with
// H5Dwrite_chunk. Any HDF5 reader decodes them as chunks libhdf5 wrote; the deflate is libdeflate's
// (about 2.4× zlib's speed at level 1, and smaller), the longest step of an import. Internal to
// stend_recording.
#pragma once

#include "hdf5_common.hpp"

#include <cstdint>
#include <filesystem>
#include <vector>

struct libdeflate_compressor;

namespace stend::detail {

// HDF5's Fletcher-32 of a chunk's bytes (big-endian 16-bit words; an odd last byte is the high
// half of a word), as its fletcher32 filter appends it.
std::uint32_t hdf5_fletcher32(const unsigned char* bytes, std::size_t size);

class ChunkWriter {
 public:
  ChunkWriter();
  ~ChunkWriter();
  ChunkWriter(const ChunkWriter&) = delete;
  ChunkWriter& operator=(const ChunkWriter&) = delete;

  // Rows [at, at + rows) of the 1-D dataset `ds` from `data` (of `mem_type`), extending it to
  // at + rows, as write_rows does. Rows that start a chunk — a whole one, or the first rows of one
  // the dataset does not reach yet — of a type stored as given (or int32 counts stored as int16)
  // through a pipeline of shuffle, deflate and Fletcher-32 or a part of it, are encoded here; any
  // other write goes through libhdf5.
  void write(hid_t ds, hid_t mem_type, hsize_t at, hsize_t rows, const void* data,
             const std::filesystem::path& file, const char* name);

 private:
  bool encode(hid_t ds, hid_t mem_type, hsize_t at, hsize_t rows, const void* data);

  libdeflate_compressor* deflate_ = nullptr;
  std::vector<unsigned char> stored_, shuffled_, encoded_;
};

}  // namespace stend::detail
