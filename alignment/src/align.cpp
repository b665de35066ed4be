// The blocks classified into stretches and the procedure's observed steps matched to them in time
// order, written as segments and truth. See align.hpp.
#include "stend/alignment/align.hpp"

#include <stend/physics/gravity.hpp>
#include <stend/physics/units.hpp>
#include <stend/recording/samples.hpp>
#include <stend/recording/truth_columns.hpp>
#include <stend/yaml/reader.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

namespace stend::alignment {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
using yaml::format_number;

enum class Motion { kStill, kSteadyRate, kMoving };

// A run of blocks of one class: [first, last] block indices, with their sums.
struct Stretch {
  Motion motion = Motion::kMoving;
  std::size_t first = 0, last = 0;
  double t0_s = 0.0, t1_s = 0.0;
  Block sum;  // the blocks' sums added up
  bool used = false;

  double duration_s() const { return t1_s - t0_s; }
  double mid_s() const { return 0.5 * (t0_s + t1_s); }
};

void add_block(Block& into, const Block& b) {
  into.n += b.n;
  into.accel_sum += b.accel_sum;
  into.accel_sq += b.accel_sq;
  into.gyro_sum += b.gyro_sum;
  into.gyro_sq += b.gyro_sq;
  into.gyro_dt += b.gyro_dt;
  into.dt_sum += b.dt_sum;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) / physics::kDegToRad;
}

std::string vec_text(const Eigen::Vector3d& v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.2f, %.2f, %.2f)", v[0], v[1], v[2]);
  return buf;
}

std::string time_text(double t0, double t1) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.2f–%.2f s", t0, t1);
  return buf;
}

// "+x", "-z" for an axis direction, else the vector.
std::string direction_text(const Eigen::Vector3d& d) {
  for (int i = 0; i < 3; ++i)
    if (std::abs(std::abs(d[i]) - 1.0) < 1e-9) return std::string(d[i] > 0 ? "+" : "-") + static_cast<char>('x' + i);
  return vec_text(d);
}

// --- blocks → stretches ------------------------------------------------------------------------

// The limits a still block keeps, from the quietest blocks of the recording.
struct Limits {
  double accel_std = 0.0, gyro_std = 0.0;  // [m/s²], [rad/s]
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();  // median over the quiet blocks [rad/s]
};

Limits still_limits(const std::vector<Block>& blocks, const AlignOptions& o) {
  std::vector<double> a, g;
  for (const auto& b : blocks) {
    if (b.n < 2) continue;
    a.push_back(std::sqrt(b.accel_var()));
    g.push_back(std::sqrt(b.gyro_var()));
  }
  Limits l;
  l.accel_std = std::max(o.noise_factor * quantile(a, 0.1), o.min_accel_std_mps2);
  l.gyro_std = std::max(o.noise_factor * quantile(g, 0.1), o.min_gyro_std_radps);
  std::array<std::vector<double>, 3> quiet;
  for (const auto& b : blocks)
    if (b.n >= 2 && std::sqrt(b.accel_var()) <= l.accel_std && std::sqrt(b.gyro_var()) <= l.gyro_std)
      for (int i = 0; i < 3; ++i) quiet[static_cast<std::size_t>(i)].push_back(b.gyro_mean()[i]);
  for (int i = 0; i < 3; ++i) l.gyro_bias[i] = quantile(quiet[static_cast<std::size_t>(i)], 0.5);
  return l;
}

Motion classify(const Block& b, const Limits& l, const AlignOptions& o) {
  if (b.n < 2) return Motion::kMoving;
  const double rate = (b.gyro_mean() - l.gyro_bias).norm();
  const double gstd = std::sqrt(b.gyro_var());
  if (rate < o.max_still_rate_dps * physics::kDegToRad && gstd <= l.gyro_std && std::sqrt(b.accel_var()) <= l.accel_std)
    return Motion::kStill;
  if (rate >= o.max_still_rate_dps * physics::kDegToRad && gstd <= l.gyro_std + o.rate_steadiness * rate)
    return Motion::kSteadyRate;
  return Motion::kMoving;
}

