// The rows of a table of means, held. See held_rows.hpp.
#include "held_rows.hpp"

#include <stend/io/importers.hpp>
#include <stend/recording/truth_columns.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>

namespace stend::io::detail {

namespace {

bool one_of(const std::string& s, std::initializer_list<const char*> words) {
  return std::any_of(words.begin(), words.end(), [&](const char* w) { return s == w; });
}

const std::initializer_list<const char*> kCountWords = {"n", "count", "samples", "nsamples"};
const std::initializer_list<const char*> kSigmaWords = {"sigma", "std", "sd", "stddev", "stdev"};
const std::initializer_list<const char*> kAxisPrefixes = {"", "a", "acc", "accel"};

// The axis (0, 1, 2) a per-axis sigma key names ("sigmax", "sigmaax", "axstd", …); −1 for none.
int sigma_axis_of(const std::string& key) {
  for (int a = 0; a < 3; ++a) {
    const std::string axis(1, static_cast<char>('x' + a));
    for (const char* s : kSigmaWords)
      for (const char* p : kAxisPrefixes)
        if (key == std::string(s) + p + axis || key == std::string(p) + axis + s) return a;
  }
  return -1;
}

}  // namespace

ColumnKey column_key(const std::string& name) {
  std::string s, bracket;
  bool in_bracket = false;
  for (const char c : name) {
    const char l = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (c == '[' || c == '(') in_bracket = true;  // "ax [g]", "ax (m/s^2)": a unit, else a comment
    else if (c == ']' || c == ')') break;
    else (in_bracket ? bracket : s).push_back(l);
  }
  std::vector<std::string> words(1);
  for (const char c : s) {
    if (c == '_' || c == '-' || c == '.' || c == ' ' || c == '\t') {
      if (!words.back().empty()) words.emplace_back();
    } else {
      words.back().push_back(c);
    }
  }
  if (words.back().empty()) words.pop_back();
  ColumnKey k;
  if (words.size() > 1 && one_of(words.back(), {"mps2", "g"})) {
    k.unit = words.back();
    words.pop_back();
  }
  for (const auto& w : words) k.key += w;
  const std::string b(trim(bracket));
  if (b == "g") k.unit = "g";
  if (one_of(b, {"m/s^2", "m/s2", "m/s²", "mps2"})) k.unit = "mps2";
  return k;
}

bool SpreadColumns::uses(int i) const {
  return i == n || i == sigma || std::find(sigma_axis.begin(), sigma_axis.end(), i) != sigma_axis.end();
}

std::string SpreadColumns::describe(const std::vector<std::string>& names) const {
  auto name = [&](int i) { return names[static_cast<std::size_t>(i)]; };
  std::string out;
  if (n >= 0) out = name(n) + " (samples per row)";
  if (sigma >= 0) out += (out.empty() ? "" : " and ") + name(sigma) + " (one sigma per row, all axes)";
  if (per_axis())
    out += (out.empty() ? "" : " and ") + name(sigma_axis[0]) + ", " + name(sigma_axis[1]) + ", " +
           name(sigma_axis[2]) + " (sigma per axis)";
  return out.empty() ? "none" : out;
}

SpreadColumns spread_columns(const LineReader& r, const std::vector<std::string>& names) {
  SpreadColumns c;
  auto take = [&](int& slot, int i, const std::string& what) {
    if (slot >= 0) r.fail("two columns give " + what + ": '" + names[static_cast<std::size_t>(slot)] + "' and '" +
                          names[static_cast<std::size_t>(i)] + "'");
    slot = i;
  };
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string key = column_key(names[i]).key;
    const int col = static_cast<int>(i);
    if (one_of(key, kCountWords)) take(c.n, col, "the sample count n");
    else if (one_of(key, kSigmaWords)) take(c.sigma, col, "sigma");
    else if (const int a = sigma_axis_of(key); a >= 0)
      take(c.sigma_axis[static_cast<std::size_t>(a)], col, std::string("sigma of ") + "xyz"[a]);
  }
  const auto per_axis = std::count_if(c.sigma_axis.begin(), c.sigma_axis.end(), [](int i) { return i >= 0; });
  if (per_axis > 0 && per_axis < 3)
    r.fail("sigma per axis needs a column for each of x, y and z (or one sigma column for all axes)");
  if (per_axis == 3 && c.sigma >= 0) r.fail("sigma given both for all axes and per axis: keep one of them");
  return c;
}

