// Zip archives (zip_archive.hpp): the end of central directory record found from the end of the
// file (its zip64 record through the locator before it), the central directory walked entry by
// entry inside the bytes it declares, each member's local header checked, and a member's bytes
// read forwards (stored, or raw deflate through zlib's inflate).
#include "zip_archive.hpp"

#include "mat_file.hpp"  // kMaxZlibExpansion

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <new>

namespace stend::io::detail {

namespace fs = std::filesystem;

namespace {

constexpr std::uint32_t kEnd = 0x06054b50, kEnd64Locator = 0x07064b50, kEnd64 = 0x06064b50, kCentral = 0x02014b50;
constexpr std::size_t kEndBytes = 22, kEnd64LocatorBytes = 20, kEnd64Bytes = 56, kCentralBytes = 46;
constexpr std::size_t kMaxComment = 65535;
constexpr std::uint32_t kSaturated32 = 0xffffffff;  // "see the zip64 record"
constexpr std::uint16_t kZip64Extra = 0x0001;

std::string hex32(std::uint32_t v) {
  char s[16];
  std::snprintf(s, sizeof s, "0x%08x", v);
  return s;
}

// Where the central directory lies and how many entries it declares.
struct Directory {
  std::uint64_t offset = 0, bytes = 0, entries = 0;
};

// The end of central directory record: its last signature in the file's last 64 KiB + 22 bytes
// (the record and at most a 65535-byte comment), as Python's zipfile finds it.
std::size_t find_end(const BinaryReader& zip) {
  const std::size_t size = zip.size();
  if (size < kEndBytes) zip.fail(0, "is not a zip archive: shorter than an end of central directory record (22 bytes)");
  const std::size_t from = size - std::min(size, kEndBytes + kMaxComment);
  zip.need(from, size - from, "the end of central directory record");
  for (std::size_t p = size - kEndBytes + 1; p-- > from;)
    if (load_le<std::uint32_t>(zip.at(p)) == kEnd) return p;
  zip.fail(from, "no end of central directory record in the last " + std::to_string(size - from) +
                     " bytes: not a zip archive, or cut short");
}

// The zip64 end of central directory record the locator before `end` points to, if there is one.
bool read_zip64_end(const BinaryReader& zip, std::size_t end, Directory& d) {
  if (end < kEnd64LocatorBytes) return false;
  const std::size_t locator = end - kEnd64LocatorBytes;
  if (zip.get<std::uint32_t>(locator, "the zip64 locator") != kEnd64Locator) return false;
  const std::uint64_t at = zip.get<std::uint64_t>(locator + 8, "the zip64 locator");
  if (zip.get<std::uint32_t>(locator + 16, "the zip64 locator") > 1) zip.fail(locator, "the archive spans several disks: not read");
  if (at > zip.size()) zip.fail(locator, "the zip64 locator points beyond the file's end, to byte " + std::to_string(at));
  zip.need(static_cast<std::size_t>(at), kEnd64Bytes, "the zip64 end of central directory record");
  if (zip.get<std::uint32_t>(static_cast<std::size_t>(at), "the zip64 end of central directory record") != kEnd64)
    zip.fail(static_cast<std::size_t>(at), "no zip64 end of central directory record where its locator points");
  const std::uint8_t* r = zip.at(static_cast<std::size_t>(at));
  if (load_le<std::uint32_t>(r + 16) != 0 || load_le<std::uint32_t>(r + 20) != 0)
    zip.fail(static_cast<std::size_t>(at), "the archive spans several disks: not read");
  d.entries = load_le<std::uint64_t>(r + 32);
  d.bytes = load_le<std::uint64_t>(r + 40);
  d.offset = load_le<std::uint64_t>(r + 48);
  return true;
}

Directory directory(const BinaryReader& zip) {
  const std::size_t end = find_end(zip);
  zip.need(end, kEndBytes, "the end of central directory record");
  const std::uint8_t* e = zip.at(end);
  if (load_le<std::uint16_t>(e + 4) != 0 || load_le<std::uint16_t>(e + 6) != 0)
    zip.fail(end, "the archive spans several disks: not read");
  Directory d{load_le<std::uint32_t>(e + 16), load_le<std::uint32_t>(e + 12), load_le<std::uint16_t>(e + 10)};
  const bool saturated = d.offset == kSaturated32 || d.bytes == kSaturated32;
  if (!read_zip64_end(zip, end, d) && saturated)
    zip.fail(end, "the end of central directory record refers to a zip64 record, and there is none before it");
  if (d.offset > zip.size() || d.bytes > zip.size() - d.offset)
    zip.fail(end, "the central directory (" + std::to_string(d.bytes) + " bytes at byte " + std::to_string(d.offset) +
                      ") lies beyond the file's end (" + std::to_string(zip.size()) + " bytes)");
  if (d.entries > d.bytes / kCentralBytes)
    zip.fail(end, "declares " + std::to_string(d.entries) + " entries in a central directory of " +
                      std::to_string(d.bytes) + " bytes (at most " + std::to_string(d.bytes / kCentralBytes) + " fit)");
  return d;
}

// The sizes and offset a zip64 extra field gives for those the entry saturated, in the order the
// format fixes (size, compressed size, local header offset).
void read_zip64_extra(const BinaryReader& zip, std::size_t at, std::size_t extra, std::size_t bytes, ZipMember& m) {
  std::uint64_t* fields[] = {&m.size, &m.compressed, &m.header};
  std::size_t p = extra;
  while (p + 4 <= extra + bytes) {
    const std::uint16_t id = load_le<std::uint16_t>(zip.at(p)), len = load_le<std::uint16_t>(zip.at(p + 2));
    if (p + 4 + len > extra + bytes) break;
    if (id == kZip64Extra) {
      std::size_t q = p + 4;
      for (std::uint64_t* f : fields) {
        if (*f != kSaturated32) continue;
        if (q + 8 > p + 4 + len) zip.fail(at, "member '" + m.name + "': its zip64 extra field is shorter than the sizes it stands for");
        *f = load_le<std::uint64_t>(zip.at(q));
        q += 8;
      }
      return;
    }
    p += 4 + len;
  }
  for (const std::uint64_t* f : fields)
    if (*f == kSaturated32) zip.fail(at, "member '" + m.name + "': a size is in a zip64 extra field, and there is none");
}

// The central directory entry at `at` (inside the directory, which ends at `end`); `at` moves past it.
ZipMember central_entry(const BinaryReader& zip, std::uint64_t& at, std::uint64_t end) {
  const auto here = static_cast<std::size_t>(at);
  if (end - at < kCentralBytes) zip.fail(here, "the central directory ends inside an entry");
  zip.need(here, kCentralBytes, "a central directory entry");
  const std::uint8_t* c = zip.at(here);
  if (load_le<std::uint32_t>(c) != kCentral) zip.fail(here, "no central directory entry where one should start");
  const std::uint16_t flags = load_le<std::uint16_t>(c + 8);
  ZipMember m;
  m.method = load_le<std::uint16_t>(c + 10);
  m.crc32 = load_le<std::uint32_t>(c + 16);
  m.compressed = load_le<std::uint32_t>(c + 20);
  m.size = load_le<std::uint32_t>(c + 24);
  const std::size_t name = load_le<std::uint16_t>(c + 28), extra = load_le<std::uint16_t>(c + 30),
                    comment = load_le<std::uint16_t>(c + 32);
  const std::uint16_t disk = load_le<std::uint16_t>(c + 34);
  m.header = load_le<std::uint32_t>(c + 42);
  const std::uint64_t bytes = kCentralBytes + name + extra + comment;
  if (end - at < bytes) zip.fail(here, "the central directory ends inside an entry's name or extra fields");
  zip.need(here, static_cast<std::size_t>(bytes), "a central directory entry");
  m.name = std::string(reinterpret_cast<const char*>(zip.at(here + kCentralBytes)), name);
  read_zip64_extra(zip, here, here + kCentralBytes + name, extra, m);
  if (flags & 1) zip.fail(here, "member '" + m.name + "' is encrypted: not read");
  if (disk != 0 && disk != 0xffff) zip.fail(here, "the archive spans several disks: not read");
  at += bytes;
  return m;
}

// Where the member's bytes start, after its local header (whose name and extra field lengths may
// differ from the directory's), checked to lie inside the file.
void locate_data(const BinaryReader& zip, std::ifstream& in, ZipMember& m) {
  const std::uint64_t size = zip.size();
  std::uint8_t h[kZipLocalHeaderBytes];
  if (m.header > size || size - m.header < kZipLocalHeaderBytes)
    zip.fail(static_cast<std::size_t>(std::min(m.header, size)),
             "member '" + m.name + "': its local header at byte " + std::to_string(m.header) + " lies beyond the file's end");
  in.clear();
  in.seekg(static_cast<std::streamoff>(m.header));
  in.read(reinterpret_cast<char*>(h), sizeof h);
  if (in.gcount() != static_cast<std::streamsize>(sizeof h)) zip.fail(static_cast<std::size_t>(m.header), "cannot read a local header");
  const auto where = static_cast<std::size_t>(m.header);
  if (load_le<std::uint32_t>(h) != kZipLocalHeader) zip.fail(where, "member '" + m.name + "': no local header where the directory says");
  m.data = m.header + kZipLocalHeaderBytes + load_le<std::uint16_t>(h + 26) + load_le<std::uint16_t>(h + 28);
  if (m.data > size || m.compressed > size - m.data)
    zip.fail(where, "member '" + m.name + "': its " + std::to_string(m.compressed) + " bytes at byte " + std::to_string(m.data) +
                        " lie beyond the file's end (" + std::to_string(size) + " bytes)");
  if (m.method == 0 && m.size != m.compressed)
    zip.fail(where, "member '" + m.name + "' is stored, yet declares " + std::to_string(m.size) + " bytes in " +
                        std::to_string(m.compressed));
  if (m.deflated() && m.size / kMaxZlibExpansion > m.compressed)
    zip.fail(where, "member '" + m.name + "' declares " + std::to_string(m.size) + " bytes inflated from " +
                        std::to_string(m.compressed) + " (deflate inflates at most " + std::to_string(kMaxZlibExpansion) +
                        " bytes from one)");
}

}  // namespace

std::vector<ZipMember> zip_members(const BinaryReader& zip) {
  const Directory d = directory(zip);
  std::ifstream in(zip.file(), std::ios::binary);  // local headers: 30 bytes each, read where they are
  std::vector<ZipMember> members;
  std::uint64_t at = d.offset;
  for (std::uint64_t i = 0; i < d.entries; ++i) {
    members.push_back(central_entry(zip, at, d.offset + d.bytes));
    locate_data(zip, in, members.back());
  }
  return members;
}

ZipMember whole_file(const fs::path& file) {
  ZipMember m;
  m.name = file.filename().string();
  std::error_code ec;
  m.size = m.compressed = fs::file_size(file, ec);
  if (ec) throw ImportError(file, 0, "cannot read its size: " + ec.message() + " (check the path)");
  m.in_archive = false;
  return m;
}

ZipMemberReader::ZipMemberReader(const fs::path& file, const ZipMember& member)
    : file_(file), m_(member), in_(file, std::ios::binary), next_(member.data), left_(member.compressed),
      crc_whole_(member.in_archive) {
  if (!in_) throw ImportError(file, 0, std::string("cannot open: ") + std::strerror(errno) + " (check the path)");
  if (m_.method != 0 && !m_.deflated())
    throw ImportError(file, ByteOffset{m_.header}, "member '" + m_.name + "' is compressed by zip method " +
                                                       std::to_string(m_.method) + ": only stored and deflated members are read");
  in_.seekg(static_cast<std::streamoff>(next_));
  if (m_.deflated()) {
    in_buf_.resize(std::size_t{1} << 14);
    if (inflateInit2(&z_, -15) != Z_OK) throw std::bad_alloc();  // raw deflate: no zlib header
  }
}

ZipMemberReader::~ZipMemberReader() {
  if (m_.deflated()) inflateEnd(&z_);
}

bool ZipMemberReader::read(std::uint8_t* out, std::size_t n) {
  if (n > m_.size - pos_) return false;
  for (std::size_t done = 0; done < n;) {
    const std::size_t got = m_.deflated() ? inflate_into(out + done, n - done) : read_stored(out + done, n - done);
    if (got == 0) return false;
    done += got;
  }
  if (crc_whole_) crc_ = static_cast<std::uint32_t>(crc32_z(crc_, out, n));
  pos_ += n;
  if (pos_ == m_.size && crc_whole_) check_crc();
  return true;
}

bool ZipMemberReader::skip(std::uint64_t n) {
  if (n > m_.size - pos_) return false;
  if (!m_.deflated() && n > kCheckedSkip) {  // stored: seek (the CRC is then not checked)
    next_ += n;
    left_ -= n;
    pos_ += n;
    crc_whole_ = false;
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(next_));
    return true;
  }
  std::vector<std::uint8_t> scratch(static_cast<std::size_t>(std::min<std::uint64_t>(n, kCheckedSkip)));
  for (std::uint64_t left = n; left > 0;) {
    const auto piece = static_cast<std::size_t>(std::min<std::uint64_t>(left, scratch.size()));
    if (!read(scratch.data(), piece)) return false;
    left -= piece;
  }
  return true;
}

