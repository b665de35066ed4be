// Reading an HDF5 file's own bytes, for the checks Stend makes before libhdf5 reads a file
// (hdf5_global_heap.hpp, hdf5_metadata.hpp). Internal to stend_recording.
//
// HDF5 file format specification 3.0, "Superblock": the signature is looked for at byte 0, then
// 512, 1024, 2048, …; versions 0 and 1 hold the sizes of offsets and lengths at bytes 13 and 14;
// versions 2 and 3 hold them at bytes 9 and 10, then (from byte 12) the base address, the
// superblock extension's address, the end-of-file address and the root group's object header
// address, and a checksum. Addresses are relative to the base address; "undefined" is all bits
// set.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <vector>

namespace stend::detail::hdf5 {

inline std::uint64_t little_endian(const unsigned char* p, unsigned bytes) {
  std::uint64_t v = 0;
  for (unsigned i = bytes; i-- > 0;) v = (v << 8) | p[i];
  return v;
}

class FileBytes {
 public:
  explicit FileBytes(const std::filesystem::path& file)
      : in_(file, std::ios::binary), size_(std::filesystem::file_size(file)) {}
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

inline constexpr std::uint64_t kUndefinedAddress = ~std::uint64_t{0};

struct Superblock {
  std::uint64_t at = 0;  // byte offset of the signature
  unsigned version = 0;
  unsigned size_of_offsets = 0, size_of_lengths = 0;
  // Versions 2 and 3 only (what the object header check reads; 0 and 1 are refused before):
  std::uint64_t base = 0;                         // base address (absolute)
  std::uint64_t extension = kUndefinedAddress;    // the superblock extension's object header
  std::uint64_t end_of_file = kUndefinedAddress;  // end-of-file address (of what was allocated)
  std::uint64_t root_header = kUndefinedAddress;  // the root group's object header
  // File consistency flags (byte 11): a writer has the file open, or was killed with it open
  // (bit 0: write access, bit 2: SWMR writing); its metadata may be read mid-update.
  bool open_for_writing = false;
};

// An address of `size` bytes at p (all bits set: undefined).
inline std::uint64_t address(const unsigned char* p, unsigned size) {
  const std::uint64_t v = little_endian(p, size);
  return size < 8 && v == (std::uint64_t{1} << (8 * size)) - 1 ? kUndefinedAddress : v;
}

// The superblock where libhdf5 looks for it; nullopt when there is none it could read (libhdf5
// then refuses the file itself) or its sizes are not ones libhdf5 accepts.
inline std::optional<Superblock> find_superblock(FileBytes& f) {
  static constexpr std::array<unsigned char, 8> kSignature = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
  for (std::uint64_t at = 0; at < f.size(); at = at ? at * 2 : 512) {
    const auto b = f.read(at, 16);
    if (!b || !std::equal(kSignature.begin(), kSignature.end(), b->begin())) continue;
    Superblock s;
    s.at = at;
    s.version = (*b)[8];
    const bool old = s.version <= 1;
    s.size_of_offsets = old ? (*b)[13] : (*b)[9];
    s.size_of_lengths = old ? (*b)[14] : (*b)[10];
    auto valid = [](unsigned n) { return n == 2 || n == 4 || n == 8; };
    if (s.version > 3 || !valid(s.size_of_offsets) || !valid(s.size_of_lengths)) return std::nullopt;
    if (!old) {
      const unsigned o = s.size_of_offsets;
      const auto v = f.read(at + 12, 4 * o);
      if (!v) return std::nullopt;
      s.base = little_endian(v->data(), o);
      s.extension = address(v->data() + o, o);
      s.end_of_file = address(v->data() + 2 * o, o);
      s.root_header = address(v->data() + 3 * o, o);
      s.open_for_writing = ((*b)[11] & 0x05) != 0;
    }
    return s;
  }
  return std::nullopt;
}

// Bob Jenkins' lookup3 hash (hashlittle, 2006, public domain) with initial value 0: the checksum of
// HDF5's version 2 metadata (object headers "OHDR" and "OCHK", fractal heaps, v2 B-trees, …),
// stored little-endian in the block's last 4 bytes over all bytes before them.
inline std::uint32_t lookup3(const unsigned char* k, std::size_t length) {
  auto rot = [](std::uint32_t x, int r) { return (x << r) | (x >> (32 - r)); };
  std::uint32_t a, b, c;
  a = b = c = 0xdeadbeefu + static_cast<std::uint32_t>(length);
  auto word = [&](std::size_t i, std::size_t n) {  // up to 4 bytes from k[i], little-endian
    std::uint32_t w = 0;
    for (std::size_t j = 0; j < n; ++j) w |= static_cast<std::uint32_t>(k[i + j]) << (8 * j);
    return w;
  };
  while (length > 12) {
    a += word(0, 4);
    b += word(4, 4);
    c += word(8, 4);
    a -= c; a ^= rot(c, 4); c += b;
    b -= a; b ^= rot(a, 6); a += c;
    c -= b; c ^= rot(b, 8); b += a;
    a -= c; a ^= rot(c, 16); c += b;
    b -= a; b ^= rot(a, 19); a += c;
    c -= b; c ^= rot(b, 4); b += a;
    length -= 12;
    k += 12;
  }
  if (length == 0) return c;
  a += word(0, std::min<std::size_t>(length, 4));
  if (length > 4) b += word(4, std::min<std::size_t>(length - 4, 4));
  if (length > 8) c += word(8, length - 8);
  c ^= b; c -= rot(b, 14);
  a ^= c; a -= rot(c, 11);
  b ^= a; b -= rot(a, 25);
  c ^= b; c -= rot(b, 16);
  a ^= c; a -= rot(c, 4);
  b ^= a; b -= rot(a, 14);
  c ^= b; c -= rot(b, 24);
  return c;
}

// Whether the last 4 bytes of `block` are the lookup3 checksum of the bytes before them.
inline bool checksum_matches(const std::vector<unsigned char>& block) {
  if (block.size() < 4) return false;
  return lookup3(block.data(), block.size() - 4) == little_endian(block.data() + block.size() - 4, 4);
}

}  // namespace stend::detail::hdf5