// Whether block b continues stretch s: same class, and a still keeps its gravity direction, a
// steady rate its rate.
bool continues(const Stretch& s, Motion m, const Block& b, const AlignOptions& o) {
  if (s.motion != m) return false;
  if (m == Motion::kStill) return angle_deg(s.sum.accel_mean(), b.accel_mean()) <= o.split_deg;
  if (m == Motion::kSteadyRate) {
    const Eigen::Vector3d w = s.sum.gyro_mean();
    return (b.gyro_mean() - w).norm() <= std::max(0.1 * w.norm(), o.max_still_rate_dps * physics::kDegToRad);
  }
  return true;
}

std::vector<Stretch> raw_stretches(const std::vector<Block>& blocks, const Limits& l, const AlignOptions& o) {
  std::vector<Stretch> out;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const Block& b = blocks[i];
    const Motion m = classify(b, l, o);
    if (out.empty() || !continues(out.back(), m, b, o)) out.push_back(Stretch{m, i, i, b.t0_s, b.t1_s, Block{}, false});
    Stretch& s = out.back();
    s.last = i;
    s.t1_s = b.t1_s;
    add_block(s.sum, b);
  }
  return out;
}

// Stills and steady rates shorter than min_stretch_s become motion; neighbouring motion joins.
std::vector<Stretch> stretches(const std::vector<Block>& blocks, const Limits& l, const AlignOptions& o) {
  std::vector<Stretch> out;
  for (Stretch s : raw_stretches(blocks, l, o)) {
    if (s.motion != Motion::kMoving && s.duration_s() < o.min_stretch_s) s.motion = Motion::kMoving;
    if (!out.empty() && out.back().motion == Motion::kMoving && s.motion == Motion::kMoving) {
      Stretch& m = out.back();
      m.last = s.last;
      m.t1_s = s.t1_s;
      add_block(m.sum, s.sum);
    } else {
      out.push_back(s);
    }
  }
  return out;
}

// --- matching ------------------------------------------------------------------------------------

// The alignment under construction: segments and held truth rows, in any order until finish().
class Builder {
 public:
  Builder(const Experiment& exp, const std::vector<Block>& blocks, const AlignOptions& o)
      : exp_(exp), blocks_(blocks), o_(o), limits_(still_limits(blocks, o)), stretches_(stretches(blocks, limits_, o)) {}

  Alignment run() {
    for (std::size_t i = 0; i < exp_.procedure.size(); ++i) step(static_cast<int>(i), exp_.procedure[i]);
    keep_unnamed_stills();
    return finish();
  }

 private:
  void step(int index, const Step& s) {
    switch (s.kind) {
      case Step::Kind::kFaces:
        for (std::size_t k = 0; k < s.faces_up.size(); ++k) face(index, s, static_cast<int>(k));
        break;
      case Step::Kind::kStill:
        if (s.count == 0) every_still(index, s);
        for (int k = 0; k < s.count; ++k) still(index, s, k);
        break;
      case Step::Kind::kTurns:
        for (int k = 0; k < s.count; ++k) turn(index, s, k);
        break;
      case Step::Kind::kRateLegs:
        for (std::size_t k = 0; k < s.rates.size(); ++k) leg(index, s, static_cast<int>(k));
        break;
      case Step::Kind::kRecord:  // with no table to say where: a still at an unstated orientation
        still(index, s, 0);
        break;
      case Step::Kind::kSetTemperature:
      case Step::Kind::kWait:
      case Step::Kind::kSetVibration:
        note(s, "not looked for: a log holds no chamber or shaker truth");
        break;
      case Step::Kind::kOrientations:
      case Step::Kind::kRates:
        fail(index, s, std::string("a '") + step_kind_name(s.kind) + "' step needs its table's geometry",
             "align through stend import --experiment, which turns table steps into the faces and rate legs they "
             "make (stend/core/procedure_geometry.hpp)");
    }
  }

  // Whether stretch i may serve step s: unused, in the step's window, long enough.
  bool candidate(std::size_t i, const Step& s, Motion m) const {
    const Stretch& x = stretches_[i];
    return !x.used && x.motion == m && x.mid_s() >= s.within_from_s && x.mid_s() <= s.within_to_s &&
           x.duration_s() >= std::max(o_.min_still_s, 0.5 * s.record_s);
  }

