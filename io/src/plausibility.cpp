// Plausibility on the way in. See stend/io/plausibility.hpp.
#include <stend/io/plausibility.hpp>

#include <stend/model/terms.hpp>
#include <stend/physics/units.hpp>
#include <stend/recording/instruments.hpp>

#include "import_common.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace stend::io {

using detail::fmt_g;

namespace {

// "|a| ≈ 15 000 m/s²" style figure: three significant digits.
std::string rough(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

bool finite3(const Eigen::Vector3d& v) { return v.allFinite(); }

// Why the still rate is implausible (a gyroscope read in counts), "" when it is not or there is
// no gyroscope (NaN).
std::string implausible_rate(const Stillness::Still& still) {
  if (!(still.rate_radps > kMaxStillRate_dps * physics::kDegPerSecond)) return {};
  return "|w| ≈ " + rough(still.rate_radps) + " rad/s (" + rough(still.rate_radps / physics::kDegPerSecond) +
         " deg/s) in the stillest stretch, more than any MEMS gyroscope reads: these look like raw counts — give "
         "--gyro-lsb (e.g. 1/131deg/s)";
}

}  // namespace

std::string sample_problem(const ImuSample& s, const SensorInfo& info) {
  if (!std::isfinite(s.t_s)) return "time " + fmt_g(s.t_s) + " is not a finite number";
  const bool accel = has_instrument(info, model::Instrument::kAccelerometer);
  const bool gyro = has_instrument(info, model::Instrument::kGyroscope);
  if (accel && !finite3(s.accel_mps2)) return "an accelerometer value is not a finite number (" + fmt_g(s.accel_mps2.x()) + ", " +
                                     fmt_g(s.accel_mps2.y()) + ", " + fmt_g(s.accel_mps2.z()) + ")";
  if (gyro && !finite3(s.gyro_radps)) return "a gyroscope value is not a finite number (" + fmt_g(s.gyro_radps.x()) + ", " +
                                     fmt_g(s.gyro_radps.y()) + ", " + fmt_g(s.gyro_radps.z()) + ")";
  if (std::isinf(s.temperature_c)) return "the temperature " + fmt_g(s.temperature_c) + " is not a finite number";
  return {};
}

Stillness::Stillness(const SensorInfo& info)
    : accel_(has_instrument(info, model::Instrument::kAccelerometer)),
      gyro_(has_instrument(info, model::Instrument::kGyroscope)) {}

void Stillness::add(const ImuSample& s) {
  if (n_ > 0 && s.t_s - t0_s_ >= kStillBlock_s) close_block();
  if (n_ == 0) t0_s_ = s.t_s;
  ++n_;
  if (accel_) {
    sum_a_ += s.accel_mps2;
    sum_aa_ += s.accel_mps2.squaredNorm();
  }
  if (gyro_) {
    sum_w_ += s.gyro_radps;
    sum_ww_ += s.gyro_radps.squaredNorm();
  }
}

// The block gathered so far, kept when it is still and among the stillest: by the accelerometer's
// scatter relative to |a|, or without an accelerometer by the gyroscope's scatter alone.
void Stillness::close_block() {
  const double n = static_cast<double>(n_);
  const Eigen::Vector3d mean_a = sum_a_ / n, mean_w = sum_w_ / n;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Block b;
  b.accel_mps2 = accel_ ? mean_a.norm() : nan;
  b.rate_radps = gyro_ ? mean_w.norm() : nan;
  b.scatter = accel_ ? std::sqrt(std::max(0.0, sum_aa_ / n - mean_a.squaredNorm())) / b.accel_mps2
                     : std::sqrt(std::max(0.0, sum_ww_ / n - mean_w.squaredNorm()));
  const bool still = n_ >= kStillMinSamples && (accel_ ? b.accel_mps2 > 0.0 && b.scatter < kStillScatter : gyro_);
  n_ = 0;
  sum_a_.setZero();
  sum_w_.setZero();
  sum_aa_ = sum_ww_ = 0.0;
  if (!still) return;
  const auto by_scatter = [](const Block& x, const Block& y) { return x.scatter < y.scatter; };
  kept_.push_back(b);
  std::sort(kept_.begin(), kept_.end(), by_scatter);
  if (kept_.size() > kStillBlocksKept) kept_.pop_back();
}

std::optional<Stillness::Still> Stillness::stillest() const {
  Stillness copy = *this;
  if (copy.n_ > 0) copy.close_block();
  if (copy.kept_.empty()) return std::nullopt;
  std::vector<double> a, w;
  for (const Block& b : copy.kept_) {
    a.push_back(b.accel_mps2);
    w.push_back(b.rate_radps);
  }
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  return Still{median(a), median(w), copy.kept_.size()};
}

std::string implausible_because(const Stillness::Still& still, const ImportOptions& options, const std::string& where) {
  if (std::isnan(still.accel_mps2)) return implausible_rate(still);  // a gyro-only log: its rate alone
  const double g = physics::kStandardGravity;
  const double a_g = still.accel_mps2 / g;  // the still |a| in g, as imported
  const auto plausible = [](double in_g) { return in_g >= kMinStillG && in_g <= kMaxStillG; };
  const std::string seen = "|a| ≈ " + rough(still.accel_mps2) + " m/s^2 (" + rough(a_g) + " g) " + where;
  const bool counts = options.accel_value.counts();
  const bool given_in_g = !counts && options.accel_value.unit == g;
  if (!plausible(a_g)) {
    if (!counts && a_g > kMinCountsPerG) return seen + ": these look like raw counts — give --accel-lsb (e.g. 1/16384g)";
    if (given_in_g && plausible(a_g / g)) return seen + ": these look like m/s^2 read as g — drop --accel-unit g";
    if (!counts && !given_in_g && plausible(still.accel_mps2)) return seen + ": these look like g — give --accel-unit g";
    return seen + ", not about 1 g: check --accel-lsb / --accel-unit";
  }
  return implausible_rate(still);
}

void BadSamples::report(const ImportError& refusal) {
  if (!drop_) throw refusal;
  if (dropped_++ == 0) first_ = refusal.what();
}

std::string BadSamples::describe() const {
  if (dropped_ == 0) return {};
  return std::to_string(dropped_) + " bad sample(s) dropped (--drop-bad-samples), the first: " + first_;
}

void SampleCheck::add_samples(const ImuSample* samples, std::size_t count) {
  // Checked copies pass on kCheckBatch at a time, so that the gate holds a few hundred KiB whatever
  // the size of the chunks it is given.
  constexpr std::size_t kCheckBatch = 4096;
  kept_.reserve(kCheckBatch);
  const SensorInfo& info = rec_->header.info;
  if (!stillness_) stillness_.emplace(info);
  for (std::size_t i = 0; i < count; ++i) {
    ImuSample s = samples[i];
    ++seen_;
    blank_absent(info, s);
    if (const std::string why = sample_problem(s, info); !why.empty()) {
      bad_.report(ImportError(file_, "sample " + std::to_string(seen_), why));
      continue;
    }
    stillness_->add(s);
    kept_.push_back(s);
    if (kept_.size() == kCheckBatch) pass_kept();
  }
  pass_kept();
}

void SampleCheck::pass_kept() {
  if (!kept_.empty()) out_->add_samples(kept_.data(), kept_.size());
  kept_.clear();
}

void SampleCheck::finish(Recording& rec) {
  if (bad_.dropped() > 0) add_import_event(rec, bad_.describe(), "warning");
  if (options_->accept_implausible) return;
  const auto still = stillness_ ? stillness_->stillest() : std::nullopt;
  if (!still) return;
  if (const std::string why = implausible_because(*still, *options_); !why.empty())
    throw ImportError(file_, 0, why + " (--accept-implausible imports it as it is)");
}

void check_held_means(const Recording& rec, const std::filesystem::path& file, const ImportOptions& options) {
  if (options.accept_implausible || rec.samples.empty()) return;
  std::vector<double> norms;  // every row holds the same number of samples: the samples' median is the rows'
  norms.reserve(rec.samples.size());
  for (const ImuSample& s : rec.samples)
    if (s.accel_mps2.allFinite()) norms.push_back(s.accel_mps2.norm());
  if (norms.empty()) return;
  std::nth_element(norms.begin(), norms.begin() + static_cast<std::ptrdiff_t>(norms.size() / 2), norms.end());
  Stillness::Still still;
  still.accel_mps2 = norms[norms.size() / 2];
  still.blocks = rec.segments.size();
  if (const std::string why = implausible_because(still, options, "over the table's rows (median)"); !why.empty())
    throw ImportError(file, 0, why + " (--accept-implausible imports it as it is)");
}

void check_samples(Recording& rec, const std::filesystem::path& file, const ImportOptions& options) {
  std::vector<ImuSample> checked;
  checked.reserve(rec.samples.size());
  VectorSink sink(checked);
  SampleCheck check(rec, sink, file, options);
  check.add_samples(rec.samples.data(), rec.samples.size());
  check.finish(rec);
  rec.samples = std::move(checked);
}

}  // namespace stend::io
