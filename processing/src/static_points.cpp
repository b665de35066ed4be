// Recording → static points. See stend/processing/static_points.hpp.
#include "stend/processing/static_points.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <stend/errors.hpp>

#include "stend/processing/static_detector.hpp"
#include "stend/processing/truth.hpp"
#include "stend/recording/truth_columns.hpp"
#include "stend/recording/instruments.hpp"

namespace stend::processing {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

void require_increasing_times(const Recording& rec) {
  double prev = 0.0;
  for_each_chunk(rec.sample_source(), [&](const ImuSample* c, std::size_t n, std::uint64_t first) {
    for (std::size_t k = 0; k < n; ++k) {
      if (first + k > 0 && !(c[k].t_s > prev))
        throw InputError("recording '" + rec.dir.string() + "': sample times are not " +
                                 "strictly increasing at sample " + std::to_string(first + k) + " (t = " +
                                 num(c[k].t_s) + " s)");
      prev = c[k].t_s;
    }
  });
}

std::vector<Segment> segments_of_kinds(const Recording& rec, const ProcessingOptions& o,
                                       std::vector<std::string>& notes) {
  std::vector<Segment> out;
  for (const Segment& s : rec.segments)
    if (o.selects(s.kind)) out.push_back(s);
  if (out.empty()) {
    std::vector<std::string> present;
    for (const auto& s : rec.segments)
      if (std::find(present.begin(), present.end(), to_string(s.kind)) == present.end()) present.emplace_back(to_string(s.kind));
    notes.push_back("the recording has no segment of kind " + join(o.segment_kinds) + " (kinds present: " +
                    (present.empty() ? "none" : join(present)) + ")");
  }
  return out;
}

std::vector<Segment> detected_segments(const Recording& rec, const StaticDetectorOptions& o,
                                       std::optional<DetectionSummary>& summary) {
  const Detection found = detect_static(rec, o);
  summary = found.summary;
  std::vector<Segment> out;
  for (const DetectedInterval& iv : found.intervals) {
    Segment s;
    s.id = static_cast<int>(out.size());
    s.kind = SegmentKind::kDetected;
    s.label = "static_" + std::to_string(s.id);
    s.t_start_s = iv.t_start_s;
    s.t_end_s = iv.t_end_s;
    out.push_back(s);
  }
  return out;
}

// Step 1: the intervals, as segments.
std::vector<Segment> intervals(const Recording& rec, const ProcessingOptions& o, Extraction& out) {
  IntervalSource source = o.intervals;
  if (source == IntervalSource::kAuto)
    source = rec.segments.empty() ? IntervalSource::kDetect : IntervalSource::kSegments;
  if (source == IntervalSource::kDetect && holds_means(rec)) {
    out.notes.push_back("a table of means: its rows (segments) are the static points, not detected (held values do "
                        "not vary)");
    source = IntervalSource::kSegments;
  }
  if (source == IntervalSource::kSegments) return segments_of_kinds(rec, o, out.notes);
  std::vector<Segment> found = detected_segments(rec, o.detector, out.detection);
  if (o.intervals == IntervalSource::kAuto)
    out.notes.push_back("the recording has no segments: " + std::to_string(found.size()) +
                        " static intervals detected in the samples");
  out.notes.push_back(out.detection->print());
  return found;
}

// Steps 2–5 for one interval.
class PointBuilder {
 public:
  PointBuilder(const Recording& rec, const ProcessingOptions& o, const Request& req, Extraction& out)
      : rec_(rec), o_(o), req_(req), out_(out) {
    for (const auto& name : req.truth_columns) add_column(name);
    for (std::size_t a = 0; a < 3; ++a) {
      input_at_[a] = req.stimulus.input[a].empty() ? -1 : add_column(req.stimulus.input[a]);
      force_at_[a] = req.stimulus.specific_force[a].empty() ? -1 : add_column(req.stimulus.specific_force[a]);
    }
    requests_truth_ = !columns_.empty();
    die_ = rec.truth_column(kDieTemperatureColumn);
    if (die_ >= 0) {
      die_at_ = static_cast<int>(columns_.size());
      columns_.push_back(die_);
    }
    if (holds_means(rec)) {
      held_at_ = static_cast<int>(columns_.size());
      for (const auto& name : held_column_names()) columns_.push_back(rec.truth_column(name));
    }
    saturation_ = (req.accel ? kAccelSaturated : 0u) | (req.gyro ? kGyroSaturated : 0u);
  }