  // faces: the next still pointing the stated way.
  void face(int index, const Step& s, int k) {
    const Eigen::Vector3d up = s.faces_up[static_cast<std::size_t>(k)];
    std::string seen;
    for (std::size_t i = cursor_; i < stretches_.size(); ++i) {
      if (!candidate(i, s, Motion::kStill)) continue;
      const Eigen::Vector3d f = stretches_[i].sum.accel_mean();
      const double off = angle_deg(f, up);
      if (off <= o_.face_tolerance_deg) {
        Segment seg = segment(index, s, SegmentKind::kOrientation, i, k, static_cast<int>(s.faces_up.size()));
        seg.targets = direction_text(up) + " up";
        hold(seg, exp_.gravity.resolved_mps2 * up, earth_rate_along(up), nan3());
        note(s, "face " + std::to_string(k + 1) + " '" + seg.targets + "': " + time_text(seg.t_start_s, seg.t_end_s) +
                    ", measured gravity " + format_number(std::round(off * 10) / 10) + " deg from it");
        take(i, seg);
        return;
      }
      if (seen.size() < 400) seen += "; " + time_text(stretches_[i].t0_s, stretches_[i].t1_s) + " up along " + vec_text(f.normalized()) + " (" + format_number(std::round(off)) + " deg off)";
    }
    fail(index, s,
         "face " + std::to_string(k + 1) + " of " + std::to_string(s.faces_up.size()) + " ('" + direction_text(up) +
             " up'): no still stretch after " + format_number(after_s()) + " s points that way within " +
             format_number(o_.face_tolerance_deg) + " deg" + (seen.empty() ? "; no still stretch is left" : "; the stills there: " + seen.substr(2)),
         "check the order of the faces and the sensor axes' signs, or give the step a time window (within_s: [from, to])");
  }

  // still: the next still, any direction (of `count`; 0: all, numbered as found).
  bool still(int index, const Step& s, int k, bool required = true) {
    for (std::size_t i = cursor_; i < stretches_.size(); ++i) {
      if (!candidate(i, s, Motion::kStill)) continue;
      Segment seg = segment(index, s, SegmentKind::kOrientation, i, k, s.count);
      seg.targets = "still, orientation not stated";
      hold(seg, nan3(), earth_rate_along(stretches_[i].sum.accel_mean().normalized()), nan3());
      take(i, seg);
      return true;
    }
    if (!required) return false;
    fail(index, s, "still " + std::to_string(k + 1) + " of " + std::to_string(s.count) + ": no still stretch of at least " +
                       format_number(std::max(o_.min_still_s, 0.5 * s.record_s)) + " s after " + format_number(after_s()) + " s",
         "shorten record_s, or check that the sensor was left still");
  }

  // still with `count: all`: every still left in the window, at least one.
  void every_still(int index, const Step& s) {
    const std::size_t first = segments_.size();
    int k = 0;
    while (still(index, s, k, k == 0)) ++k;
    for (std::size_t i = first; i < segments_.size(); ++i) segments_[i].orientation_count = k;
    note(s, std::to_string(k) + " still(s) found");
  }

