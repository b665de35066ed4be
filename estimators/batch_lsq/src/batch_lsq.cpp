// The paper's batch least-squares procedure on a recording. See stend/batch_lsq/batch_lsq.hpp.
#include "stend/batch_lsq/batch_lsq.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "stend/physics/units.hpp"
#include "stend/processing/static_extraction.hpp"

namespace stend::batch_lsq {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

int column(const RecordingHeader& h, const std::string& name) {
  for (std::size_t i = 0; i < h.truth_columns.size(); ++i)
    if (h.truth_columns[i] == name) return static_cast<int>(i);
  return -1;
}

std::string describe_segment(const Segment& s) {
  std::string out = "segment " + std::to_string(s.id) + " (" + s.kind;
  if (!s.label.empty()) out += " '" + s.label + "'";
  if (s.orientation >= 0)
    out += ", orientation " + std::to_string(s.orientation + 1) + "/" +
           std::to_string(s.orientation_count);
  return out + ", " + num(s.t_start_s) + "–" + num(s.t_end_s) + " s)";
}

// A stimulus at which every term's regressor entry is generically nonzero: used to decide which
// parameters can affect which output axes, from the vocabulary itself.
model::Stimulus<double> generic_stimulus() {
  model::Stimulus<double> s;
  s.input = {0.371, -0.713, 1.129};
  s.specific_force = {0.523, 0.917, -1.311};
  s.temperature_c = 31.77;
  s.temperature_rate_cps = 0.0137;
  s.time_s = 17.3;
  return s;
}

}  // namespace

Eigen::VectorXd FitResult::theta_full() const {
  Eigen::VectorXd t = Eigen::VectorXd::Constant(spec.model.size(), kNaN);
  if (!ok) return t;
  for (std::size_t j = 0; j < param_index.size(); ++j)
    t[param_index[j]] = lsq.estimate[static_cast<Eigen::Index>(j)];
  return t;
}