std::size_t ZipMemberReader::read_stored(std::uint8_t* to, std::size_t want) {
  const auto take = static_cast<std::size_t>(std::min<std::uint64_t>(want, left_));
  if (take == 0) return 0;
  in_.read(reinterpret_cast<char*>(to), static_cast<std::streamsize>(take));
  const auto got = static_cast<std::size_t>(std::max<std::streamsize>(0, in_.gcount()));
  next_ += got;
  left_ -= got;
  return got;
}

std::size_t ZipMemberReader::inflate_into(std::uint8_t* to, std::size_t want) {
  const std::size_t ask = std::min<std::size_t>(want, std::size_t{1} << 30);
  z_.next_out = to;
  z_.avail_out = static_cast<uInt>(ask);
  while (z_.avail_out > 0 && !ended_) {
    if (z_.avail_in == 0) {
      const std::size_t got = read_stored(in_buf_.data(), in_buf_.size());
      if (got == 0) break;
      z_.next_in = in_buf_.data();
      z_.avail_in = static_cast<uInt>(got);
    }
    const int rc = inflate(&z_, Z_NO_FLUSH);
    if (rc == Z_STREAM_END) {
      ended_ = true;
    } else if (rc == Z_MEM_ERROR) {
      throw std::bad_alloc();
    } else if (rc != Z_OK) {
      throw ImportError(file_, ByteOffset{next_ - z_.avail_in},
                        "member '" + m_.name + "': its deflate stream is damaged (zlib: " + (z_.msg ? z_.msg : "error " + std::to_string(rc)) +
                            ", " + std::to_string(pos_ + ask - z_.avail_out) + " bytes inflated)");
    }
  }
  return ask - z_.avail_out;
}

void ZipMemberReader::fail(std::uint64_t pos, const std::string& message) const {
  const std::string member = m_.in_archive ? "member '" + m_.name + "'" : "";
  if (m_.deflated())
    throw ImportError(file_, ByteOffset{m_.header}, member + " (deflated), byte " + std::to_string(pos) + " once inflated: " + message);
  throw ImportError(file_, ByteOffset{m_.data + pos}, member.empty() ? message : member + ": " + message);
}

void ZipMemberReader::check_crc() const {
  if (crc_ != m_.crc32)
    throw ImportError(file_, ByteOffset{m_.header}, "member '" + m_.name + "': its bytes' CRC-32 is " + hex32(crc_) +
                                                        ", its directory entry states " + hex32(m_.crc32) + " (damaged)");
}

}  // namespace stend::io::detail
