// An HDF5 file's metadata checked before libhdf5 reads it (why: hdf5_metadata.hpp).
//
// HDF5 file format specification 3.0, the parts walked here:
//   Object header version 1: version 1, reserved, message count (2), reference count (4), size of
//     the first chunk (4), 4 bytes of padding; messages: type (2), size (2), flags (1), reserved
//     (3), data. A continuation chunk is messages only.
//   Object header version 2: "OHDR", version 2, flags (bit 5: four times, 16 bytes; bit 4: two
//     attribute limits, 4 bytes; bits 0–1: the first chunk's size takes 1, 2, 4 or 8 bytes), the
//     size; messages: type (1), size (2), flags (1), creation order (2, when flags bit 2); a
//     checksum (4, lookup3 of everything before it) after the chunk. A continuation chunk is
//     "OCHK", messages, checksum.
//   Messages followed: continuation (0x10: address, length), symbol table (0x11: v1 B-tree
//     address, local heap address), link (0x06: a hard link's object header address).
//   Local heap: "HEAP", version 0, 3 reserved, data segment size (a length), free list offset (a
//     length), data segment address.
//   v1 B-tree node of a group (type 0): "TREE", type, level, entries (2), left and right sibling
//     addresses, then key, child, key, …, key (keys are lengths); children are nodes one level
//     down, at level 0 symbol table nodes.
//   Symbol table node: "SNOD", version 1, reserved, symbol count (2), entries: link name offset,
//     object header address, cache type (4), reserved (4), scratch pad (16).
//   Driver information block (superblock versions 0, 1): version 0, 3 reserved, size (4), …
#include "hdf5_metadata.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cstring>
#include <deque>
#include <set>
#include <string_view>
#include <thread>
#include <vector>

#include "hdf5_file_bytes.hpp"

namespace stend::detail {
namespace {

namespace fs = std::filesystem;
using hdf5::FileBytes;
using hdf5::kUndefinedAddress;
using hdf5::little_endian;
using Bytes = std::vector<unsigned char>;

constexpr std::uint64_t kMaxBlocks = 1u << 16;  // blocks visited at most (a damaged file may loop)
constexpr int kChecksumAttempts = 3;             // reads of a chunk before a checksum mismatch is damage

bool starts_with(const Bytes& b, std::string_view signature) {
  return b.size() >= signature.size() && std::memcmp(b.data(), signature.data(), signature.size()) == 0;
}

class MetadataWalk {
 public:
  MetadataWalk(FileBytes& f, const hdf5::Superblock& s)
      : f_(f), base_(s.base), end_of_file_(s.end_of_file), o_(s.size_of_offsets), l_(s.size_of_lengths) {}

  std::string run(const hdf5::Superblock& s) {
    driver_info(s.driver_info);
    object(s.root_header);
    object(s.extension);
    local_heap(s.cached_heap);
    group_node(s.cached_btree);
    while (damage_.empty() && !objects_.empty() && blocks_ < kMaxBlocks) {
      const std::uint64_t at = objects_.front();
      objects_.pop_front();
      object_header(at);
    }
    return damage_;
  }

 private:
  // Bytes at a file address (relative to the base), nullopt past the end; each address once.
  std::optional<Bytes> block(std::uint64_t address, std::uint64_t bytes) {
    if (address == kUndefinedAddress || address > f_.size() || !seen_.insert(address).second) return std::nullopt;
    ++blocks_;
    return read(address, bytes);
  }
  std::optional<Bytes> read(std::uint64_t address, std::uint64_t bytes) {
    if (address > f_.size() - std::min(f_.size(), base_)) return std::nullopt;
    return f_.read(base_ + address, std::min(bytes, f_.size()));
  }

  // An object header to walk (the queue is bounded like the walk).
  void object(std::uint64_t at) {
    if (objects_.size() < kMaxBlocks) objects_.push_back(at);
  }

  // True (and the damage noted) when `bytes` declared at `what` exceed the whole file.
  bool too_big(std::uint64_t bytes, const std::string& what) {
    if (bytes <= f_.size()) return false;
    note(fmt::format("{} declares {} bytes, more than the whole file ({} bytes)", what, bytes, f_.size()));
    return true;
  }

