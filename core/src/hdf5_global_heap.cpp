// Global heap collections checked before libhdf5 reads them (why: hdf5_global_heap.hpp).
//
// HDF5 file format, "Global Heap": a collection is the signature "GCOL", version 1, 3 reserved
// bytes and the collection's size in bytes (a "length": the superblock's size of lengths, 8 in
// every file Stend writes), then objects, each: heap index (2 bytes; 0 is the free space),
// reference count (2), 4 reserved, size (a length), and the object's data padded to 8 bytes. The
// free-space object's size includes its header and is not padded. A tail shorter than an object
// header is free space.
#include "hdf5_global_heap.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>
#include <optional>
#include <string_view>
#include <vector>

namespace stend::detail {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kSignature = "GCOL";
constexpr std::uint64_t kAlignment = 8;

std::uint64_t little_endian(const unsigned char* p, unsigned bytes) {
  std::uint64_t v = 0;
  for (unsigned i = bytes; i-- > 0;) v = (v << 8) | p[i];
  return v;
}

class FileBytes {
 public:
  explicit FileBytes(const fs::path& file) : in_(file, std::ios::binary), size_(fs::file_size(file)) {}
  std::uint64_t size() const { return size_; }
  // `bytes` bytes at `offset`, nullopt when they are not all inside the file.
  std::optional<std::vector<unsigned char>> read(std::uint64_t offset, std::uint64_t bytes) {
    if (offset > size_ || bytes > size_ - offset) return std::nullopt;
    std::vector<unsigned char> out(bytes);
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(offset));
    in_.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(bytes));
    if (static_cast<std::uint64_t>(in_.gcount()) != bytes) return std::nullopt;
    return out;
  }

 private:
  std::ifstream in_;
  std::uint64_t size_;
};

// The superblock's size of lengths; where libhdf5 looks for it: byte 0, then 512, 1024, 2048, …
// 0 when there is no superblock (libhdf5 would not have opened the file).
unsigned size_of_lengths(FileBytes& f) {
  static constexpr std::array<unsigned char, 8> kHdf5Signature = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
  for (std::uint64_t at = 0; at < f.size(); at = at ? at * 2 : 512) {
    const auto b = f.read(at, 16);
    if (!b || !std::equal(kHdf5Signature.begin(), kHdf5Signature.end(), b->begin())) continue;
    const unsigned version = (*b)[8];
    return version <= 1 ? (*b)[14] : (*b)[10];  // versions 0, 1: byte 14; 2, 3: byte 10
  }
  return 0;
}

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
  const unsigned length_bytes = size_of_lengths(f);
  if (length_bytes != 2 && length_bytes != 4 && length_bytes != 8) return {};  // libhdf5 refuses those
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
