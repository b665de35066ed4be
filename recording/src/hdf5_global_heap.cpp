// Global heap collections checked before libhdf5 reads them (why: hdf5_global_heap.hpp).
//
// HDF5 file format, "Global Heap": a collection is the signature "GCOL", version 1, 3 reserved
// bytes and the collection's size in bytes (a "length": the superblock's size of lengths, 8 in
// every file Stend writes), then objects, each: heap index (2 bytes; 0 is the free space),
// reference count (2), 4 reserved, size (a length), and the object's data padded to 8 bytes. The
// free-space object's size includes its header and is not padded. A tail shorter than an object
// header is free space.
#include "hdf5_global_heap.hpp"

#include "hdf5_file_bytes.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <string_view>
#include <vector>

namespace stend::detail {
namespace {

namespace fs = std::filesystem;
using hdf5::FileBytes;
using hdf5::little_endian;

constexpr std::string_view kSignature = "GCOL";
constexpr std::uint64_t kAlignment = 8;

// Byte offsets of every "GCOL" in the file, read sequentially in blocks.
std::vector<std::uint64_t> signature_offsets(const fs::path& file) {
  constexpr std::size_t kBlock = std::size_t{1} << 20;
  std::ifstream in(file, std::ios::binary);
  std::vector<char> buf(kBlock + kSignature.size() - 1);
  std::vector<std::uint64_t> out;
  std::size_t carry = 0;        // bytes kept from the previous block (a signature cut in two)
  std::uint64_t buf_start = 0;  // file offset of buf[0]
  while (in) {
    in.read(buf.data() + carry, static_cast<std::streamsize>(kBlock));
    const std::size_t have = carry + static_cast<std::size_t>(in.gcount());
    if (have < kSignature.size()) break;
    const std::string_view view(buf.data(), have);
    for (std::size_t at = view.find(kSignature); at != std::string_view::npos; at = view.find(kSignature, at + 1))
      out.push_back(buf_start + at);
    carry = kSignature.size() - 1;
    std::memmove(buf.data(), buf.data() + have - carry, carry);
    buf_start += have - carry;
  }
  return out;
}

// Empty when libhdf5's walk of the collection at `at` ends exactly at its end with every object
// inside it, else what is wrong. Collections of another version are refused by libhdf5 itself.
std::string collection_damage(FileBytes& f, std::uint64_t at, unsigned length_bytes) {
  const std::uint64_t header = 8 + length_bytes;      // signature, version, reserved, size
  const std::uint64_t object_header = 8 + length_bytes;  // index, refcount, reserved, size
  const auto head = f.read(at, header);
  if (!head || (*head)[4] != 1) return {};
  const std::uint64_t size = little_endian(head->data() + 8, length_bytes);
  if (size < header || size > f.size() - at)
    return fmt::format("declares {} bytes, {} remain in the file", size, f.size() - at);
  const auto c = f.read(at, size);
  if (!c) return "cannot be read";
  std::uint64_t p = header;
  while (p < size) {
    const std::uint64_t left = size - p;
    if (left < object_header) break;  // a tail too small for an object header: free space
    const unsigned index = static_cast<unsigned>(little_endian(c->data() + p, 2));
    const std::uint64_t object_size = little_endian(c->data() + p + 8, length_bytes);
    std::uint64_t need = 0;
    if (index == 0) {
      need = object_size;  // free space, its header included
      if (need < object_header || need > left)
        return fmt::format("its free-space object at byte {} declares {} bytes, {} remain in the collection",
                           at + p, object_size, left);
    } else {
      if (object_size > left - object_header)
        return fmt::format("object {} at byte {} declares {} bytes, {} remain in the collection", index, at + p,
                           object_size, left - object_header);
      need = std::min(left, object_header + (object_size + kAlignment - 1) / kAlignment * kAlignment);
    }
    p += need;
  }
  return {};
}

}  // namespace

std::string global_heap_damage(const fs::path& file, const IsChunkData& is_chunk_data) {
  FileBytes f(file);
  const auto superblock = hdf5::find_superblock(f);
  if (!superblock) return {};  // libhdf5 refuses the file itself
  const unsigned length_bytes = superblock->size_of_lengths;
  for (const std::uint64_t at : signature_offsets(file)) {
    const std::string what = collection_damage(f, at, length_bytes);
    if (!what.empty() && !(is_chunk_data && is_chunk_data(at)))
      return fmt::format("the global heap collection at byte {} (where format 1 keeps its string attributes) "
                         "is damaged: {}",
                         at, what);
  }
  return {};
}

}  // namespace stend::detail