  void driver_info(std::uint64_t at) {
    const auto b = block(at, 8);
    if (!b || b->size() < 8 || (*b)[0] != 0) return;
    too_big(little_endian(b->data() + 4, 4), fmt::format("the driver information block at byte {}", base_ + at));
  }

  void object_header(std::uint64_t at) {
    const auto prefix = block(at, 48);
    if (!prefix || prefix->size() < 16) return;
    const std::string where = fmt::format("the object header at byte {}", base_ + at);
    if (starts_with(*prefix, "OHDR")) {
      if ((*prefix)[4] != 2) return;
      const unsigned flags = (*prefix)[5];
      const std::size_t size_at = 6 + ((flags & 0x20) ? 16 : 0) + ((flags & 0x10) ? 4 : 0);
      const unsigned size_bytes = 1u << (flags & 3);
      if (prefix->size() < size_at + size_bytes) return;
      const std::uint64_t chunk0 = little_endian(prefix->data() + size_at, size_bytes);
      if (too_big(chunk0, where + ": its first chunk")) return;
      const std::uint64_t start = size_at + size_bytes;
      if (const auto chunk = whole_chunk(at, start + chunk0 + 4, true, where + ": its first chunk"))
        messages(*chunk, start, chunk->size() - 4, 2, (flags & 0x04) != 0, where);
    } else {
      if ((*prefix)[0] != 1) return;
      const std::uint64_t chunk0 = little_endian(prefix->data() + 8, 4);
      if (too_big(chunk0, where + ": its first chunk")) return;
      if (const auto chunk = whole_chunk(at, 16 + chunk0, false, where + ": its first chunk"))
        messages(*chunk, 16, chunk->size(), 1, false, where);
    }
  }