  void add(const Segment& seg) {
    const std::string what = describe(seg);
    if (!seg.complete) return skip(seg, SkipReason::kIncomplete, what + ": incomplete (the run stopped inside it)");
    if (!seg.settled) return skip(seg, SkipReason::kUnsettled, what + ": the fixtures/chamber were not settled");
    StaticPoint p;
    p.segment = seg;
    try {
      extract_axes(p);
    } catch (const SkipError& e) {
      return skip(seg, e.reason(), what + ": " + e.what());
    }
    const Window w = scan_window(p);
    if (w.saturated > 0)
      return skip(seg, SkipReason::kSaturated, what + ": " + std::to_string(w.saturated) + " saturated sample(s)");
    if (p.gaps > 0)
      out_.notes.push_back(what + ": " + std::to_string(p.gaps) +
                           " gap(s) in the kept window; the filter assumed uniform sampling");
    if (!add_truth(p, w.sensor_temperature_c))
      return skip(seg, SkipReason::kNoTruth, what + ": no truth snapshot at or before its window");
    out_.points.push_back(std::move(p));
  }

 private:
  // Step 3: the requested instruments' axes over the segment's samples (read a column at a time);
  // sets the kept window.
  void extract_axes(StaticPoint& p) const {
    const SampleSource& src = rec_.sample_source();
    const std::uint64_t first = lower_bound_time(src, p.segment.t_start_s);
    const std::uint64_t end = std::max(first, lower_bound_time(src, std::nextafter(p.segment.t_end_s, kInf)));
    const std::vector<double> t = read_column(src, Channel::kTime, first, end);
    const double rate_hz = segment_sample_rate(t, p.segment.t_start_s, p.segment.t_end_s);
    if (req_.accel) p.accel = axes(first, end, t, rate_hz, Channel::kAx, p);
    if (req_.gyro) p.gyro = axes(first, end, t, rate_hz, Channel::kGx, p);
  }

