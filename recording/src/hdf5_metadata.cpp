// An HDF5 file's object headers checked before libhdf5 reads them (why: hdf5_metadata.hpp).
//
// HDF5 file format specification 3.0, the parts read here:
//   Object header version 2: "OHDR", version 2, flags (bit 5: four times, 16 bytes; bit 4: two
//     attribute limits, 4 bytes; bits 0–1: the first chunk's size takes 1, 2, 4 or 8 bytes), the
//     size; messages: type (1), size (2), flags (1), creation order (2, when flags bit 2); then
//     the checksum (4: lookup3 of every byte of the header before it). A continuation chunk is
//     "OCHK", messages, checksum.
//   Continuation message (type 0x10): the chunk's address and length (the length includes
//     "OCHK" and the checksum).
#include "hdf5_metadata.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cstring>
#include <optional>
#include <set>
#include <string_view>
#include <thread>
#include <vector>

#include "hdf5_file_bytes.hpp"

namespace stend::detail {
namespace {

using hdf5::kUndefinedAddress;
using hdf5::little_endian;
using Bytes = std::vector<unsigned char>;

constexpr std::uint64_t kMaxChunks = 1u << 12;  // chunks of one object header at most (a damaged one may loop)
constexpr int kChecksumAttempts = 3;            // reads of a chunk before a mismatch counts (file open for writing)

bool starts_with(const Bytes& b, std::string_view signature) {
  return b.size() >= signature.size() && std::memcmp(b.data(), signature.data(), signature.size()) == 0;
}

}  // namespace

struct Hdf5HeaderCheck::Impl {
  explicit Impl(const std::filesystem::path& file) : f(file), superblock(hdf5::find_superblock(f)) {}

  // Up to `bytes` bytes at a file address: fewer where the file ends first.
  std::optional<Bytes> read(std::uint64_t address, std::uint64_t bytes) {
    const std::uint64_t base = superblock->base;
    if (base > f.size() || address > f.size() - base) return std::nullopt;
    return f.read(base + address, std::min(bytes, f.size() - base - address));
  }

