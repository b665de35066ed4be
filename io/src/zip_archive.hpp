// A zip archive as np.savez and np.savez_compressed write it (an .npz): its members listed from
// the central directory (zip64 as well, which NumPy asks for), and a member's bytes read forwards,
// stored or inflated from raw deflate through zlib, a block at a time — never a member whole.
// Internal to stend_io.
#pragma once

#include "import_common.hpp"

#include <zlib.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace stend::io::detail {

// One member: where its bytes lie and how they are stored.
struct ZipMember {
  std::string name;              // as stored ("ax.npy")
  std::uint16_t method = 0;      // 0 stored, 8 deflated (any other: not read)
  std::uint64_t compressed = 0;  // bytes in the archive
  std::uint64_t size = 0;        // bytes once inflated
  std::uint64_t header = 0;      // offset of its local file header
  std::uint64_t data = 0;        // offset of its first stored byte
  std::uint32_t crc32 = 0;       // of its inflated bytes
  bool in_archive = true;        // false: a plain file read as one stored member (no CRC, no member name)
  bool deflated() const { return method == 8; }
};

// "PK\3\4": the signature a zip archive starts with (its first local file header).
inline constexpr std::uint32_t kZipLocalHeader = 0x04034b50;
// Bytes of a local file header before its name: the name's length is at offset 26.
inline constexpr std::size_t kZipLocalHeaderBytes = 30;

// The members of the archive `zip`, in the central directory's order, each checked to lie inside
// the file (a deflated one to inflate to at most kMaxZlibExpansion times its bytes). Throws
// ImportError at the byte offset of what is damaged: no end of central directory record, a
// directory outside the file or declaring more entries than it holds, an encrypted or spanned
// archive, a local header that does not match.
std::vector<ZipMember> zip_members(const BinaryReader& zip);

// The whole file `file` as one stored member (a plain .npy read like an .npz's member).
ZipMember whole_file(const std::filesystem::path& file);

// A member's bytes from its start, forwards. A member read to its end is checked against its
// CRC-32 when every byte went through read() (skips of up to kCheckedSkip bytes are read too).
class ZipMemberReader {
 public:
  ZipMemberReader(const std::filesystem::path& file, const ZipMember& member);
  ~ZipMemberReader();
  ZipMemberReader(const ZipMemberReader&) = delete;
  ZipMemberReader& operator=(const ZipMemberReader&) = delete;

  // The next n bytes of the member into out; false when the member (or its deflate stream) ends
  // first. Throws ImportError for a damaged deflate stream or a CRC that does not match.
  bool read(std::uint8_t* out, std::size_t n);
  // Moves n bytes on; false when the member ends first.
  bool skip(std::uint64_t n);
  // Bytes of the member read or skipped so far.
  std::uint64_t position() const { return pos_; }
  // Throws ImportError for what is wrong at byte `pos` of the member: at its byte offset in the
  // file when stored, at its local header (naming the inflated byte) when deflated.
  [[noreturn]] void fail(std::uint64_t pos, const std::string& message) const;
  const ZipMember& member() const { return m_; }

  static constexpr std::uint64_t kCheckedSkip = 1 << 16;

 private:
  std::size_t read_stored(std::uint8_t* to, std::size_t want);
  std::size_t inflate_into(std::uint8_t* to, std::size_t want);
  void check_crc() const;

  std::filesystem::path file_;
  ZipMember m_;
  std::ifstream in_;
  std::uint64_t next_;  // file offset of the next stored (compressed) byte
  std::uint64_t left_;  // stored bytes of the member not yet read
  std::uint64_t pos_ = 0;
  bool ended_ = false;  // the deflate stream's end was reached
  z_stream z_{};
  std::uint32_t crc_ = 0;
  bool crc_whole_;      // every byte so far went through the CRC
  std::vector<std::uint8_t> in_buf_;
};

}  // namespace stend::io::detail