  // An object header chunk of `bytes` at `at`, read whole: libhdf5 decodes its header first and
  // loses that (an object header, 424 bytes, unreachable) when the rest cannot be loaded, so a
  // chunk past the end of the file or of its allocated space, or one whose checksum does not
  // match (version 2), is damage here.
  std::optional<Bytes> whole_chunk(std::uint64_t at, std::uint64_t bytes, bool checksummed, const std::string& what) {
    auto chunk = read(at, bytes);
    if (!chunk || chunk->size() != bytes || (end_of_file_ != kUndefinedAddress && at + bytes > end_of_file_)) {
      note(fmt::format("{} ({} bytes at byte {}) runs past the end of the file", what, bytes, base_ + at));
      return std::nullopt;
    }
    // A file still being written (SWMR) may be read while a header is rewritten: read again, as
    // libhdf5 does, before calling it damaged.
    for (int attempt = 1; checksummed && !hdf5::checksum_matches(*chunk); ++attempt) {
      if (attempt == kChecksumAttempts) {
        note(fmt::format("{} ({} bytes at byte {}) does not match its checksum", what, bytes, base_ + at));
        return std::nullopt;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      chunk = read(at, bytes);
      if (!chunk) return std::nullopt;
    }
    return chunk;
  }

  void note(std::string what) {
    if (damage_.empty()) damage_ = std::move(what);
  }

  // The messages of one chunk in c[from, to).
  void messages(const Bytes& c, std::size_t from, std::size_t to, int version, bool creation_order,
                const std::string& where) {
    const std::size_t header = version == 1 ? 8 : (creation_order ? 6 : 4);
    for (std::size_t p = from; p + header <= to && damage_.empty();) {
      const unsigned type = version == 1 ? static_cast<unsigned>(little_endian(&c[p], 2)) : c[p];
      const std::size_t size = static_cast<std::size_t>(little_endian(&c[p + (version == 1 ? 2 : 1)], 2));
      const std::size_t data = p + header;
      if (size > to - data) return;  // libhdf5 refuses a message past its chunk itself
      message(type, &c[data], size, version, creation_order, where);
      p = data + size;
    }
  }

  void message(unsigned type, const unsigned char* p, std::size_t size, int version, bool creation_order,
               const std::string& where) {
    switch (type) {
      case 0x10: {  // continuation
        if (size < o_ + l_) return;
        const std::uint64_t at = hdf5::address(p, o_), length = little_endian(p + o_, l_);
        const std::string what = fmt::format("{}: its continuation message (chunk at byte {})", where, base_ + at);
        if (too_big(length, what) || at == hdf5::kUndefinedAddress || !seen_.insert(at).second) return;
        ++blocks_;
        const auto chunk = whole_chunk(at, length, version == 2, what);
        if (!chunk) return;
        if (version == 1) messages(*chunk, 0, chunk->size(), 1, false, where);
        else if (starts_with(*chunk, "OCHK") && chunk->size() >= 8)
          messages(*chunk, 4, chunk->size() - 4, 2, creation_order, where);
        return;
      }
      case 0x11:  // symbol table
        if (size < 2 * o_) return;
        group_node(hdf5::address(p, o_));
        local_heap(hdf5::address(p + o_, o_));
        return;
      case 0x06: {  // link
        if (size < 2 || p[0] != 1) return;
        const unsigned flags = p[1];
        std::size_t q = 2;
        unsigned link_type = 0;
        if (flags & 0x08) link_type = q < size ? p[q++] : 255;
        if (flags & 0x04) q += 8;
        if (flags & 0x10) q += 1;
        const unsigned name_bytes = 1u << (flags & 3);
        if (link_type != 0 || q + name_bytes > size) return;
        q += name_bytes + static_cast<std::size_t>(little_endian(p + q, name_bytes));
        if (q + o_ <= size) object(hdf5::address(p + q, o_));
        return;
      }
      default: return;
    }
  }

  void local_heap(std::uint64_t at) {
    const auto b = block(at, 8 + 2 * l_ + o_);
    if (!b || b->size() < 8 + 2 * l_ + o_ || !starts_with(*b, "HEAP") || (*b)[4] != 0) return;
    too_big(little_endian(b->data() + 8, l_), fmt::format("the local heap at byte {}: its data segment", base_ + at));
  }

  void group_node(std::uint64_t at, int depth = 0) {
    const std::size_t header = 8 + 2 * o_;
    const auto h = block(at, header);
    if (!h || h->size() < header || depth > 64) return;
    if (!starts_with(*h, "TREE") || (*h)[4] != 0) return;
    const unsigned level = (*h)[5];
    const std::uint64_t entries = little_endian(h->data() + 6, 2);
    const auto body = read(at + header, entries * (l_ + o_) + l_);
    if (!body) return;
    for (std::uint64_t i = 0; i < entries && damage_.empty(); ++i) {
      const std::uint64_t child = hdf5::address(body->data() + i * (l_ + o_) + l_, o_);
      if (level > 0) {
        group_node(child, depth + 1);
      } else if (const auto node = block(child, 8); node && starts_with(*node, "SNOD")) {
        symbol_node(*node, child);
      }
    }
  }

  void symbol_node(const Bytes& head, std::uint64_t at) {
    if (head.size() < 8 || head[4] != 1) return;
    const std::uint64_t symbols = little_endian(head.data() + 6, 2);
    const std::uint64_t entry = 2 * o_ + 8 + 16;
    const auto body = read(at + 8, symbols * entry);
    if (!body) return;
    for (std::uint64_t i = 0; i < symbols; ++i) object(hdf5::address(body->data() + i * entry + o_, o_));
  }

  FileBytes& f_;
  std::uint64_t base_, end_of_file_;
  unsigned o_, l_;  // sizes of offsets and lengths
  std::deque<std::uint64_t> objects_;
  std::set<std::uint64_t> seen_;
  std::uint64_t blocks_ = 0;
  std::string damage_;
};

}  // namespace

std::string metadata_damage(const fs::path& file) {
  FileBytes f(file);
  const auto superblock = hdf5::find_superblock(f);
  if (!superblock) return {};
  return MetadataWalk(f, *superblock).run(*superblock);
}

}  // namespace stend::detail