RowSpread row_spread(const LineReader& r, const std::vector<std::string_view>& f, const SpreadColumns& c,
                     const std::vector<std::string>& names, double sigma_si) {
  RowSpread s;
  auto value = [&](int i) { return number(r, f[static_cast<std::size_t>(i)], names[static_cast<std::size_t>(i)]); };
  if (c.n >= 0) {
    s.n = value(c.n);
    if (!(s.n >= 1.0) || s.n != std::floor(s.n) || !std::isfinite(s.n))
      r.fail("column '" + names[static_cast<std::size_t>(c.n)] + "': the samples averaged must be a count of at least 1");
  }
  for (int a = 0; a < 3; ++a) {
    const int i = c.per_axis() ? c.sigma_axis[static_cast<std::size_t>(a)] : c.sigma;
    if (i < 0) continue;
    const double v = value(i);
    if (!(v > 0.0) || !std::isfinite(v))
      r.fail("column '" + names[static_cast<std::size_t>(i)] + "': sigma must be a positive standard deviation (a "
             "sigma of 0 would give the row infinite weight)");
    s.sigma[a] = v * sigma_si;
  }
  return s;
}

std::vector<std::string> held_truth_columns(const std::vector<std::string>& inputs) {
  std::vector<std::string> out = inputs;
  for (const auto& c : held_column_names()) out.push_back(c);
  return out;
}

void hold_row(Recording& rec, const std::string& label, const Eigen::Vector3d& mean, const std::vector<double>& inputs,
              const RowSpread& spread) {
  const auto per_row = static_cast<std::size_t>(kStaticTableHold_s * kStaticTableRate_hz);
  ImuSample s;
  s.accel_mps2 = mean;
  const double t0 = static_cast<double>(rec.samples.size()) / kStaticTableRate_hz;
  for (std::size_t i = 0; i < per_row; ++i) {
    s.t_s = static_cast<double>(rec.samples.size()) / kStaticTableRate_hz;
    rec.samples.push_back(s);
  }
  const int id = static_cast<int>(rec.segments.size());
  Segment seg = make_segment(id, SegmentKind::kOrientation, label, t0, rec.samples.back().t_s);
  seg.orientation = id;
  rec.segments.push_back(seg);
  std::vector<double> row = inputs;
  row.push_back(spread.n);
  for (int a = 0; a < 3; ++a) row.push_back(spread.sigma[a]);
  add_held_truth(rec, seg.t_start_s, seg.t_end_s, row);
}

void finish_held_rows(Recording& rec) {
  for (auto& seg : rec.segments) seg.orientation_count = static_cast<int>(rec.segments.size());
  rec.header.info.output_rate_hz = kStaticTableRate_hz;
  rec.header.info.has_gyro = false;
  rec.header.info.has_temperature = false;
}

std::string held_rows_text(const SpreadColumns& c) {
  std::string noise;
  if (c.n >= 0 && c.has_sigma())
    noise = "sigma/sqrt(n) from the table, an absolute standard error the fit weights each row by";
  else if (c.n >= 0)
    noise = "proportional to 1/sqrt(n) (the table states no sigma): relative weights, their scale from the fit's "
            "residuals";
  else if (c.has_sigma())
    noise = "proportional to sigma (the table states no n): relative weights, their scale from the fit's residuals";
  else
    noise = "not stated (no n or sigma column): rows weighted equally, the spread from the fit's residuals";
  return "each row held as an orientation segment of " + fmt_g(kStaticTableHold_s) + " s at " +
         fmt_g(kStaticTableRate_hz) + " Hz repeating its mean (the samples' spread is zero and says nothing about "
         "noise); the noise of a row's mean: " + noise;
}

}  // namespace stend::io::detail
