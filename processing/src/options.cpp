// Processing options: ranges, YAML keys, and the experiment's processing section as the fallback
// for what a model file does not state. See stend/processing/options.hpp.
#include "stend/processing/options.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <yaml-cpp/yaml.h>

#include "stend/physics/geometry.hpp"

namespace stend::processing {

namespace {

std::string num(double v) { return yaml::format_number(v); }

const std::vector<std::string> kSourceNames = {"segments", "detect", "auto"};
const std::vector<std::string> kFilterNames = {"butterworth", "none"};

IntervalSource source_from(const std::string& name) {
  if (name == "segments") return IntervalSource::kSegments;
  if (name == "detect") return IntervalSource::kDetect;
  return IntervalSource::kAuto;
}

// Whether `key` of `r` is to be read (present, and not kept), recorded as stated under `name`.
bool take(const yaml::MapReader& r, const std::string& key, const std::string& name,
          const std::set<std::string>& keep, ProcessingOptions& o) {
  if (!r.has(key) || keep.count(name) > 0) return false;
  o.stated.insert(name);
  return true;
}

std::string choice(const yaml::MapReader& r, const std::string& key,
                   const std::vector<std::string>& allowed) {
  const std::string s = r.string(key, "");
  if (std::find(allowed.begin(), allowed.end(), s) == allowed.end())
    r.fail_value(key, "expected one of " + yaml::join(allowed) + ", got '" + s + "'",
                 yaml::did_you_mean(s, allowed));
  return s;
}

std::vector<std::string> segment_kinds(const yaml::MapReader& m) {
  const YAML::Node seg = m.get("segments");
  if (!seg.IsSequence() || seg.size() == 0)
    m.fail_value("segments", "expected a non-empty list of segment kinds such as [orientation]");
  std::vector<std::string> kinds;
  for (std::size_t i = 0; i < seg.size(); ++i) {
    const std::string path = m.child_path("segments") + "[" + std::to_string(i) + "]";
    const std::string k = yaml::as_string(seg[i], m.file(), path);
    if (!segment_kind_from_string(k))
      throw ExperimentError(yaml::location_of(seg[i], m.file()), path,
                            "unknown segment kind '" + k + "'",
                            yaml::did_you_mean(k, segment_kind_names()) +
                                "segment kinds: " + yaml::join(segment_kind_names()));
    kinds.push_back(k);
  }
  return kinds;
}

// Throws at the key of `r` whose value options.problem() names, when it lies in `r` (`prefix`:
// the mapping's path in the key names, "" / "extraction." / "detector.").
void check(const yaml::MapReader& r, const std::string& prefix, const ProcessingOptions& o) {
  const auto p = o.problem();
  if (!p || p->key.rfind(prefix, 0) != 0) return;
  const std::string leaf = p->key.substr(prefix.size());
  if (r.has(leaf)) r.fail_value(leaf, leaf + ": " + p->message);
}

void read_extraction(const yaml::MapReader& m, ProcessingOptions& o, const std::set<std::string>& keep) {
  const yaml::MapReader ex(m.get("extraction"), m.file(), m.child_path("extraction"),
                           "static extraction settings",
                           {"filter", "filter_order", "cutoff_hz", "settle_s", "zero_phase"}, {},
                           m.key_location("extraction"));
  StaticExtractionSettings& s = o.extraction;
  if (take(ex, "filter", "extraction.filter", keep, o))
    s.filter = choice(ex, "filter", kFilterNames) == "none" ? Filter::kNone : Filter::kButterworth;
  if (take(ex, "filter_order", "extraction.filter_order", keep, o))
    s.filter_order = static_cast<int>(std::clamp<std::int64_t>(
        ex.integer("filter_order", 0), std::numeric_limits<int>::min(), std::numeric_limits<int>::max()));
  if (take(ex, "cutoff_hz", "extraction.cutoff_hz", keep, o))
    s.cutoff_hz = ex.number("cutoff_hz", 0.0, "in hertz");
  if (take(ex, "settle_s", "extraction.settle_s", keep, o)) s.settle_s = ex.number("settle_s", 0.0, "in seconds");
  if (take(ex, "zero_phase", "extraction.zero_phase", keep, o)) s.zero_phase = ex.boolean("zero_phase", true);
  check(ex, "extraction.", o);
}

void read_detector(const yaml::MapReader& m, ProcessingOptions& o, const std::set<std::string>& keep) {
  const yaml::MapReader d(m.get("detector"), m.file(), m.child_path("detector"), "static-interval detector",
                          {"window_s", "min_duration_s", "variance_threshold_m2ps4", "threshold_multiplier",
                           "init_duration_s", "trim_s", "max_gyro_dps"},
                          {}, m.key_location("detector"));
  StaticDetectorOptions& s = o.detector;
  auto number = [&](const char* key, double& field, const char* unit) {
    if (take(d, key, std::string("detector.") + key, keep, o)) field = d.number(key, 0.0, unit);
  };
  number("window_s", s.window_s, "in seconds");
  number("min_duration_s", s.min_duration_s, "in seconds");
  number("variance_threshold_m2ps4", s.variance_threshold, "in (m/s^2)^2");
  number("threshold_multiplier", s.threshold_multiplier, "");
  number("init_duration_s", s.init_duration_s, "in seconds");
  number("trim_s", s.trim_s, "in seconds");
  if (take(d, "max_gyro_dps", "detector.max_gyro_dps", keep, o))
    s.max_gyro_radps = d.number("max_gyro_dps", 0.0, "in deg/s") * physics::kDegToRad;
  check(d, "detector.", o);
}

}  // namespace

const char* interval_source_name(IntervalSource source) {
  switch (source) {
    case IntervalSource::kSegments: return "segments";
    case IntervalSource::kDetect: return "detect";
    case IntervalSource::kAuto: break;
  }
  return "auto";
}

bool ProcessingOptions::selects(SegmentKind k) const {
  return std::find(segment_kinds.begin(), segment_kinds.end(), to_string(k)) != segment_kinds.end();
}

namespace {

bool at_least(double v, double lo, bool open) { return std::isfinite(v) && (open ? v > lo : v >= lo); }

// "KEY: what is wrong" of a problem, for IsValid.
bool report(const std::optional<OptionProblem>& p, std::string* message) {
  if (p && message) *message = p->key + ": " + p->message;
  return !p;
}

}  // namespace

std::optional<OptionProblem> StaticExtractionSettings::problem() const {
  if (filter == Filter::kButterworth && (filter_order < 1 || filter_order > 20))
    return OptionProblem{"filter_order",
                         "Butterworth order " + std::to_string(filter_order) + " is outside 1..20 (the paper uses 6)"};
  if (filter == Filter::kButterworth && !at_least(cutoff_hz, 0.0, true))
    return OptionProblem{"cutoff_hz", "the cutoff frequency must be positive, got " + num(cutoff_hz) + " Hz"};
  if (!at_least(settle_s, 0.0, false))
    return OptionProblem{"settle_s", "the settling time must not be negative, got " + num(settle_s) + " s"};
  return std::nullopt;
}

bool StaticExtractionSettings::IsValid(std::string* message) const { return report(problem(), message); }

std::optional<OptionProblem> StaticDetectorOptions::problem() const {
  if (!at_least(window_s, 0.0, false))
    return OptionProblem{"window_s", "must be >= 0 (in seconds; 0: from the sample rate), got " + num(window_s)};
  if (!at_least(min_duration_s, 0.0, false))
    return OptionProblem{"min_duration_s", "must be >= 0 (in seconds; 0: from the window), got " + num(min_duration_s)};
  if (!at_least(variance_threshold, 0.0, false))
    return OptionProblem{"variance_threshold_m2ps4",
                         "must be >= 0 (in (m/s^2)^2; 0: automatic), got " + num(variance_threshold)};
  if (!at_least(threshold_multiplier, 0.0, false))
    return OptionProblem{"threshold_multiplier", "must be >= 0 (0: scanned), got " + num(threshold_multiplier)};
  if (!at_least(init_duration_s, 0.0, false))
    return OptionProblem{"init_duration_s",
                         "must be >= 0 (in seconds; 0: the recording's initialization segment), got " + num(init_duration_s)};
  if (!at_least(trim_s, 0.0, false)) return OptionProblem{"trim_s", "must be >= 0 (in seconds), got " + num(trim_s)};
  if (!at_least(max_gyro_radps, 0.0, false))
    return OptionProblem{"max_gyro_dps",
                         "must be >= 0 (in deg/s; 0: no limit), got " + num(max_gyro_radps / physics::kDegToRad)};
  return std::nullopt;
}

bool StaticDetectorOptions::IsValid(std::string* message) const { return report(problem(), message); }

std::optional<OptionProblem> ProcessingOptions::problem() const {
  if (segment_kinds.empty()) return OptionProblem{"segments", "expected a non-empty list of segment kinds such as [orientation]"};
  for (const auto& k : segment_kinds)
    if (!segment_kind_from_string(k))
      return OptionProblem{"segments", "unknown segment kind '" + k + "' (segment kinds: " + yaml::join(segment_kind_names()) + ")"};
  if (auto p = extraction.problem()) return OptionProblem{"extraction." + p->key, p->message};
  if (auto p = detector.problem()) return OptionProblem{"detector." + p->key, p->message};
  return std::nullopt;
}

bool ProcessingOptions::IsValid(std::string* message) const { return report(problem(), message); }

void read_options(const yaml::MapReader& m, ProcessingOptions& o, const std::set<std::string>& keep) {
  if (take(m, "intervals", "intervals", keep, o)) o.intervals = source_from(choice(m, "intervals", kSourceNames));
  if (take(m, "segments", "segments", keep, o)) o.segment_kinds = segment_kinds(m);
  if (m.has("extraction")) read_extraction(m, o, keep);
  if (m.has("detector")) read_detector(m, o, keep);
  check(m, "", o);
}

void emit_options(YAML::Emitter& out, const ProcessingOptions& o) {
  const StaticExtractionSettings& e = o.extraction;
  const StaticDetectorOptions& d = o.detector;
  out << YAML::Key << "intervals" << YAML::Value << interval_source_name(o.intervals);
  out << YAML::Key << "segments" << YAML::Value << YAML::Flow << o.segment_kinds;
  out << YAML::Key << "extraction" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "filter" << YAML::Value << filter_name(e.filter);
  out << YAML::Key << "filter_order" << YAML::Value << e.filter_order;
  out << YAML::Key << "cutoff_hz" << YAML::Value << YAML::Precision(17) << e.cutoff_hz;
  out << YAML::Key << "settle_s" << YAML::Value << YAML::Precision(17) << e.settle_s;
  out << YAML::Key << "zero_phase" << YAML::Value << e.zero_phase;
  out << YAML::EndMap;
  out << YAML::Key << "detector" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "window_s" << YAML::Value << YAML::Precision(17) << d.window_s;
  out << YAML::Key << "min_duration_s" << YAML::Value << YAML::Precision(17) << d.min_duration_s;
  out << YAML::Key << "variance_threshold_m2ps4" << YAML::Value << YAML::Precision(17) << d.variance_threshold;
  out << YAML::Key << "threshold_multiplier" << YAML::Value << YAML::Precision(17) << d.threshold_multiplier;
  out << YAML::Key << "init_duration_s" << YAML::Value << YAML::Precision(17) << d.init_duration_s;
  out << YAML::Key << "trim_s" << YAML::Value << YAML::Precision(17) << d.trim_s;
  out << YAML::Key << "max_gyro_dps" << YAML::Value << YAML::Precision(17) << d.max_gyro_radps / physics::kDegToRad;
  out << YAML::EndMap;
}

namespace {

// The experiment's YAML parsed (once per text: an analysis resolves its options several times on
// one recording, and the recording's reader has parsed it already).
YAML::Node parsed_experiment(const std::string& text, const std::string& file) {
  try {
    return yaml::parse_kept(text);
  } catch (const YAML::ParserException& e) {
    throw ExperimentError({file, e.mark.line + 1, e.mark.column + 1}, "", "YAML syntax error: " + e.msg);
  }
}

}  // namespace

ProcessingOptions resolve(const ProcessingOptions& options, const Recording& rec) {
  // Without the word, the experiment has no processing section: nothing to parse.
  if (rec.experiment_yaml.find("processing") == std::string::npos) return options;
  const std::string file = (rec.dir / "experiment.yaml").string();
  const YAML::Node root = parsed_experiment(rec.experiment_yaml, file);
  if (!root.IsMap() || !root["processing"] || root["processing"].IsNull()) return options;
  const yaml::MapReader section(root["processing"], file, "processing", "'processing'", kOptionKeys);
  ProcessingOptions out = options;
  read_options(section, out, options.stated);
  return out;
}

}  // namespace stend::processing
