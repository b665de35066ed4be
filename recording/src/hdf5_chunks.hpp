// Whole chunks of a run.h5 sample column encoded by Stend as the dataset's own filter pipeline
// encodes them (shuffle, deflate, Fletcher-32: docs/recording-format.md) and written with
// H5Dwrite_chunk. Any HDF5 reader decodes them as chunks libhdf5 wrote; the deflate is libdeflate's
// (about 2.4× zlib's speed at level 1, and smaller), the longest step of an import. Read back the
// same way: a whole chunk read as stored (H5Dread_chunk) and decoded here — inflate by libdeflate,
// about 3× zlib's — outside the library's lock. Internal to stend_recording.
#pragma once

#include "hdf5_common.hpp"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <vector>

namespace stend::detail {

// HDF5's Fletcher-32 of a chunk's bytes (big-endian 16-bit words; an odd last byte is the high
// half of a word), as its fletcher32 filter appends it.
std::uint32_t hdf5_fletcher32(const unsigned char* bytes, std::size_t size);

// How a dataset's chunks are laid out and filtered, when decode_chunk can decode them: a 1-D dataset,
// or a 2-D one chunked by whole rows, stored in the type it is read as, through shuffle, deflate
// and Fletcher-32 or a part of them, in that order (as create_dataset sets them).
struct ChunkLayout {
  hsize_t rows = 0;             // rows per chunk
  std::size_t row_bytes = 0;    // bytes of one row
  std::size_t value_bytes = 0;  // bytes of one value (the shuffle's unit)
  bool shuffle = false, deflate = false, fletcher32 = false;
};
std::optional<ChunkLayout> decodable_layout(hid_t ds, hid_t mem_type);

// Chunk k of `ds` (layout.rows rows) decoded into out. False, with out undefined, when the chunk is
// not written, was stored with a filter skipped, or its checksum or stream does not hold: libhdf5
// then reads it, and says what is damaged. Takes the library lock to read the stored bytes only.
bool decode_chunk(hid_t ds, const ChunkLayout& layout, std::uint64_t k, unsigned char* out);

// One column of a write: rows of the 1-D dataset `ds` from `data` (of `mem_type`).
struct ChunkColumn {
  hid_t ds = -1;
  hid_t mem_type = -1;
  const void* data = nullptr;
  const char* name = "";  // the dataset's name, for errors
};

class ChunkWriter {
 public:
  ChunkWriter();
  ~ChunkWriter();
  ChunkWriter(const ChunkWriter&) = delete;
  ChunkWriter& operator=(const ChunkWriter&) = delete;

  // Rows [at, at + rows) of each column, extending its dataset to at + rows, as write_rows does.
  // Rows that start a chunk — a whole one, or the first rows of one the dataset does not reach yet —
  // of a type stored as given (or int32 counts stored as int16) through a pipeline of shuffle,
  // deflate and Fletcher-32 or a part of it, are encoded here, the columns shared between this
  // thread and one more where the machine has a second core (deflate is an import's longest step);
  // any other write goes through libhdf5. The datasets are written in the order given.
  void write(std::span<const ChunkColumn> columns, hsize_t at, hsize_t rows, const std::filesystem::path& file);

 private:
  class Encoder;
  std::unique_ptr<Encoder> here_, beside_;            // one per encoding thread: a compressor, its buffers
  std::vector<std::vector<unsigned char>> encoded_;  // each column's chunk as stored
};
}  // namespace stend::detail