  // One instrument's three axes (channels x, x + 1, x + 2) over samples [first, end) at times t
  // (their segment's sample rate rate_hz).
  AxesValue axes(std::uint64_t first, std::uint64_t end, const std::vector<double>& t, double rate_hz, Channel x,
                 StaticPoint& p) const {
    AxesValue v;
    for (int a = 0; a < 3; ++a) {
      const auto c = static_cast<Channel>(static_cast<int>(x) + a);
      const StaticValue s = extract_static(t, read_column(rec_.sample_source(), c, first, end), p.segment.t_start_s,
                                           p.segment.t_end_s, o_.extraction, rate_hz);
      v.mean[a] = s.mean;
      v.sample_std[a] = s.raw_std;
      v.std_error[a] = s.white_std_error;
      v.correlated_std_error[a] = s.correlated_std_error;
      p.t_start_s = s.t_first_s;
      p.t_end_s = s.t_last_s;
      p.samples_used = s.n_used;
    }
    p.first = first + static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), p.t_start_s) - t.begin());
    p.last = p.first + p.samples_used - 1;
    return v;
  }

  // Step 4: flags and the sensor's temperature over the kept window; sets p.gaps.
  struct Window {
    std::size_t saturated = 0;
    double sensor_temperature_c = 0.0;  // mean
  };
  Window scan_window(StaticPoint& p) const {
    Window w;
    for_each_chunk(rec_.sample_source(), p.first, p.last + 1, [&](const ImuSample* c, std::size_t n, std::uint64_t at) {
      for (std::size_t k = 0; k < n; ++k) {
        const ImuSample& s = c[k];
        if (s.flags & saturation_) ++w.saturated;
        if (at + k > p.first && (s.flags & kGapBefore)) ++p.gaps;
        w.sensor_temperature_c += s.temperature_c;
      }
    });
    w.sensor_temperature_c /= static_cast<double>(p.samples_used);
    return w;
  }

  // The requested truth column `name` read over every window; returns its place in columns_.
  int add_column(const std::string& name) {
    const int c = rec_.truth_column(name);
    if (c < 0) throw std::invalid_argument("processing: the recording has no truth column '" + name + "'");
    columns_.push_back(c);
    return static_cast<int>(columns_.size()) - 1;
  }

  // Step 5: truth means, stimulus and temperature over the kept window; false when truth was
  // requested and there is none.
  bool add_truth(StaticPoint& p, double sensor_temperature_c) const {
    const TruthMean truth = truth_mean(rec_, columns_, p.t_start_s, p.t_end_s);
    if (!truth.found && requests_truth_) return false;
    p.truth.assign(truth.values.begin(), truth.values.begin() + static_cast<std::ptrdiff_t>(req_.truth_columns.size()));
    model::Stimulus<double>& st = p.stimulus;
    for (std::size_t a = 0; a < 3; ++a) {
      const auto i = static_cast<Eigen::Index>(a);
      if (input_at_[a] >= 0) st.input[i] = truth.values[static_cast<std::size_t>(input_at_[a])];
      if (force_at_[a] >= 0) st.specific_force[i] = truth.values[static_cast<std::size_t>(force_at_[a])];
    }
    if (held_at_ >= 0 && truth.found) add_held(p, truth.values);
    if (die_ >= 0 && truth.found) {
      st.temperature_c = truth.values[static_cast<std::size_t>(die_at_)];
      st.temperature_rate_cps = truth_slope(rec_, die_, p.t_start_s, p.t_end_s);
      p.temperature_source = TemperatureSource::kDie;
    } else {
      st.temperature_c = rec_.header.info.has_temperature ? sensor_temperature_c : kNaN;  // absent is absent
    }
    st.time_s = 0.5 * (p.t_start_s + p.t_end_s);
    return true;
  }

  // A held mean's stated noise (held_at_: n, then sigma x, y, z) as its accelerometer's (HeldMean).
  void add_held(StaticPoint& p, const std::vector<double>& values) const {
    HeldMean h;
    const auto at = static_cast<std::size_t>(held_at_);
    h.n = values[at];
    for (int a = 0; a < 3; ++a) h.sigma[a] = values[at + 1 + static_cast<std::size_t>(a)];
    p.held = h;
    if (!req_.accel) return;
    p.accel.sample_std = h.sigma;
    p.accel.std_error = p.accel.correlated_std_error =
        h.absolute() ? h.std_error() : Eigen::Vector3d(Eigen::Vector3d::Constant(kNaN));
  }

  void skip(const Segment& seg, SkipReason reason, const std::string& what_why) {
    out_.skipped.push_back({seg, reason, "skipped " + what_why});
    out_.notes.push_back(out_.skipped.back().note);
  }

  const Recording& rec_;
  const ProcessingOptions& o_;
  const Request& req_;
  Extraction& out_;
  std::vector<int> columns_;  // truth columns requested, the stimulus', then die_c when present
  bool requests_truth_ = false;
  std::array<int, 3> input_at_{-1, -1, -1}, force_at_{-1, -1, -1};  // places in columns_, −1 none
  int die_ = -1;
  int die_at_ = -1;   // place of die_c in columns_
  int held_at_ = -1;  // place of the held-mean columns in columns_ (a table of means), −1 none
  std::uint32_t saturation_ = 0;
};

}  // namespace

