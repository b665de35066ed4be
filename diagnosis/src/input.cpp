// stend gap, step 1: from a recording to static segments with their truth stimulus, groups and
// noise floor. The static points and truth means are the processing stage's (through
// estimation::extract_static_points); this file only adds what the diagnoser needs around them.
// See stend/diagnosis/input.hpp.
#include <ceres/jet.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include <stend/errors.hpp>

#include "noise_stage.hpp"
#include "samples.hpp"
#include "stend/diagnosis/input.hpp"
#include "stend/estimation/instrument_model.hpp"
#include "stend/estimation/static_fit.hpp"
#include "stend/model/output_stage.hpp"
#include "stend/physics/gravity.hpp"
#include "stend/physics/table_chain.hpp"
#include "stend/processing/truth.hpp"
#include "stend/recording/truth_columns.hpp"
#include "stend/sim/imu.hpp"  // the twin's noise: sim_imu's defaults

namespace stend::diagnosis {

namespace {

int column(const Recording& r, const std::string& name) { return r.truth_column(name); }

// Column whose name ends with `suffix` (e.g. ".tilt.meas_deg"), −1 when none.
int column_ending(const Recording& r, const std::string& suffix) {
  for (std::size_t i = 0; i < r.header.truth_columns.size(); ++i) {
    const std::string& c = r.header.truth_columns[i];
    if (c.size() >= suffix.size() && c.compare(c.size() - suffix.size(), suffix.size(), suffix) == 0)
      return static_cast<int>(i);
  }
  return -1;
}

std::string orientation_name(const Eigen::Vector3d& up) {
  for (int a = 0; a < 3; ++a)
    if (std::abs(up[a]) > 0.995) return std::string(up[a] > 0 ? "+" : "-") + "xyz"[a] + " up";
  char buf[80];
  std::snprintf(buf, sizeof buf, "up=(%.2f,%.2f,%.2f)", up[0], up[1], up[2]);
  return buf;
}

// White-noise std of a sim_imu sample as its output stage leaves it: the sensor config's noise
// density, output rate and low-pass, each defaulting to the simulator's own (SimImuConfig).
double sim_twin_std(const YAML::Node& cfg, bool accel) {
  const sim::SimImuConfig defaults;
  auto value = [&](const char* key, double fallback) { return cfg[key] ? cfg[key].as<double>() : fallback; };
  const double density = accel ? value("accel_noise_density", defaults.accel_noise_density)
                               : value("gyro_noise_density", defaults.gyro_noise_density);
  return model::white_noise_output_sigma(density, value("output_rate_hz", defaults.output_rate_hz),
                                         value("lowpass_hz", defaults.lowpass_hz));
}

// Static points of the processing stage; records its options, skips and notes in `in`.
std::vector<processing::StaticPoint> static_points(const Recording& rec, const estimation::ModelSpec& spec,
                                                   GapInput& in) {
  processing::Extraction extraction = estimation::extract_static_points(rec, spec);
  in.spec.processing = extraction.options;
  in.saturated_segments = extraction.count(processing::SkipReason::kSaturated);
  in.notes = extraction.notes;
  if (extraction.points.size() < 2)
    throw InputError("'" + in.source + "': only " + std::to_string(extraction.points.size()) +
                     " static segment(s) could be extracted (" + extraction.tally() + "); the gap needs several");
  return std::move(extraction.points);
}

// Twin noise of a simulated run: the white-noise std of one sample from the sim sensor's own
// noise settings [unit]; NaN when the run's sensor is not sim_imu (the recording's median segment
// std is the reference then).
Eigen::Vector3d twin_sample_std(const Recording& rec, bool accel) {
  if (rec.experiment_yaml.empty()) return Eigen::Vector3d::Constant(kNaN);
  try {
    const YAML::Node root = YAML::Load(rec.experiment_yaml);
    const YAML::Node sensor = root["bench"]["sensor"];
    if (sensor && sensor["plugin"] && sensor["plugin"].as<std::string>() == "sim_imu") {
      const YAML::Node cfg = sensor["config"] ? sensor["config"] : YAML::Node(YAML::NodeType::Map);
      return Eigen::Vector3d::Constant(sim_twin_std(cfg, accel));
    }
  } catch (const std::exception&) {
    // no twin noise settings
  }
  return Eigen::Vector3d::Constant(kNaN);
}

// Truth columns for the bench-side stimulus fields: specific force, rate, the sim three-axis
// table's measured angles, the sensor mounting and local gravity.
struct TruthColumns {
  int f[3], w[3], table[3];  // f_*_mps2, w_*_radps, azimuth / tilt / rotation [deg]; −1 absent
  bool three_axis = false;
  Eigen::Matrix3d mount = Eigen::Matrix3d::Identity();
  double g = 0.0;  // [m/s²]
};
TruthColumns truth_columns(const Recording& rec) {
  const auto& f = kSpecificForceColumns;
  const auto& w = kRateColumns;
  TruthColumns c{{column(rec, f[0]), column(rec, f[1]), column(rec, f[2])},
                 {column(rec, w[0]), column(rec, w[1]), column(rec, w[2])},
                 {column_ending(rec, ".azimuth.meas_deg"), column_ending(rec, ".tilt.meas_deg"),
                  column_ending(rec, ".rotation.meas_deg")}};
  c.three_axis = c.table[0] >= 0 && c.table[1] >= 0 && c.table[2] >= 0;
  if (rec.header.mounting_R.size() == 9)
    for (int i = 0; i < 9; ++i) c.mount(i / 3, i % 3) = rec.header.mounting_R[static_cast<std::size_t>(i)];
  c.g = rec.header.gravity_or_standard_mps2();
  return c;
}

// Truth specific force [m/s²] and rate [rad/s] over the point's window into its stimulus; returns
// the specific force (NaN where the column is absent).
Eigen::Vector3d truth_stimulus(const Recording& rec, const TruthColumns& c, const processing::StaticPoint& p,
                               bool accel, model::Stimulus<double>& st) {
  Eigen::Vector3d f, w;
  for (int a = 0; a < 3; ++a) {
    f[a] = processing::truth_mean(rec, c.f[a], p.t_start_s, p.t_end_s);
    w[a] = processing::truth_mean(rec, c.w[a], p.t_start_s, p.t_end_s);
  }
  if (f.allFinite() && f.norm() > 0.5) {
    st.specific_force = f;
    if (accel) st.gravity_up = f / f.norm();  // static: specific force is "up"
  }
  // Rates below 1e-3 rad/s (the Earth's 7e-5 rad/s on a static table) cannot show a lever arm
  // (ω²·1 m < 1e-6 m/s²): left at zero so the lever_arm candidate reads "not excited".
  if (w.allFinite() && w.norm() > 1e-3) st.angular_rate = w;
  if (!accel && w.allFinite()) st.input = w;
  return f;
}

// Table geometry (sim three-axis table: R = Ry(δ)·Rx(h)·Rz(az)) from the measured angles [deg],
// checked against the truth specific force f (within 2 % of g): its angle and tilt derivatives
// into the stimulus; returns false when the chain does not reproduce f.
bool table_derivatives(const Recording& rec, const TruthColumns& c, const processing::StaticPoint& p,
                       const Eigen::Vector3d& f, model::Stimulus<double>& st) {
  const double deg = physics::kDegToRad;
  const double az = processing::truth_mean(rec, c.table[0], p.t_start_s, p.t_end_s) * deg;
  const double h = processing::truth_mean(rec, c.table[1], p.t_start_s, p.t_end_s) * deg;
  const double dl = processing::truth_mean(rec, c.table[2], p.t_start_s, p.t_end_s) * deg;
  model::Stimulus<double> probe = st;
  const Eigen::Vector3d f0 = table_stimulus(probe, az, h, dl, c.mount, c.g);
  if (!f.allFinite() || (f0 - f).norm() > 0.02 * c.g) return false;
  st.table_df_dangle = probe.table_df_dangle;
  st.table_df_dtilt = probe.table_df_dtilt;
  return true;
}

// Ramp direction, setpoint [degC] and time since the last orientation or temperature change [s]
// of the segment starting at p, from the time-ordered segments up to its start.
void segment_history(const std::vector<const Segment*>& segs, const processing::StaticPoint& p, SegmentData& d) {
  const Segment* seg = nullptr;
  for (const auto* s : segs)
    if (s->id == p.segment.id) seg = s;
  double cur_sp = kNaN, prev_sp = kNaN, t_temp_change = kNaN, t_orient_change = kNaN;
  int dir = 0;
  const Segment* prev_orient = nullptr;
  for (const auto* s : segs) {
    if (s->t_start_s > p.t_start_s) break;
    if (s->kind == SegmentKind::kSetTemperature && std::isfinite(s->setpoint_c)) {
      if (!std::isfinite(cur_sp) || std::abs(s->setpoint_c - cur_sp) > 0.1) {
        prev_sp = cur_sp;
        cur_sp = s->setpoint_c;
        t_temp_change = s->t_start_s;
        dir = std::isfinite(prev_sp) ? (cur_sp > prev_sp ? 1 : -1) : 0;
      }
    }
    if (s != seg && seg && s->kind == seg->kind) prev_orient = s;
  }
  if (prev_orient) t_orient_change = prev_orient->t_end_s;
  if (seg) t_orient_change = std::isfinite(t_orient_change) ? t_orient_change : seg->t_start_s;
  d.setpoint_c = seg && std::isfinite(seg->setpoint_c) ? seg->setpoint_c : cur_sp;
  d.ramp_direction = dir;
  d.point.stimulus.temperature_direction = dir;
  double last = std::isfinite(t_orient_change) ? t_orient_change : 0.0;
  if (std::isfinite(t_temp_change)) last = std::max(last, t_temp_change);
  d.time_since_change_s = p.t_start_s - last;
}

// One axis of a kept window, accumulated a sample at a time: sum and sum of squares, and the sums
// of kBatches equal batches.
constexpr int kBatches = 8;
struct AxisSums {
  explicit AxisSums(std::size_t n) : batches(n, kBatches) {}
  void add(double v) {
    sum += v;
    sum2 += v * v;
    batches.add(v);
  }
  double sum = 0.0, sum2 = 0.0;
  BlockSums batches;
};

// Noise floor of axis a's mean over a window of n samples: the sample std, and the standard error
// of the mean as the larger of the batch-means and the white-noise estimates.
void mean_noise(const AxisSums& s, std::size_t n, int a, SegmentData& d) {
  const double mean = s.sum / static_cast<double>(n);
  const double var = std::max(0.0, s.sum2 / static_cast<double>(n) - mean * mean);
  d.raw_std[a] = std::sqrt(var * static_cast<double>(n) / static_cast<double>(n - 1));
  double bsum2 = 0.0;
  for (int b = 0; b < kBatches; ++b) {
    const double bm = s.batches.sum(b) / static_cast<double>(s.batches.size(b)) - mean;
    bsum2 += bm * bm;
  }
  const double se_bm = std::sqrt(bsum2 / (kBatches - 1) / kBatches);
  const double se_white = d.raw_std[a] / std::sqrt(static_cast<double>(n));
  d.mean_std_error[a] = std::max(se_bm, se_white);
}

// The raw-sample evidence of a point's kept window, in one pass over the store: noise floor of the
// mean per axis (the processing stage's standard error when the window is short) and the
// noise-stage evidence.
void window_evidence(const Recording& rec, const processing::StaticPoint& p, bool accel, SegmentData& d) {
  const IndexRange w = window_range(rec, p.t_start_s, p.t_end_s);
  const auto n = static_cast<std::size_t>(w.size());
  std::vector<AxisSums> axes(3, AxisSums(n));
  noise_stage::SegmentEvidence evidence(n, accel);
  for_each_sample(rec, w, [&](const ImuSample& x) {
    for (int a = 0; a < 3; ++a) axes[static_cast<std::size_t>(a)].add(axis_value(x, accel, a));
    evidence.add(x);
  });
  if (n >= 16)
    for (int a = 0; a < 3; ++a) mean_noise(axes[static_cast<std::size_t>(a)], n, a, d);
  if (!d.mean_std_error.allFinite()) d.mean_std_error = (accel ? p.accel : p.gyro).std_error;
  // A table's row states its noise (sigma/√n); its held samples, repeating the mean, have none.
  if (accel && p.held && p.held->absolute()) d.mean_std_error = p.accel.std_error;
  evidence.fill(d);
}

// Notes on the table candidates, and their stimulus derivatives cleared when the chain is unusable.
void settle_table(GapInput& in, bool three_axis, bool table_ok) {
  if (three_axis && !table_ok)
    in.notes.push_back("table angle columns found but the sim three-axis table chain does not reproduce the "
                       "truth specific force: table offset/tilt candidates not excited");
  if (!three_axis)
    in.notes.push_back("no three-axis table angle columns: the table offset/tilt candidates are not excited");
  if (!table_ok)
    for (auto& d : in.segments) {
      for (auto& v : d.point.stimulus.table_df_dangle) v.setZero();
      for (auto& v : d.point.stimulus.table_df_dtilt) v.setZero();
    }
}

// Orientation groups by gravity direction; temperature groups by setpoint (else die, 2 °C).
void assign_groups(std::vector<SegmentData>& segments) {
  std::map<std::string, int> og;
  for (auto& d : segments) d.orientation = orientation_group(og, d.orientation_name);
  std::vector<double> levels;
  for (auto& d : segments)
    d.temperature_group =
        temperature_group(levels, std::isfinite(d.setpoint_c) ? d.setpoint_c : d.point.stimulus.temperature_c);
}

}  // namespace

int orientation_group(std::map<std::string, int>& groups, const std::string& name) {
  auto it = groups.find(name);
  if (it == groups.end()) it = groups.emplace(name, static_cast<int>(groups.size())).first;
  return it->second;
}

int temperature_group(std::vector<double>& levels_c, double t_c) {
  if (!std::isfinite(t_c)) return -1;
  int k = -1;
  for (std::size_t i = 0; i < levels_c.size(); ++i)
    if (std::abs(levels_c[i] - t_c) <= kTemperatureLevel_c) k = static_cast<int>(i);
  if (k < 0) {
    levels_c.push_back(t_c);
    k = static_cast<int>(levels_c.size()) - 1;
  }
  return k;
}

bool has_temperature_spread(const std::vector<SegmentData>& segments) {
  std::set<int> levels;
  for (const auto& d : segments)
    if (d.temperature_group >= 0) levels.insert(d.temperature_group);
  return levels.size() >= 2;
}

Eigen::Vector3d table_stimulus(model::Stimulus<double>& st, double az, double h, double dl,
                               const Eigen::Matrix3d& mount, double g) {
  // Gravity through the chain on a tilted base at ε = 0, differentiated exactly by the five angles
  // (az, h, δ, ε_x, ε_y) through Jets.
  using Jet = ceres::Jet<double, 5>;
  const physics::Mat3<Jet> R_top_from_local =
      physics::three_axis_table(Jet(az, 0), Jet(h, 1), Jet(dl, 2)) * physics::tilted_base(Jet(0.0, 3), Jet(0.0, 4));
  const physics::Vec3<Jet> f = mount.cast<Jet>() * physics::gravity_specific_force(R_top_from_local, Jet(g));
  Eigen::Vector3d value;
  Eigen::Matrix<double, 3, 5> df;
  for (int i = 0; i < 3; ++i) {
    value[i] = f[i].a;
    df.row(i) = f[i].v.transpose();
  }
  for (std::size_t k = 0; k < 3; ++k) st.table_df_dangle[k] = df.col(static_cast<Eigen::Index>(k));
  st.table_df_dtilt[0] = df.col(3);
  st.table_df_dtilt[1] = df.col(4);
  return value;
}

GapInput build_input(const Recording& recording_in, const estimation::ModelSpec& spec) {
  std::vector<std::string> thermal;
  for (const auto& t : spec.model.terms)
    if (model::reads_temperature(t.kind)) thermal.push_back(model::term_name(t.kind));
  for (const std::string& why : {estimation::why_absent(recording_in.header.info, spec.model.instrument),
                                  estimation::why_no_temperature(recording_in.header.info, thermal)})
    if (!why.empty()) throw InputError("'" + recording_in.dir.string() + "': not applicable — " + why);
  GapInput in;
  in.spec = spec;
  in.source = recording_in.dir.string();
  const bool accel = spec.model.instrument == model::Instrument::kAccelerometer;
  // Truth columns: the bench's, or those an importer built from the dataset's annotations.
  // Without them the orientations are unknown, only |g|: the magnitude form.
  if (column(recording_in, accel ? kSpecificForceColumns[0] : kRateColumns[0]) < 0)
    return build_magnitude_input(recording_in, spec);
  const Recording* rec = &recording_in;
  in.truth_source = "truth columns";
  const std::vector<processing::StaticPoint> points = static_points(*rec, spec, in);
  in.lsb = accel ? rec->header.info.accel_lsb_mps2 : rec->header.info.gyro_lsb_radps;
  in.range = accel ? rec->header.info.accel_range_mps2 : rec->header.info.gyro_range_radps;
  in.twin_sample_std = twin_sample_std(*rec, accel);

  const TruthColumns cols = truth_columns(*rec);
  bool table_ok = cols.three_axis;
  // Time-ordered walk over the recording's segments for ramp direction and last changes.
  std::vector<const Segment*> segs;
  for (const auto& s : rec->segments) segs.push_back(&s);
  std::sort(segs.begin(), segs.end(), [](const Segment* a, const Segment* b) { return a->t_start_s < b->t_start_s; });
  for (const auto& p : points) {
    SegmentData d;
    d.point = p;
    const Eigen::Vector3d f = truth_stimulus(*rec, cols, p, accel, d.point.stimulus);
    d.orientation_name = orientation_name(f.allFinite() && f.norm() > 0 ? Eigen::Vector3d(f / f.norm())
                                                                        : Eigen::Vector3d::Zero());
    if (table_ok) table_ok = table_derivatives(*rec, cols, p, f, d.point.stimulus);
    segment_history(segs, p, d);
    d.averaging_s = p.t_end_s - p.t_start_s;
    window_evidence(*rec, p, accel, d);
    in.segments.push_back(d);
  }
  settle_table(in, cols.three_axis, table_ok);
  assign_groups(in.segments);
  noise_stage::recording_evidence(in, *rec);  // clipped samples, Allan of a long window
  in.floor_source = "batch means of 8 blocks inside each segment's kept window (Allan-type, robust to "
                    "short-term correlation; never below the white-noise standard error)";
  return in;
}

}  // namespace stend::diagnosis