  // turns: the next motion between two stills that turns by the stated angle about the axis.
  void turn(int index, const Step& s, int k) {
    std::string seen;
    for (std::size_t i = cursor_; i < stretches_.size(); ++i) {
      if (stretches_[i].motion == Motion::kStill || stretches_[i].used) continue;
      std::size_t j = i;
      while (j + 1 < stretches_.size() && stretches_[j + 1].motion != Motion::kStill) ++j;
      const std::size_t first = i;
      i = j;  // the next candidate starts after this motion
      if (stretches_[first].mid_s() < s.within_from_s || stretches_[j].mid_s() > s.within_to_s) continue;
      const Eigen::Vector3d v = turned_deg(first, j);
      const double about = v.dot(s.sensor_axis);
      const double sign = s.direction != 0 ? s.direction : (about < 0 ? -1.0 : 1.0);
      const double off_axis = (v - about * s.sensor_axis).norm();
      if (std::abs(sign * about - s.angle_deg) <= o_.turn_tolerance * s.angle_deg && off_axis <= o_.turn_tolerance * s.angle_deg) {
        Segment seg = segment(index, s, SegmentKind::kRotation, k, s.count,
                              first > 0 ? stretches_[first - 1].t1_s : stretches_[first].t0_s,
                              j + 1 < stretches_.size() ? stretches_[j + 1].t0_s : stretches_[j].t1_s);
        seg.targets = format_number(sign * s.angle_deg) + " deg turn about " + direction_text(s.sensor_axis);
        hold_inside(seg, sign * s.angle_deg * s.sensor_axis);
        note(s, "turn " + std::to_string(k + 1) + ": " + time_text(seg.t_start_s, seg.t_end_s) + ", " +
                    format_number(std::round(about * 10) / 10) + " deg measured about " + direction_text(s.sensor_axis) +
                    (s.direction == 0 ? " (the sign taken from the data)" : ""));
        for (std::size_t x = first; x <= j; ++x) stretches_[x].used = true;
        segments_.push_back(seg);
        cursor_ = j + 1;
        return;
      }
      if (seen.size() < 400)
        seen += "; " + time_text(stretches_[first].t0_s, stretches_[j].t1_s) + " turned " + vec_text(v) + " deg";
    }
    fail(index, s,
         "turn " + std::to_string(k + 1) + " of " + std::to_string(s.count) + " (" + format_number(s.angle_deg) + " deg about " +
             direction_text(s.sensor_axis) + "): no motion between two stills after " + format_number(after_s()) +
             " s turns by that angle about that axis (within " + format_number(o_.turn_tolerance * 100) + " %)" +
             (seen.empty() ? "; no motion is left" : "; the motions there: " + seen.substr(2)),
         "a turn must start and end still; check the axis, the angle and the order of the steps");
  }

  // rate_legs: the next steady rate about the axis at the stated rate.
  void leg(int index, const Step& s, int k) {
    const double rate_dps = s.rates[static_cast<std::size_t>(k)];
    std::string seen;
    for (std::size_t i = cursor_; i < stretches_.size(); ++i) {
      if (!candidate(i, s, Motion::kSteadyRate)) continue;
      const Eigen::Vector3d w = (stretches_[i].sum.gyro_mean() - limits_.gyro_bias) / physics::kDegToRad;
      const double about = w.dot(s.sensor_axis);
      if (std::abs(about - rate_dps) <= o_.rate_tolerance * std::abs(rate_dps) &&
          (w - about * s.sensor_axis).norm() <= o_.rate_tolerance * std::abs(rate_dps)) {
        Segment seg = segment(index, s, SegmentKind::kRate, i, k, static_cast<int>(s.rates.size()));
        seg.rate = rate_dps;
        seg.targets = "rate=" + format_number(rate_dps) + " deg/s about " + direction_text(s.sensor_axis);
        const Eigen::Vector3d f = s.up ? Eigen::Vector3d(exp_.gravity.resolved_mps2 * *s.up) : nan3();
        const Eigen::Vector3d earth = s.up ? earth_rate_along(*s.up) : Eigen::Vector3d::Zero();
        hold(seg, f, rate_dps * physics::kDegToRad * s.sensor_axis + earth, nan3());
        note(s, "leg " + std::to_string(k + 1) + " (" + format_number(rate_dps) + " deg/s): " + time_text(seg.t_start_s, seg.t_end_s) +
                    ", " + format_number(std::round(about * 100) / 100) + " deg/s measured");
        take(i, seg);
        return;
      }
      if (seen.size() < 400) seen += "; " + time_text(stretches_[i].t0_s, stretches_[i].t1_s) + " at " + vec_text(w) + " deg/s";
    }
    fail(index, s,
         "leg " + std::to_string(k + 1) + " of " + std::to_string(s.rates.size()) + " (" + format_number(rate_dps) + " deg/s about " +
             direction_text(s.sensor_axis) + "): no steady rate after " + format_number(after_s()) + " s within " +
             format_number(o_.rate_tolerance * 100) + " % of it" + (seen.empty() ? "; no steady rate is left" : "; the steady rates there: " + seen.substr(2)),
         "check the axis, the sign of the rates and their order; a leg must hold its rate for at least " +
             format_number(o_.min_still_s) + " s");
  }