const char* skip_reason_name(SkipReason reason) {
  switch (reason) {
    case SkipReason::kIncomplete: return "incomplete";
    case SkipReason::kUnsettled: return "unsettled";
    case SkipReason::kTooFewSamples: return "too_few_samples";
    case SkipReason::kFilter: return "filter";
    case SkipReason::kSaturated: return "saturated";
    case SkipReason::kNoTruth: break;
  }
  return "no_truth";
}

std::size_t Extraction::count(SkipReason reason) const {
  return static_cast<std::size_t>(
      std::count_if(skipped.begin(), skipped.end(), [&](const Skip& s) { return s.reason == reason; }));
}

std::string Extraction::tally() const {
  const std::size_t intervals = points.size() + skipped.size();
  std::string out = std::to_string(intervals) + " interval(s)";
  if (intervals == 0 && !detection) return out + ": no segment of kind " + join(options.segment_kinds);
  out += ", " + std::to_string(points.size()) + " kept";
  std::vector<std::string> reasons;
  for (SkipReason r : kAllSkipReasons)
    if (count(r) > 0) reasons.push_back(std::to_string(count(r)) + " " + skip_reason_name(r));
  if (!reasons.empty()) out += "; skipped: " + join(reasons);
  if (detection) out += "; " + detection->rejections();
  return out;
}

bool holds_means(const Recording& rec) {
  const auto names = held_column_names();
  return std::all_of(names.begin(), names.end(), [&](const std::string& c) { return rec.truth_column(c) >= 0; });
}

const AxesValue& StaticPoint::axes(model::Instrument instrument) const {
  return instrument == model::Instrument::kAccelerometer ? accel : gyro;
}
AxesValue& StaticPoint::axes(model::Instrument instrument) {
  return instrument == model::Instrument::kAccelerometer ? accel : gyro;
}

std::string label(const Segment& s) {
  if (!s.label.empty()) return s.label;
  if (s.orientation >= 0) return std::string(to_string(s.kind)) + " " + std::to_string(s.orientation + 1);
  return describe(s);
}

namespace {

// The request less what the recording lacks (an absent instrument's values are never read: its
// axes stay NaN); InputError when nothing requested is present.
Request present_only(const Recording& rec, const Request& request) {
  Request r = request;
  r.accel = r.accel && has_instrument(rec.header.info, model::Instrument::kAccelerometer);
  r.gyro = r.gyro && has_instrument(rec.header.info, model::Instrument::kGyroscope);
  if (r.accel || r.gyro) return r;
  throw InputError(rec.dir.string() + ": " +
                   absent_text(request.accel ? model::Instrument::kAccelerometer : model::Instrument::kGyroscope));
}

}  // namespace

std::string describe(const Segment& s) {
  std::string out = "segment " + std::to_string(s.id) + " (" + to_string(s.kind);
  if (!s.label.empty()) out += " '" + s.label + "'";
  if (s.orientation >= 0)
    out += ", orientation " + std::to_string(s.orientation + 1) + "/" + std::to_string(s.orientation_count);
  return out + ", " + num(s.t_start_s) + "–" + num(s.t_end_s) + " s)";
}

Extraction extract(const Recording& rec, const ProcessingOptions& options, const Request& request) {
  Extraction out;
  out.options = resolve(options, rec);
  std::string why;
  if (!out.options.IsValid(&why)) throw std::invalid_argument("processing options: " + why);
  if (!request.accel && !request.gyro)
    throw std::invalid_argument("processing: nothing requested (neither accelerometer nor gyroscope)");
  const Request present = present_only(rec, request);
  PointBuilder builder(rec, out.options, present, out);
  if (rec.truth_column(kDieTemperatureColumn) < 0)
    out.notes.push_back(rec.header.info.has_temperature
                            ? "no 'die_c' truth column: the temperature of each point is the sensor's own "
                              "temperature reading"
                            : "no temperature recorded: the points have none (NaN)");
  require_increasing_times(rec);
  for (const Segment& seg : intervals(rec, out.options, out)) builder.add(seg);
  return out;
}

}  // namespace stend::processing