std::vector<StaticPoint> extract_points(const Recording& rec, const ModelSpec& spec,
                                        std::vector<std::string>* notes) {
  auto note = [&](const std::string& s) {
    if (notes) notes->push_back(s);
  };
  const bool accel = spec.model.instrument == model::Instrument::kAccelerometer;
  const char* in_cols[2][3] = {{"f_x_mps2", "f_y_mps2", "f_z_mps2"},
                               {"w_x_radps", "w_y_radps", "w_z_radps"}};
  const auto& inputs = in_cols[accel ? 0 : 1];
  int in_idx[3], f_idx[3];
  std::vector<std::string> missing;
  for (int i = 0; i < 3; ++i) {
    in_idx[i] = column(rec.header, inputs[i]);
    f_idx[i] = column(rec.header, in_cols[0][i]);
    if (in_idx[i] < 0) missing.push_back(inputs[i]);
  }
  const bool needs_force = !accel && spec.model.find(model::TermKind::kGSensitivity) >= 0;
  if (needs_force)
    for (int i = 0; i < 3; ++i)
      if (f_idx[i] < 0) missing.push_back(in_cols[0][i]);
  if (!missing.empty()) {
    std::string have, miss;
    for (const auto& c : rec.header.truth_columns) have += (have.empty() ? "" : ", ") + c;
    for (const auto& c : missing) miss += (miss.empty() ? "" : ", ") + c;
    throw std::runtime_error("recording '" + rec.dir.string() + "' lacks the truth column(s) " +
                             miss + " that a " + instrument_name(spec.model.instrument) +
                             " fit needs; truth columns present: " +
                             (have.empty() ? "none" : have));
  }
  const int die_idx = column(rec.header, "die_c");
  if (die_idx < 0)
    note("no 'die_c' truth column: the temperature of each point is the sensor's own "
         "temperature reading");

  const std::size_t n = rec.samples.size();
  std::vector<double> t(n), x[3], temp(n);
  for (int a = 0; a < 3; ++a) x[a].resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const ImuSample& s = rec.samples[i];
    t[i] = s.t_s;
    for (int a = 0; a < 3; ++a) x[a][i] = accel ? s.accel_mps2[a] : s.gyro_radps[a];
    temp[i] = s.temperature_c;
    if (i > 0 && !(t[i] > t[i - 1]))
      throw std::runtime_error("recording '" + rec.dir.string() + "': sample times are not " +
                               "strictly increasing at sample " + std::to_string(i) + " (t = " +
                               num(t[i]) + " s)");
  }

  std::vector<StaticPoint> points;
  std::size_t considered = 0;
  for (const Segment& seg : rec.segments) {
    if (std::find(spec.segment_kinds.begin(), spec.segment_kinds.end(), seg.kind) ==
        spec.segment_kinds.end())
      continue;
    ++considered;
    const std::string what = describe_segment(seg);
    if (!seg.complete) {
      note("skipped " + what + ": incomplete (the run stopped inside it)");
      continue;
    }
    if (!seg.settled) {
      note("skipped " + what + ": the fixtures/chamber were not settled");
      continue;
    }
    StaticPoint p;
    p.segment_id = seg.id;
    p.label = seg.label.empty() ? what : seg.label;
    if (seg.orientation >= 0 && seg.label.empty())
      p.label = seg.kind + " " + std::to_string(seg.orientation + 1);
    try {
      for (int a = 0; a < 3; ++a) {
        const processing::StaticValue v =
            processing::extract_static(t, x[a], seg.t_start_s, seg.t_end_s, spec.extraction);
        p.measured[a] = v.mean;
        p.measured_std_error[a] = v.white_std_error;
        p.t_start_s = v.t_first_s;
        p.t_end_s = v.t_last_s;
        p.samples_used = v.n_used;
      }
    } catch (const std::invalid_argument& e) {
      note("skipped " + what + ": " + e.what());
      continue;
    }
    // Flags inside the kept window.
    std::size_t saturated = 0, gaps = 0;
    const auto lo = std::lower_bound(t.begin(), t.end(), p.t_start_s) - t.begin();
    const auto hi = std::upper_bound(t.begin(), t.end(), p.t_end_s) - t.begin();
    double temp_sum = 0.0;
    for (auto i = lo; i < hi; ++i) {
      const auto& s = rec.samples[static_cast<std::size_t>(i)];
      if (s.flags & (accel ? kAccelSaturated : kGyroSaturated)) ++saturated;
      if (i > lo && (s.flags & kGapBefore)) ++gaps;
      temp_sum += s.temperature_c;
    }
    if (saturated > 0) {
      note("skipped " + what + ": " + std::to_string(saturated) + " saturated sample(s)");
      continue;
    }
    if (gaps > 0)
      note(what + ": " + std::to_string(gaps) +
           " gap(s) in the kept window; the filter assumed uniform sampling");

    // Truth over the kept window: mean of the snapshots inside, else the last one before.
    const std::size_t ncol = rec.header.truth_columns.size();
    std::vector<double> mean(ncol, 0.0);
    std::size_t rows = 0;
    double st = 0, sd = 0, stt = 0, std_ = 0;  // for the die-temperature slope
    int held = -1;
    for (std::size_t r = 0; r < rec.truth_t.size(); ++r) {
      const double tr = rec.truth_t[r];
      if (tr <= p.t_start_s) held = static_cast<int>(r);
      if (tr < p.t_start_s || tr > p.t_end_s) continue;
      if (rec.truth[r].size() != ncol) continue;
      for (std::size_t c = 0; c < ncol; ++c) mean[c] += rec.truth[r][c];
      if (die_idx >= 0) {
        const double d = rec.truth[r][static_cast<std::size_t>(die_idx)];
        st += tr;
        sd += d;
        stt += tr * tr;
        std_ += tr * d;
      }
      ++rows;
    }
    if (rows > 0) {
      for (double& m : mean) m /= static_cast<double>(rows);
    } else if (held >= 0 && rec.truth[static_cast<std::size_t>(held)].size() == ncol) {
      mean = rec.truth[static_cast<std::size_t>(held)];
    } else {
      note("skipped " + what + ": no truth snapshot at or before its window");
      continue;
    }
    for (int a = 0; a < 3; ++a) {
      p.stimulus.input[a] = mean[static_cast<std::size_t>(in_idx[a])];
      p.stimulus.specific_force[a] =
          f_idx[a] >= 0 ? mean[static_cast<std::size_t>(f_idx[a])] : (accel ? p.stimulus.input[a] : 0.0);
    }
    p.stimulus.temperature_c = die_idx >= 0 ? mean[static_cast<std::size_t>(die_idx)]
                                            : temp_sum / static_cast<double>(hi - lo);
    const double nr = static_cast<double>(rows);
    const double den = nr * stt - st * st;
    p.stimulus.temperature_rate_cps = (die_idx >= 0 && rows >= 2 && den > 0) ? (nr * std_ - st * sd) / den : 0.0;
    p.stimulus.time_s = 0.5 * (p.t_start_s + p.t_end_s);
    points.push_back(p);
  }
  if (considered == 0) {
    std::string kinds, wanted;
    for (const auto& s : rec.segments)
      if (kinds.find(s.kind) == std::string::npos) kinds += (kinds.empty() ? "" : ", ") + s.kind;
    for (const auto& k : spec.segment_kinds) wanted += (wanted.empty() ? "" : ", ") + k;
    note("the recording has no segment of kind " + wanted + " (kinds present: " +
         (kinds.empty() ? "none" : kinds) + ")");
  }
  return points;
}