  // A header chunk of `bytes` at `address`, read whole and matching its checksum; else why not.
  // A file still being written (SWMR; its superblock says so) may be read while a header is
  // rewritten: read again, as libhdf5 does, before calling it damaged. A closed file cannot change.
  std::optional<Bytes> chunk(std::uint64_t address, std::uint64_t bytes, const std::string& what, std::string& why) {
    const std::uint64_t base = superblock->base, eof = superblock->end_of_file;
    const bool past_allocation = eof != kUndefinedAddress && (address > eof || bytes > eof - address);
    auto c = read(address, bytes);
    if (past_allocation || !c || c->size() != bytes) {
      why = fmt::format("{} ({} bytes at byte {}) runs past the end of the file ({} bytes)", what, bytes,
                        base + address, f.size());
      return std::nullopt;
    }
    const int attempts = superblock->open_for_writing ? kChecksumAttempts : 1;
    for (int attempt = 1; !hdf5::checksum_matches(*c); ++attempt) {
      if (attempt == attempts) {
        why = fmt::format("{} ({} bytes at byte {}) does not match its checksum", what, bytes, base + address);
        return std::nullopt;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      c = read(address, bytes);
      if (!c || c->size() != bytes) {
        why = what + " was cut short while it was read";
        return std::nullopt;
      }
    }
    return c;
  }

  std::string object(std::uint64_t address) {
    if (address == kUndefinedAddress || !checked.insert(address).second) return {};
    const std::string where = fmt::format("the object header at byte {}", superblock->base + address);
    const auto prefix = read(address, 48);
    if (prefix && starts_with(*prefix, "OHDR") && prefix->size() < 6) return where + " is cut short by the end of the file";
    if (!prefix || !starts_with(*prefix, "OHDR") || (*prefix)[4] != 2) {
      return where + " is not a version 2 object header (\"OHDR\"): damaged, or not written in the format of "
                     "HDF5 1.8 and later";
    }
    const unsigned flags = (*prefix)[5];
    const std::size_t size_at = 6 + ((flags & 0x20) ? 16 : 0) + ((flags & 0x10) ? 4 : 0);
    const unsigned size_bytes = 1u << (flags & 3);
    if (prefix->size() < size_at + size_bytes) return where + " is cut short by the end of the file";
    const std::uint64_t start = size_at + size_bytes;
    const std::uint64_t chunk0 = little_endian(prefix->data() + size_at, size_bytes);
    std::string why;
    if (chunk0 > f.size()) return fmt::format("{}: its first chunk declares {} bytes, more than the whole file ({} bytes)",
                                              where, chunk0, f.size());
    auto first = chunk(address, start + chunk0 + 4, where + ": its first chunk", why);
    if (!first) return why;
    // The messages of the first chunk and of each continuation chunk they lead to.
    std::vector<std::pair<Bytes, std::size_t>> todo;  // chunks still to walk, where their messages start
    todo.emplace_back(std::move(*first), start);
    std::set<std::uint64_t> chunks{address};
    const std::size_t header = (flags & 0x04) ? 6 : 4;
    const unsigned o = superblock->size_of_offsets, l = superblock->size_of_lengths;
    while (!todo.empty()) {
      const auto [c, from] = std::move(todo.back());
      todo.pop_back();
      const std::size_t to = c.size() - 4;  // the checksum
      for (std::size_t p = from; p + header <= to;) {
        const unsigned type = c[p];
        const std::size_t size = static_cast<std::size_t>(little_endian(&c[p + 1], 2));
        const std::size_t data = p + header;
        if (size > to - data) break;  // libhdf5 refuses a message past its chunk itself
        p = data + size;
        if (type != 0x10 || size < o + l) continue;  // not a continuation
        const std::uint64_t at = hdf5::address(&c[data], o), length = little_endian(&c[data + o], l);
        const std::string what = fmt::format("{}: its continuation chunk at byte {}", where, superblock->base + at);
        if (length > f.size())
          return fmt::format("{} declares {} bytes, more than the whole file ({} bytes)", what, length, f.size());
        if (!chunks.insert(at).second || chunks.size() > kMaxChunks) return what + " is reached twice (damaged)";
        auto cont = chunk(at, length, what, why);
        if (!cont) return why;
        if (!starts_with(*cont, "OCHK") || cont->size() < 8) return what + " is not an \"OCHK\" chunk";
        todo.emplace_back(std::move(*cont), 4);
      }
    }
    return {};
  }

  std::string at_open() {
    if (!superblock) return {};  // libhdf5 refuses the file itself
    if (superblock->version < 2) {
      return fmt::format(
          "its superblock is of version {}, the layout of HDF5 1.6 (what h5repack writes without -L), whose "
          "metadata carries no checksums; Stend reads run stores in the layout its writer makes (superblock 2 "
          "or 3: convert with `h5repack -L IN OUT`)",
          superblock->version);
    }
    if (std::string why = object(superblock->extension); !why.empty()) return why;
    return object(superblock->root_header);
  }

  hdf5::FileBytes f;
  std::optional<hdf5::Superblock> superblock;
  std::set<std::uint64_t> checked;  // object headers already checked
};

Hdf5HeaderCheck::Hdf5HeaderCheck(const std::filesystem::path& file) : impl_(std::make_unique<Impl>(file)) {}
Hdf5HeaderCheck::~Hdf5HeaderCheck() = default;
std::string Hdf5HeaderCheck::at_open() { return impl_->at_open(); }
std::string Hdf5HeaderCheck::object(std::uint64_t address) {
  return impl_->superblock ? impl_->object(address) : std::string{};
}
std::string Hdf5HeaderCheck::linked_object(std::uint64_t address) {
  if (impl_->superblock && impl_->checked.count(address) > 0) {
    return fmt::format("links to the object at byte {}, which an earlier link or the root already reached (a "
                       "second link or a loop: damaged)",
                       impl_->superblock->base + address);
  }
  return object(address);
}

}  // namespace stend::detail
