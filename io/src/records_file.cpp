// Raw binary records as named arrays (open_records in arrays.hpp): after `header_bytes`, records
// of the layout `record_layout` declares (fields of fixed types, no gaps but the '_' padding
// fields), one after the other, in `byte_order`. Each field but padding is an N×1 array named by
// the field. A last record cut short is dropped and reported (damage()).
#include "arrays.hpp"
#include "binary_values.hpp"
#include "import_common.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace stend::io::detail {

namespace fs = std::filesystem;

namespace {

// Bytes read per step of a read (at least one record).
constexpr std::size_t kBlockBytes = std::size_t{1} << 16;

// One field: where it lies in a record and how it is stored.
struct FieldPlace {
  std::string name;
  std::size_t offset = 0;  // bytes from the record's start
  ValueType type;
};

// What the options declare: the fields (their offsets), the record's size, the header's.
struct RecordLayout {
  std::vector<FieldPlace> fields;  // padding left out
  std::size_t record = 0;          // bytes
  std::uint64_t header = 0;        // bytes before the first record
  bool big_endian = false;
};

RecordLayout layout_of(const ImportOptions& o) {
  if (o.record_layout.empty())
    throw std::invalid_argument("format records: give record_layout (--record-layout t:f64,ax:i16,…): raw records do not "
                                "say what they hold");
  RecordLayout l;
  l.header = o.header_bytes;
  l.big_endian = o.big_endian;
  for (const RecordField& f : o.record_layout) {
    if (!f.padding()) l.fields.push_back({f.name, l.record, {f.kind, f.bytes, o.big_endian}});
    l.record += f.bytes;
  }
  return l;
}

// The values of one field, read a block of records at a time.
class FieldSeries final : public ArraySeries {
 public:
  FieldSeries(const fs::path& file, const RecordLayout& l, const FieldPlace& f, std::size_t records)
      : ArraySeries(f.name, records, 1), file_(file), in_(file, std::ios::binary), record_(l.record), field_(f),
        next_at_(l.header) {
    if (!in_) throw ImportError(file, 0, std::string("cannot open: ") + std::strerror(errno) + " (check the path)");
    in_.seekg(static_cast<std::streamoff>(next_at_));
  }

  void read(std::size_t n, double* out) override {
    if (n > rows - next_)
      throw std::logic_error("'" + name + "': " + std::to_string(n) + " records asked for after " + std::to_string(next_) +
                             " of " + std::to_string(rows));
    const std::size_t step = std::max<std::size_t>(1, kBlockBytes / record_);
    for (std::size_t done = 0; done < n;) {
      const std::size_t k = std::min(step, n - done);
      raw_.resize(k * record_);
      in_.read(reinterpret_cast<char*>(raw_.data()), static_cast<std::streamsize>(raw_.size()));
      if (in_.gcount() != static_cast<std::streamsize>(raw_.size()))
        throw ImportError(file_, ByteOffset{next_at_}, "cannot read records " + std::to_string(next_ + done + 1) + "…: " +
                                                           std::strerror(errno) + " (the file changed while it was read?)");
      to_doubles(field_.type, raw_.data() + field_.offset, k, record_, out + done, 1);
      next_at_ += raw_.size();
      done += k;
    }
    next_ += n;
  }

 private:
  fs::path file_;
  std::ifstream in_;
  std::size_t record_;
  FieldPlace field_;
  std::uint64_t next_at_;  // file offset of the next record
  std::vector<std::uint8_t> raw_;
  std::size_t next_ = 0;
};

class RecordsFile final : public ArrayFile {
 public:
  RecordsFile(const fs::path& file, const ImportOptions& options) : file_(file), layout_(layout_of(options)) {
    std::error_code ec;
    const std::uint64_t size = fs::file_size(file, ec);
    if (ec) throw ImportError(file, 0, "cannot read its size: " + ec.message() + " (check the path)");
    if (layout_.header > size)
      throw ImportError(file, ByteOffset{size}, "the file ends inside its header: header_bytes is " +
                                                    std::to_string(layout_.header) + ", the file holds " + std::to_string(size));
    const std::uint64_t body = size - layout_.header, cut = body % layout_.record;
    records_ = static_cast<std::size_t>(body / layout_.record);
    if (cut > 0)
      damage_ = "the last record is cut after " + std::to_string(cut) + " of " + std::to_string(layout_.record) +
                " bytes at byte offset " + std::to_string(layout_.header + records_ * layout_.record) + "; " +
                std::to_string(records_) + " whole records kept";
  }

  const fs::path& file() const override { return file_; }

  std::vector<ArrayInfo> arrays() const override {
    std::vector<ArrayInfo> out;
    for (const FieldPlace& f : layout_.fields) out.push_back({f.name, records_, 1, type_name(f.type)});
    return out;
  }

  std::unique_ptr<ArraySeries> open(const std::string& name) const override {
    for (const FieldPlace& f : layout_.fields)
      if (f.name == name) return std::make_unique<FieldSeries>(file_, layout_, f, records_);
    std::string list;
    for (const FieldPlace& f : layout_.fields) list += (list.empty() ? "" : ", ") + f.name;
    throw ImportError(file_, 0, "no field named '" + name + "' in record_layout (fields: " + list + ")");
  }

  std::string layout() const override {
    return "raw records of " + std::to_string(layout_.record) + " bytes (" + std::to_string(layout_.fields.size()) + " fields, " +
           (layout_.big_endian ? "big" : "little") + "-endian) after a " + std::to_string(layout_.header) +
           "-byte header, " + std::to_string(records_) + " records";
  }

  std::string damage() const override { return damage_; }

 private:
  fs::path file_;
  RecordLayout layout_;
  std::size_t records_ = 0;
  std::string damage_;
};

}  // namespace

std::unique_ptr<ArrayFile> open_records(const fs::path& file, const ImportOptions& options) {
  return std::make_unique<RecordsFile>(file, options);
}

}  // namespace stend::io::detail