FitResult fit_points(const std::vector<StaticPoint>& points, const ModelSpec& spec) {
  FitResult fr;
  fr.spec = spec;
  fr.points = points;
  const bool accel = spec.model.instrument == model::Instrument::kAccelerometer;
  fr.unit = accel ? "m/s^2" : "rad/s";
  fr.display_unit = accel ? "mg" : "deg/h";
  const double display_factor =
      accel ? 1.0 / physics::kMilliG : 1.0 / physics::kDegPerHour;

  if (spec.axes.empty() || spec.model.terms.empty()) {
    fr.message = "the model specification has no axes or no terms";
    return fr;
  }
  // Parameters that can affect the fitted axes.
  const std::vector<model::ParamInfo> all = spec.model.params();
  const Eigen::MatrixXd generic = spec.model.regressor(generic_stimulus());
  for (int j = 0; j < spec.model.size(); ++j) {
    bool affects = false;
    for (int a : spec.axes) affects = affects || generic(a, j) != 0.0;
    if (affects) {
      fr.params.push_back(all[static_cast<std::size_t>(j)]);
      fr.param_index.push_back(j);
    } else {
      fr.excluded.push_back(all[static_cast<std::size_t>(j)].name);
    }
  }
  const int p = static_cast<int>(fr.params.size());
  const int k = static_cast<int>(points.size() * spec.axes.size());

  estimation::LsqProblem prob;
  prob.design.resize(k, p);
  prob.observations.resize(k);
  if (spec.weighting == Weighting::kSegmentNoise) prob.weights.resize(k);
  for (const auto& pi : fr.params) {
    prob.names.push_back(pi.name);
    prob.units.push_back(pi.unit);
  }
  int row = 0;
  for (std::size_t n = 0; n < points.size(); ++n) {
    const StaticPoint& pt = points[n];
    const Eigen::MatrixXd phi = spec.model.regressor(pt.stimulus);
    for (int a : spec.axes) {
      for (int j = 0; j < p; ++j) prob.design(row, j) = phi(a, fr.param_index[static_cast<std::size_t>(j)]);
      prob.observations[row] = pt.measured[a] - pt.stimulus.input[a];
      if (spec.weighting == Weighting::kSegmentNoise) {
        const double se = pt.measured_std_error[a];
        if (!(se > 0.0) || !std::isfinite(se)) {
          fr.message = "weighting: segment_noise needs a positive standard error for every point; "
                       "point '" + pt.label + "' axis " + axis_name(a) + " has " + num(se) +
                       ". Use weighting: none.";
          return fr;
        }
        prob.weights[row] = 1.0 / (se * se);
      }
      fr.residuals.push_back({static_cast<int>(n), a, prob.observations[row], 0.0, 0.0});
      ++row;
    }
  }
  estimation::LsqOptions opt;
  opt.confidence = spec.confidence;
  fr.lsq = estimation::solve_lsq(prob, opt);
  if (!fr.lsq.ok()) {
    fr.message = fr.lsq.message;
    fr.residuals.clear();
    return fr;
  }
  fr.ok = true;
  Eigen::Vector3d ss = Eigen::Vector3d::Zero();
  Eigen::Vector3i cnt = Eigen::Vector3i::Zero();
  for (int r = 0; r < k; ++r) {
    Residual& res = fr.residuals[static_cast<std::size_t>(r)];
    res.residual = fr.lsq.residuals[r];
    res.fitted = res.observed - res.residual;
    ss[res.axis] += res.residual * res.residual;
    ++cnt[res.axis];
  }
  for (int a : spec.axes) {
    fr.residual_rms[a] = std::sqrt(ss[a] / cnt[a]);
    fr.residual_rms_display[a] = fr.residual_rms[a] * display_factor;
  }
  return fr;
}

FitResult fit_recording(const Recording& rec, const ModelSpec& spec) {
  std::vector<std::string> notes;
  FitResult fr;
  std::vector<StaticPoint> points;
  try {
    points = extract_points(rec, spec, &notes);
  } catch (const std::exception& e) {
    fr.spec = spec;
    fr.message = e.what();
    fr.notes = notes;
  }
  if (fr.message.empty()) {
    fr = fit_points(points, spec);
    if (!fr.ok && points.empty())
      fr.message = "no usable static segment in the recording; " + fr.message;
    fr.notes.insert(fr.notes.begin(), notes.begin(), notes.end());
  }
  fr.extracted = true;
  fr.recording_dir = rec.dir.string();
  fr.experiment_name = rec.header.experiment_name;
  fr.recording_status = rec.status;
  if (!rec.complete())
    fr.notes.push_back("the recording's status is '" + rec.status +
                       "', not 'complete': it may be truncated");
  if (spec.extraction.settle_s < 1.0 / spec.extraction.cutoff_hz)
    fr.notes.push_back("settle_s = " + num(spec.extraction.settle_s) +
                       " s is shorter than 1/cutoff_hz = " + num(1.0 / spec.extraction.cutoff_hz) +
                       " s: the filter's edge transients may reach the averaged window");
  return fr;
}

}  // namespace stend::batch_lsq
