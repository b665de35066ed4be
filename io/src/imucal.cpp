// The imucal annotated session importer (import_imucal_session in stend/io/importers.hpp): counts
// with a sample index and a part label per line; each held part a static segment with its truth,
// the parts between them rotations.
#include "import_common.hpp"

#include <stend/io/timestamps.hpp>
#include <stend/physics/gravity.hpp>
#include <stend/physics/table_chain.hpp>
#include <stend/physics/units.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

namespace stend::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// The columns an imucal session must have, in the order of ImucalColumns::index.
constexpr const char* kImucalColumns[8] = {"part", "samples", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"};

// Positions of the required columns in the column-name line.
struct ImucalColumns {
  std::array<std::size_t, 8> index{};
  std::size_t count = 0;  // columns in the header
};

// One data line: sample index, part label, the six raw counts (acc xyz, gyr xyz), source line.
struct ImucalRow {
  std::int64_t index;
  std::string part;
  std::array<std::int32_t, 6> counts;
  std::size_t line;
};

// Reads the column-name line and finds the required columns in it.
ImucalColumns read_imucal_header(LineReader& r) {
  std::string line;
  if (!r.next(line)) throw ImportError(r.file(), 0, "empty file (expected the column-name line)");
  std::vector<std::string> names;
  for (auto f : split(line, ',')) names.push_back(unquote(f));
  ImucalColumns c;
  c.count = names.size();
  for (int k = 0; k < 8; ++k) {
    const auto it = std::find(names.begin(), names.end(), kImucalColumns[k]);
    if (it == names.end()) {
      r.fail(std::string("no column '") + kImucalColumns[k] +
             "' (expected part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z)");
    }
    c.index[static_cast<std::size_t>(k)] = static_cast<std::size_t>(it - names.begin());
  }
  return c;
}

// One data line's fields as a row: a non-empty part, a non-negative integer index, six counts.
ImucalRow imucal_row(const LineReader& r, const std::vector<std::string_view>& f, const ImucalColumns& c) {
  ImucalRow row;
  row.part = unquote(f[c.index[0]]);
  if (row.part.empty()) r.fail("empty 'part'");
  const double idx = number(r, f[c.index[1]], "samples");
  constexpr double kMaxIndex = 9007199254740992.0;  // 2^53: every integer up to it is exact in a double
  if (!(idx >= 0 && idx <= kMaxIndex) || idx != std::floor(idx)) {
    r.fail("'samples' must be a non-negative integer index (at most 2^53)");
  }
  row.index = static_cast<std::int64_t>(idx);
  for (std::size_t k = 0; k < 6; ++k) {
    row.counts[k] = to_counts(r, number(r, f[c.index[k + 2]], kImucalColumns[k + 2]), kImucalColumns[k + 2]);
  }
  row.line = r.line();
  return row;
}

// A run of data lines whose sample index increases from line to line: where its first line starts
// (file position, lines before it) and how many rows it holds. An imucal session is grouped by
// part, so its time order (the sample index) interleaves a few such runs.
struct ImucalRun {
  std::streampos pos;
  std::size_t lines_before = 0;
  std::size_t rows = 0;
};

// More runs would mean a file read through as many readers at once: such a file (its index going
// back at nearly every line) is refused with the advice to sort it.
constexpr std::size_t kMaxImucalRuns = 1024;

// "<axis>_p" (+axis up) or "<axis>_a" (+axis down) for axis x, y or z: a part with known specific
// force (truth).
bool imucal_held_part(const std::string& part) {
  return part.size() == 3 && part[0] >= 'x' && part[0] <= 'z' && part[1] == '_' && (part[2] == 'p' || part[2] == 'a');
}

// What the first pass finds: the runs, and whether a part gives truth.
struct ImucalScan {
  std::vector<ImucalRun> runs;
  bool truth = false;
};

// Checks every data line and finds the runs.
ImucalScan scan_imucal(LineReader& r, const ImucalColumns& c) {
  ImucalScan scan;
  std::vector<ImucalRun>& runs = scan.runs;
  std::string line;
  std::int64_t prev = 0;
  for (std::streampos pos = r.tell(); r.next(line); pos = r.tell()) {
    if (is_blank(line)) continue;
    const auto f = split(line, ',');
    if (f.size() != c.count) {
      r.fail("expected " + std::to_string(c.count) + " fields as on the column-name line, found " +
             std::to_string(f.size()));
    }
    const ImucalRow row = imucal_row(r, f, c);
    if (runs.empty() || row.index <= prev) {
      if (runs.size() == kMaxImucalRuns) {
        r.fail("the sample index goes back more than " + std::to_string(kMaxImucalRuns) +
               " times; sort the file by the 'samples' column");
      }
      runs.push_back({pos, r.line() - 1, 0});
    }
    ++runs.back().rows;
    prev = row.index;
    scan.truth = scan.truth || imucal_held_part(row.part);
  }
  if (runs.empty()) throw ImportError(r.file(), 0, "no data lines");
  return scan;
}

// The rows of every run merged in time order (by sample index; equal indices in file order), one
// reader per run; a repeated sample index is an error.
class ImucalRows {
 public:
  ImucalRows(const fs::path& file, const ImucalColumns& c, const std::vector<ImucalRun>& runs) : columns_(c) {
    for (const ImucalRun& run : runs) {
      Cursor& k = cursors_.emplace_back(Cursor{std::make_unique<LineReader>(file), run.rows, {}});
      k.reader->seek(run.pos, run.lines_before);
      advance(k);
    }
  }
  bool next(ImucalRow& out) {
    Cursor* best = nullptr;
    for (Cursor& k : cursors_)
      if (k.has_row() && (!best || k.row.index < best->row.index)) best = &k;
    if (!best) return false;
    out = best->row;
    if (emitted_ && out.index == last_.index) {
      throw ImportError(best->reader->file(), out.line, "sample index " + std::to_string(out.index) +
                                                         " also appears on line " + std::to_string(last_.line));
    }
    last_ = out;
    emitted_ = true;
    advance(*best);
    return true;
  }

 private:
  struct Cursor {
    std::unique_ptr<LineReader> reader;
    std::size_t rows_left;  // in its run, the current row included
    ImucalRow row;
    bool has_row() const { return rows_left > 0; }
  };
  void advance(Cursor& k) {
    if (k.row.line != 0 && --k.rows_left == 0) return;
    std::string line;
    while (k.reader->next(line)) {
      if (is_blank(line)) continue;
      k.row = imucal_row(*k.reader, split(line, ','), columns_);
      return;
    }
  }
  ImucalColumns columns_;
  std::vector<Cursor> cursors_;
  ImucalRow last_{};
  bool emitted_ = false;
};

// The sample of a row: t = index / rate [s], counts × LSB [m/s², rad/s].
ImuSample imucal_sample(const ImucalRow& row, const ImucalOptions& opt, double acc_lsb, double gyr_lsb) {
  ImuSample s;
  s.t_s = static_cast<double>(row.index) / opt.rate_hz;
  for (int k = 0; k < 3; ++k) {
    s.accel_counts[k] = row.counts[static_cast<std::size_t>(k)];
    s.gyro_counts[k] = row.counts[static_cast<std::size_t>(k + 3)];
    s.accel_mps2[k] = (s.accel_counts[k] - opt.accel_offset_counts) * acc_lsb;
    s.gyro_radps[k] = (s.gyro_counts[k] - opt.gyro_offset_counts) * gyr_lsb;
  }
  return s;
}

// One segment per contiguous run of a part in time order: "<axis>_rot" is a 360° rotation about
// the axis, any other part an orientation ("<axis>_p" = +axis up: f = +g along it, "<axis>_a" =
// +axis down: f = −g, both held as truth). Parts come sample by sample (add), finish() closes the
// last segment and counts the orientations.
class ImucalSegments {
 public:
  explicit ImucalSegments(double g_mps2) : g_mps2_(g_mps2) {}
  void add(const std::string& part, double t_s, Recording& rec) {
    if (open_ && part == part_) {
      t_end_ = t_s;
      return;
    }
    close(rec);
    open_ = true;
    part_ = part;
    t_start_ = t_end_ = t_s;
  }
  void finish(Recording& rec) {
    close(rec);
    for (std::size_t k : orientation_segments_) rec.segments[k].orientation_count = orientation_;
  }

 private:
  void close(Recording& rec) {
    if (!open_) return;
    const bool rotation = part_.size() > 4 && part_.compare(part_.size() - 4, 4, "_rot") == 0;
    Segment seg = make_segment(id_++, rotation ? SegmentKind::kRotation : SegmentKind::kOrientation, part_, t_start_,
                               t_end_);
    const std::string axis = part_.substr(0, 1);
    if (rotation) {
      seg.targets = "360 deg turn about " + axis;
    } else {
      seg.orientation = orientation_++;
      const bool up = part_.size() == 3 && part_[1] == '_' && part_[2] == 'p';
      const bool down = part_.size() == 3 && part_[1] == '_' && part_[2] == 'a';
      if (up || down) seg.targets = "+" + axis + (up ? " up" : " down");
      if (imucal_held_part(part_)) {
        std::array<double, 3> f{};
        f[static_cast<std::size_t>(part_[0] - 'x')] = up ? g_mps2_ : -g_mps2_;
        add_held_truth(rec, seg.t_start_s, seg.t_end_s, f);
      }
      orientation_segments_.push_back(rec.segments.size());
    }
    rec.segments.push_back(seg);
    open_ = false;
  }
  double g_mps2_;
  bool open_ = false;
  std::string part_;
  double t_start_ = 0.0, t_end_ = 0.0;
  int id_ = 0, orientation_ = 0;
  std::vector<std::size_t> orientation_segments_;
};

}  // namespace