  // The rotation over stretches [first, last] [deg, sensor frame], the gyro bias from the stills
  // beside them (or the recording's quiet blocks) taken out.
  Eigen::Vector3d turned_deg(std::size_t first, std::size_t last) const {
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    int n = 0;
    const auto beside = [&](std::size_t x) {
      if (stretches_[x].motion != Motion::kStill) return;
      b += stretches_[x].sum.gyro_mean();
      ++n;
    };
    if (first > 0) beside(first - 1);
    if (last + 1 < stretches_.size()) beside(last + 1);
    b = n > 0 ? Eigen::Vector3d(b / n) : limits_.gyro_bias;
    Block sum;
    for (std::size_t x = first; x <= last; ++x) add_block(sum, stretches_[x].sum);
    return (sum.gyro_dt - b * sum.dt_sum) / physics::kDegToRad;
  }

  // The segment of item k of `count` of step s over [t0, t1] [s].
  static Segment segment(int index, const Step& s, SegmentKind kind, int k, int count, double t0_s, double t1_s) {
    Segment seg{};
    seg.step = index;
    seg.kind = kind;
    seg.label = s.label;
    seg.repeat = s.repeat_index;
    seg.orientation = k;
    seg.orientation_count = count;
    seg.t_start_s = t0_s;
    seg.t_end_s = t1_s;
    return seg;
  }
  // … over stretch i.
  Segment segment(int index, const Step& s, SegmentKind kind, std::size_t i, int k, int count) const {
    return segment(index, s, kind, k, count, stretches_[i].t0_s, stretches_[i].t1_s);
  }

  void take(std::size_t i, const Segment& seg) {
    stretches_[i].used = true;
    segments_.push_back(seg);
    cursor_ = i + 1;
  }

  // Held truth over a still or leg: at its start, middle and end.
  void hold(const Segment& seg, const Eigen::Vector3d& f, const Eigen::Vector3d& w, const Eigen::Vector3d& turn) {
    for (double t : {seg.t_start_s, 0.5 * (seg.t_start_s + seg.t_end_s), seg.t_end_s}) row(t, f, w, turn);
  }
  // Held truth of a turn: strictly inside it, so the stills beside it (which share its end
  // times) never average it in.
  void hold_inside(const Segment& seg, const Eigen::Vector3d& turn_deg) {
    for (double q : {0.25, 0.5, 0.75}) row(seg.t_start_s + q * (seg.t_end_s - seg.t_start_s), nan3(), nan3(), turn_deg);
  }
  void row(double t, const Eigen::Vector3d& f, const Eigen::Vector3d& w, const Eigen::Vector3d& turn) {
    rows_.emplace(t, std::vector<double>{f[0], f[1], f[2], w[0], w[1], w[2], turn[0], turn[1], turn[2]});
  }

  // The Earth rate's vertical component along the sensor direction `up` (stated, or measured for a
  // still at an unstated orientation) [rad/s], when the site's latitude is known; else 0 (an MEMS
  // gyro hardly resolves it; said in the notes). The horizontal part depends on the heading, which
  // no step states.
  Eigen::Vector3d earth_rate_along(const Eigen::Vector3d& up) const {
    if (!exp_.gravity.latitude_known()) return Eigen::Vector3d::Zero();
    return physics::earth_rate_local(exp_.gravity.latitude_deg).z() * up;
  }

  // Stills no step named: detected segments with unknown truth.
  void keep_unnamed_stills() {
    int kept = 0;
    for (std::size_t i = 0; i < stretches_.size(); ++i) {
      const Stretch& x = stretches_[i];
      if (x.used || x.motion != Motion::kStill) continue;
      Segment seg{};
      seg.step = -1;
      seg.kind = SegmentKind::kDetected;
      seg.label = "still not in the procedure";
      seg.t_start_s = x.t0_s;
      seg.t_end_s = x.t1_s;
      seg.targets = "gravity along " + vec_text(x.sum.accel_mean().normalized());
      hold(seg, nan3(), earth_rate_along(x.sum.accel_mean().normalized()), nan3());
      segments_.push_back(seg);
      ++kept;
    }
    if (kept > 0) notes_.push_back(std::to_string(kept) + " still stretch(es) the procedure does not name kept as detected segments");
  }

