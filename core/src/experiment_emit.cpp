// The resolved experiment: everything read from the file written back as YAML, defaults filled
// in, repeats, sweeps and grids expanded (a run folder's experiment.yaml).
#include "experiment_parse.hpp"

#include <cmath>
#include <stdexcept>
#include <utility>

namespace stend::detail {

using yaml::format_number;

namespace {

// A sensor direction as the vector [x, y, z] (reads back as the same direction).
void emit_direction(YAML::Emitter& out, const char* key, const Eigen::Vector3d& d) {
  out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (int i = 0; i < 3; ++i) out << format_number(d[i]);
  out << YAML::EndSeq;
}

// The time hint of an observed step, when it has one.
void emit_within(YAML::Emitter& out, const Step& s) {
  if (!std::isfinite(s.within_from_s) && !std::isfinite(s.within_to_s)) return;
  out << YAML::Key << "within_s" << YAML::Value << YAML::Flow << YAML::BeginSeq << format_number(s.within_from_s)
      << format_number(s.within_to_s) << YAML::EndSeq;
}

void emit_step(YAML::Emitter& out, const Step& s) {
  const auto num = [&](const char* key, double v) { out << YAML::Key << key << YAML::Value << format_number(v); };
  const auto rates = [&] {
    out << YAML::Key << "rates_dps" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (double r : s.rates) out << format_number(r);
    out << YAML::EndSeq;
  };
  const auto fixture = [&] {
    out << YAML::Key << "fixture" << YAML::Value;
    yaml::emit_string(out, s.fixture);
  };
  out << YAML::BeginMap << YAML::Key << step_kind_name(s.kind) << YAML::Value << YAML::BeginMap;
  switch (s.kind) {
    case Step::Kind::kSetTemperature:
      fixture();
      num("setpoint_c", s.setpoint_c);
      num("tolerance_c", s.tolerance_c);
      num("hold_s", s.hold_s);
      num("timeout_s", s.timeout_s);
      out << YAML::Key << "record" << YAML::Value << s.record_settling;
      break;
    case Step::Kind::kOrientations:
      fixture();
      out << YAML::Key << "list" << YAML::Value << YAML::BeginSeq;
      for (const auto& o : s.orientations) {
        out << YAML::Flow << YAML::BeginMap;
        for (const auto& t : o.targets)
          out << YAML::Key << (t.axis + "_deg") << YAML::Value << format_number(t.value);
        out << YAML::EndMap;
      }
      out << YAML::EndSeq;
      num("dwell_s", s.dwell_s);
      num("record_s", s.record_s);
      break;
    case Step::Kind::kRates:
      fixture();
      out << YAML::Key << "axis" << YAML::Value;
      yaml::emit_string(out, s.axis);
      rates();
      num("dwell_s", s.dwell_s);
      num("record_s", s.record_s);
      break;
    case Step::Kind::kSetVibration:
      fixture();
      num("amplitude_g", s.amplitude_g);
      if (s.amplitude_g > 0 || s.frequency_hz > 0) num("frequency_hz", s.frequency_hz);
      break;
    case Step::Kind::kRecord:
      num("duration_s", s.record_s);
      break;
    case Step::Kind::kWait:
      num("duration_s", s.dwell_s);
      break;
    case Step::Kind::kFaces:
      out << YAML::Key << "list" << YAML::Value << YAML::BeginSeq;
      for (const auto& u : s.faces_up) {
        out << YAML::Flow << YAML::BeginSeq;
        for (int i = 0; i < 3; ++i) out << format_number(u[i]);
        out << YAML::EndSeq;
      }
      out << YAML::EndSeq;
      num("record_s", s.record_s);
      emit_within(out, s);
      break;
    case Step::Kind::kTurns:
      emit_direction(out, "axis", s.sensor_axis);
      num("angle_deg", s.angle_deg);
      out << YAML::Key << "direction" << YAML::Value
          << (s.direction > 0 ? "positive" : s.direction < 0 ? "negative" : "either");
      out << YAML::Key << "count" << YAML::Value << s.count;
      emit_within(out, s);
      break;
    case Step::Kind::kRateLegs:
      emit_direction(out, "axis", s.sensor_axis);
      rates();
      if (s.up) emit_direction(out, "up", *s.up);
      num("record_s", s.record_s);
      emit_within(out, s);
      break;
    case Step::Kind::kStill:
      out << YAML::Key << "count" << YAML::Value;
      if (s.count == 0) out << "all";
      else out << s.count;
      num("record_s", s.record_s);
      emit_within(out, s);
      break;
  }
  out << YAML::Key << "label" << YAML::Value;
  yaml::emit_string(out, s.label);
  if (s.repeat_index != 0) out << YAML::Key << "repeat_index" << YAML::Value << s.repeat_index;
  out << YAML::EndMap << YAML::EndMap;
}

void emit_instance(YAML::Emitter& out, const PluginInstance& p, const PluginCatalogue& cat) {
  out << YAML::Key << "plugin" << YAML::Value;
  yaml::emit_string(out, p.plugin);
  out << YAML::Key << "config" << YAML::Value;
  yaml::emit_params(out, p.params, cat.find(p.plugin));
}

// experiment: name, description, seed, clock, plugin paths.
void emit_experiment_section(YAML::Emitter& out, const Experiment& e) {
  out << YAML::Key << "experiment" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value;
  yaml::emit_string(out, e.name);
  out << YAML::Key << "description" << YAML::Value;
  yaml::emit_string(out, e.description);
  out << YAML::Key << "seed" << YAML::Value << e.seed;
  out << YAML::Key << "clock" << YAML::Value << to_string(e.clock);
  out << YAML::Key << "plugin_paths" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (const auto& p : e.plugin_paths) yaml::emit_string(out, p);
  out << YAML::EndSeq << YAML::EndMap;
}

// gravity: as given (value, or latitude and height), and resolved [m/s²].
void emit_gravity(YAML::Emitter& out, const GravitySpec& g) {
  out << YAML::Key << "gravity" << YAML::Value << YAML::Flow << YAML::BeginMap;
  if (g.value_mps2) {
    out << YAML::Key << "value_mps2" << YAML::Value << format_number(*g.value_mps2);
  } else {
    out << YAML::Key << "latitude_deg" << YAML::Value << format_number(g.latitude_deg);
    out << YAML::Key << "height_m" << YAML::Value << format_number(g.height_m);
  }
  out << YAML::Key << "resolved_mps2" << YAML::Value << format_number(g.resolved_mps2);
  out << YAML::EndMap;
}

// fixtures: each with its id, what it stands on and its plugin config.
void emit_fixtures(YAML::Emitter& out, const Experiment& e, const PluginCatalogue& cat) {
  out << YAML::Key << "fixtures" << YAML::Value;
  if (e.fixtures.empty()) out << YAML::Flow;
  out << YAML::BeginSeq;
  for (const auto& f : e.fixtures) {
    out << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << f.id;
    out << YAML::Key << "on" << YAML::Value << (f.on.empty() ? std::string("base") : f.on);
    emit_instance(out, f, cat);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
}

// mounting: what the sensor is on, and the rotation as a 3x3 matrix (rows).
void emit_mounting(YAML::Emitter& out, const Experiment& e) {
  out << YAML::Key << "mounting" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "on" << YAML::Value
      << (e.mounted_on.empty() ? std::string("base") : e.mounted_on);
  out << YAML::Key << "matrix" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (int r = 0; r < 3; ++r) {
    out << YAML::Flow << YAML::BeginSeq;
    for (int c = 0; c < 3; ++c) out << format_number(e.R_sensor_from_mount(r, c));
    out << YAML::EndSeq;
  }
  out << YAML::EndSeq << YAML::EndMap;
}

void emit_bench_section(YAML::Emitter& out, const Experiment& e, const PluginCatalogue& cat) {
  out << YAML::Key << "bench" << YAML::Value << YAML::BeginMap;
  emit_gravity(out, e.gravity);
  out << YAML::Key << "base_heading_deg" << YAML::Value << format_number(e.base_heading_deg);
  if (!e.sensor.plugin.empty()) {  // none: a procedure for a recording made elsewhere
    out << YAML::Key << "sensor" << YAML::Value << YAML::BeginMap;
    emit_instance(out, e.sensor, cat);
    out << YAML::EndMap;
  }
  emit_fixtures(out, e, cat);
  emit_mounting(out, e);
  out << YAML::EndMap;
}

// processing:, estimation: as given ({} when absent); outputs:.
void emit_later_sections(YAML::Emitter& out, const Experiment& e) {
  for (const auto& [key, node] : {std::pair<const char*, const YAML::Node*>{"processing", &e.processing},
                                   {"estimation", &e.estimation}}) {
    out << YAML::Key << key << YAML::Value;
    if (!node->IsDefined() || node->IsNull() || node->size() == 0)
      out << YAML::Flow << YAML::BeginMap << YAML::EndMap;
    else
      out << *node;
  }
  out << YAML::Key << "limits" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "max_run_time_s" << YAML::Value << e.limits.max_run_time_s;
  out << YAML::Key << "max_samples" << YAML::Value << e.limits.max_samples;
  out << YAML::Key << "max_bytes" << YAML::Value << e.limits.max_bytes;
  out << YAML::EndMap;
  out << YAML::Key << "outputs" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "directory" << YAML::Value;
  yaml::emit_string(out, e.outputs.directory);
  out << YAML::Key << "report" << YAML::Value << e.outputs.report;
  out << YAML::EndMap;
}

}  // namespace

std::string emit_resolved(const Experiment& e, const PluginCatalogue& cat) {
  YAML::Emitter out;
  out << YAML::Comment("Resolved by Stend: defaults filled in, repeats and sweeps expanded");
  out << YAML::BeginMap;
  emit_experiment_section(out, e);
  emit_bench_section(out, e, cat);
  out << YAML::Key << "procedure" << YAML::Value << YAML::BeginSeq;
  for (const auto& s : e.procedure) emit_step(out, s);
  out << YAML::EndSeq;
  emit_later_sections(out, e);
  out << YAML::EndMap;
  if (!out.good()) throw std::logic_error("experiment: cannot emit resolved YAML: " + out.GetLastError());
  return std::string(out.c_str()) + "\n";
}

}  // namespace stend::detail