bool ImucalOptions::IsValid(std::string* error) const {
  if (!(rate_hz > 0.0 && std::isfinite(rate_hz))) return invalid(error, "rate_hz must be > 0");
  if (!(accel_lsb_per_g > 0.0 && gyro_lsb_per_dps > 0.0)) return invalid(error, "the LSBs must be > 0");
  if (!(std::isfinite(accel_offset_counts) && std::isfinite(gyro_offset_counts))) return invalid(error, "the offsets must be finite");
  if (!(gravity_mps2 > 0.0 && std::isfinite(gravity_mps2))) return invalid(error, "gravity_mps2 must be > 0");
  return true;
}

void import_imucal_session(const fs::path& file, const ImucalOptions& opt, Recording& rec, SampleSink& out) {
  require_valid(opt, "imucal options");
  LineReader r(file);
  const ImucalColumns columns = read_imucal_header(r);
  const ImucalScan scan = scan_imucal(r, columns);
  rec = new_recording(file, "imucal");
  if (scan.truth) rec.header.truth_columns = kTruthColumns;  // before the samples: the run's layout
  const double acc_lsb = physics::kStandardGravity / opt.accel_lsb_per_g;
  const double gyr_lsb = physics::kDegPerSecond / opt.gyro_lsb_per_dps;
  set_int16_sensor_info(opt.rate_hz, acc_lsb, gyr_lsb, rec);
  rec.header.identity.model = "imucal example session";
  rec.header.gravity_mps2 = opt.gravity_mps2;

  ImucalRows rows(file, columns, scan.runs);
  ImucalSegments segments(opt.gravity_mps2);
  SampleChunker chunks(out);
  std::size_t gaps = 0;
  std::int64_t prev = 0;
  for (ImucalRow row; rows.next(row); prev = row.index) {
    ImuSample s = imucal_sample(row, opt, acc_lsb, gyr_lsb);
    if (chunks.count() > 0 && row.index != prev + 1) {  // a jump in the index
      s.flags |= kGapBefore;
      ++gaps;
    }
    segments.add(row.part, s.t_s, rec);
    chunks.add(s);
  }
  chunks.flush();
  segments.finish(rec);
  add_import_event(
      rec, "imported " + std::to_string(chunks.count()) + " samples from " + file.string() +
               " (imucal annotated session; rate " + fmt_g(opt.rate_hz) +
               " Hz; counts converted with the nominal " + fmt_g(opt.accel_lsb_per_g) +
               " LSB/g and " + fmt_g(opt.gyro_lsb_per_dps) +
               " LSB/(deg/s), which imucal's own calibration of this session (example_cal.json) "
               "matches within 3 % — SI values are uncalibrated approximations; gravity " +
               fmt_g(opt.gravity_mps2) + " m/s^2 is imucal's expected_g; truth from the annotations: "
               "<axis>_p = axis up (f = +g along it), <axis>_a = axis down (-g), rate 0" +
               (gaps ? "; " + std::to_string(gaps) + " gap(s) in the sample index" : "") + ")");
}

Recording import_imucal_session(const fs::path& file, const ImucalOptions& opt) {
  return import_in_memory([&](Recording& rec, SampleSink& out) { import_imucal_session(file, opt, rec, out); });
}

}  // namespace stend::io