  Alignment finish() {
    Alignment a;
    a.truth_columns = aligned_truth_columns();
    std::sort(segments_.begin(), segments_.end(), [](const Segment& x, const Segment& y) { return x.t_start_s < y.t_start_s; });
    for (std::size_t i = 0; i < segments_.size(); ++i) segments_[i].id = static_cast<int>(i);
    a.segments = std::move(segments_);
    for (auto& [t, values] : rows_) {
      a.truth_t.push_back(t);
      a.truth.push_back(std::move(values));
    }
    if (!exp_.gravity.latitude_known())
      notes_.push_back("the site's latitude is not stated (bench.gravity.latitude_deg): the Earth rate is taken as 0 in the truth");
    a.notes = std::move(notes_);
    return a;
  }

  void note(const Step& s, const std::string& text) { notes_.push_back("step '" + s.label + "': " + text); }

  [[noreturn]] void fail(int index, const Step& s, const std::string& message, const std::string& hint) const {
    throw AlignmentError(s.where, "procedure[" + std::to_string(index) + "]",
                         "step '" + s.label + "' (" + step_kind_name(s.kind) + "): " + message, hint);
  }

  double after_s() const { return cursor_ > 0 ? stretches_[cursor_ - 1].t1_s : (blocks_.empty() ? 0.0 : blocks_.front().t0_s); }
  static Eigen::Vector3d nan3() { return Eigen::Vector3d::Constant(kNaN); }

  const Experiment& exp_;
  const std::vector<Block>& blocks_;
  const AlignOptions& o_;
  Limits limits_;
  std::vector<Stretch> stretches_;
  std::size_t cursor_ = 0;
  std::vector<Segment> segments_;
  std::map<double, std::vector<double>> rows_;  // held truth by time (a time already held keeps its first row)
  std::vector<std::string> notes_;
};

}  // namespace

std::vector<std::string> aligned_truth_columns() {
  return truth_column_names({kSpecificForceColumns, kRateColumns, kTurnColumns});
}

std::string Alignment::summary() const {
  std::map<SegmentKind, int> by_kind;
  for (const auto& s : segments) ++by_kind[s.kind];
  std::string out = "aligned to the procedure:";
  for (const auto& [kind, n] : by_kind) out += " " + std::to_string(n) + " " + to_string(kind);
  return out + " segment(s)";
}

Alignment align(const Experiment& exp, const std::vector<Block>& blocks, const AlignOptions& options) {
  require_valid(options, "alignment options");
  if (!exp.gravity.stated)
    throw AlignmentError(SourceLocation{exp.file, 0, 0}, "bench.gravity",
                         "the experiment states no site: the truth of a face needs the local gravity",
                         "add bench: {gravity: {latitude_deg: 49.6, height_m: 300}} (or value_mps2: measured g)");
  if (blocks.empty()) throw InputError("the recording has no samples to align the procedure to");
  return Builder(exp, blocks, options).run();
}

void align_header(RecordingHeader& h, const Experiment& exp) {
  h.truth_columns = aligned_truth_columns();
  h.gravity_mps2 = exp.gravity.resolved_mps2;
  if (exp.gravity.latitude_known()) h.latitude_deg = exp.gravity.latitude_deg;
}

void apply_alignment(Recording& rec, const Experiment& exp, Alignment a) {
  const std::string summary = a.summary();
  rec.header.truth_columns = a.truth_columns;
  rec.truth_store.reset();
  rec.truth_t = std::move(a.truth_t);
  rec.truth = std::move(a.truth);
  rec.truth_rows = rec.truth_t.size();
  rec.segments = std::move(a.segments);
  rec.events.push_back({0.0, "info", "import",
                        "procedure from " + exp.file + " (experiment '" + exp.name + "'): " + summary});
  for (const auto& n : a.notes) rec.events.push_back({0.0, "info", "import", "alignment: " + n});
}

void align_recording(Recording& rec, const Experiment& exp, const AlignOptions& options) {
  Observer observer(options);
  for_each_chunk(rec.sample_source(), 0, rec.sample_count(),
                 [&](const ImuSample* chunk, std::size_t n, std::uint64_t) { observer.add(chunk, n); });
  const bool had_own = !rec.segments.empty() || rec.truth_rows > 0;
  align_header(rec.header, exp);
  apply_alignment(rec, exp, align(exp, observer.finish(), observer.options()));
  rec.experiment_yaml = exp.resolved_yaml;
  if (had_own) rec.events.push_back({0.0, "info", "import", "the log's own segments and truth were replaced by the procedure's"});
}

}  // namespace stend::alignment
