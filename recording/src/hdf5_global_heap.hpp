// The global heap collections of an HDF5 file, checked before libhdf5 reads them.
//
// run.h5 of format 1 keeps its string attributes variable-length, i.e. in global heap collections
// ("GCOL"). libhdf5 1.10 walks a collection's objects without checking that each one advances and
// stays inside the collection (H5HG__cache_heap_deserialize): a free-space object of size 0 makes
// it loop for ever, a size past the end reads past its buffer. Stend therefore walks every
// collection of such a file itself, with bounds checks, before it reads a variable-length value.
// Internal to stend_recording (hdf5_reader.cpp); layout in docs/recording-format.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

namespace stend::detail {

// Whether the byte range [offset, offset + bytes) of the file is a dataset chunk (data, not
// metadata): "GCOL" found by chance inside recorded samples is not a collection.
using IsChunkData = std::function<bool(std::uint64_t offset)>;

// Empty when every global heap collection in `file` is one libhdf5 can walk safely (or there is
// none), else what is damaged: "the global heap collection at byte N …". Reads the whole file once
// (sequentially); `is_chunk_data` is asked only about collections that fail the walk.
std::string global_heap_damage(const std::filesystem::path& file, const IsChunkData& is_chunk_data);

}  // namespace stend::detail
