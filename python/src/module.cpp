// stend._stend — the Python module's compiled part: the `stend` program's commands (app/commands.hpp,
// the same functions, options and messages) and a recording's samples, truth and segments read
// through the store. The Python package (python/stend/) gives them their shape; docs/python.md.
#include "commands.hpp"

#include "stend/errors.hpp"
#include "stend/recording/recording.hpp"
#include "stend/recording/samples.hpp"
#include "stend/recording/version.hpp"

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace py = pybind11;

namespace stend::python {

namespace {

using cli::ExitCode;

// ---- errors -------------------------------------------------------------------------------------

// Raises the exception being handled as stend.Error (the subclass of its exit code), with the
// message and the exit code the program gives for it.
[[noreturn]] void raise_failure() {
  const cli::Failure f = cli::failure_of_current_exception();
  const py::object type = py::module_::import("stend.errors").attr("error_for")(cli::to_int(f.code));
  const py::tuple args = py::make_tuple(f.text, cli::to_int(f.code));
  PyErr_SetObject(type.ptr(), args.ptr());
  throw py::error_already_set();
}

// Calls `f`; a C++ exception becomes stend.Error, a Python one passes through.
template <class F>
auto guarded(F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (py::error_already_set&) {
    throw;
  } catch (...) {
    raise_failure();
  }
}

// The commands print nothing from Python: their results come back as values.
struct Quiet {
  Quiet() { cli::set_quiet(true); }
  ~Quiet() { cli::set_quiet(false); }
};

// ---- arguments ----------------------------------------------------------------------------------

// An option given from Python (None: the program's own default, written once in its Args struct).
template <class T, class U>
void set_given(T& field, const std::optional<U>& given) {
  if (given) field = *given;
}

// An import option's value as the command line gives it: True → "true", a list → "a,b,c".
std::string option_text(const py::handle& value) {
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>() ? "true" : "";
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
    std::string text;
    for (const auto& item : value) text += (text.empty() ? "" : ",") + py::str(item).cast<std::string>();
    return text;
  }
  return py::str(value).cast<std::string>();
}

// The import options as keyword arguments, each checked as the command line checks its flag (a
// usage error, exit 1, naming the flag).
std::map<std::string, std::string> import_flags(const py::dict& options) {
  std::map<std::string, std::string> flags;
  for (const auto& [k, v] : options) {
    const std::string key = k.cast<std::string>(), value = option_text(v);
    const auto& keys = io::import_keys();
    if (std::none_of(keys.begin(), keys.end(), [&](const io::ImportKey& ik) { return ik.key == key; }))
      throw cli::Refusal(ExitCode::kUsage, "unknown import option '" + key + "' (" + io::import_flag(key) +
                                               "); the import options: `stend import --help`");
    if (value.empty()) continue;
    try {
      io::ImportOptions().set(key, value);
    } catch (const std::invalid_argument& e) {
      throw cli::Refusal(ExitCode::kUsage, io::import_flag(key) + ": " + e.what());
    }
    flags[key] = value;
  }
  return flags;
}

// What a command reads, as DatasetArgs (app/commands.hpp): inputs, --format, --mapping,
// --experiment, --accept-damaged and the import flags.
cli::DatasetArgs dataset_args(const std::vector<std::string>& inputs, const std::optional<std::string>& format,
                              const std::string& mapping, const std::string& experiment, bool accept_damaged,
                              const py::dict& options) {
  cli::DatasetArgs d;
  d.inputs = inputs;
  set_given(d.format, format);
  d.mapping = mapping;
  d.experiment = experiment;
  d.accept_damaged = accept_damaged;
  d.flags = import_flags(options);
  return d;
}

// ---- a recording --------------------------------------------------------------------------------

// Byte offsets of ImuSample's members: the NumPy dtype of a sample (python/stend/recording.py).
py::dict sample_layout() {
  const ImuSample s;
  const auto at = [&s](const void* member) {
    return static_cast<std::size_t>(static_cast<const char*>(member) - reinterpret_cast<const char*>(&s));
  };
  py::dict d;
  d["itemsize"] = sizeof(ImuSample);
  d["t_s"] = at(&s.t_s);
  d["accel_counts"] = at(&s.accel_counts[0]);
  d["gyro_counts"] = at(&s.gyro_counts[0]);
  d["temperature_counts"] = at(&s.temperature_counts);
  d["accel_mps2"] = at(s.accel_mps2.data());
  d["gyro_radps"] = at(s.gyro_radps.data());
  d["temperature_c"] = at(&s.temperature_c);
  d["flags"] = at(&s.flags);
  return d;
}

// Samples owned by a NumPy array of bytes (no copy: the array keeps the vector).
py::array_t<std::uint8_t> owned_bytes(std::vector<ImuSample> samples) {
  auto* held = new std::vector<ImuSample>(std::move(samples));
  py::capsule owner(held, [](void* p) { delete static_cast<std::vector<ImuSample>*>(p); });
  const auto bytes = static_cast<py::ssize_t>(held->size() * sizeof(ImuSample));
  return py::array_t<std::uint8_t>({bytes}, {1}, reinterpret_cast<const std::uint8_t*>(held->data()), owner);
}

// A recording opened for Python: samples and truth in the store (read in chunks) or, for a dataset
// file opened without a run folder, in memory.
class PyRecording {
 public:
  explicit PyRecording(Recording rec) : rec_(std::make_shared<Recording>(std::move(rec))) {}
  std::uint64_t size() const { return rec_->sample_count(); }
  std::string dir() const { return rec_->dir.string(); }
  bool in_memory() const { return !rec_->source; }

  // Samples [first, first + count) as bytes of ImuSample, read through the store.
  py::array_t<std::uint8_t> read(std::uint64_t first, std::size_t count) const {
    return guarded([&] {
      if (first > size()) throw std::out_of_range("first sample beyond the recording's end");
      const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(count, size() - first));
      std::vector<ImuSample> out(n);
      if (n > 0) rec_->sample_source().read(first, n, out.data());
      return owned_bytes(std::move(out));
    });
  }
  // The samples held in memory as bytes, without a copy (the array keeps `self` alive).
  py::array_t<std::uint8_t> memory(py::object self) const {
    const auto bytes = static_cast<py::ssize_t>(rec_->samples.size() * sizeof(ImuSample));
    return py::array_t<std::uint8_t>({bytes}, {1}, reinterpret_cast<const std::uint8_t*>(rec_->samples.data()), self);
  }
  // The bench truth: times [s], values (rows × columns) and the column names.
  py::tuple truth() const {
    return guarded([&] {
      const auto src = rec_->recorded_truth();
      const std::size_t rows = static_cast<std::size_t>(src->rows()), cols = src->columns();
      py::array_t<double> t(static_cast<py::ssize_t>(rows));
      py::array_t<double> values({static_cast<py::ssize_t>(rows), static_cast<py::ssize_t>(cols)});
      std::vector<char> whole(rows);  // bool storage for RecordedTruth::read
      if (rows > 0)
        src->read(0, rows, t.mutable_data(), values.mutable_data(), reinterpret_cast<bool*>(whole.data()));
      return py::make_tuple(t, values, rec_->header.truth_columns);
    });
  }
  // `stend info --json` of this recording (docs/schemas/info.schema.json).
  std::string info() const {
    return guarded([&] { return cli::recording_summary(*rec_).dump(); });
  }
  std::vector<py::dict> segments() const {
    std::vector<py::dict> out;
    for (const auto& s : rec_->segments) {
      py::dict d;
      d["id"] = s.id;
      d["step"] = s.step;
      d["kind"] = std::string(to_string(s.kind));
      d["label"] = s.label;
      d["repeat"] = s.repeat;
      d["orientation"] = s.orientation;
      d["t_start_s"] = s.t_start_s;
      d["t_end_s"] = s.t_end_s;
      d["settled"] = s.settled;
      d["complete"] = s.complete;
      d["targets"] = s.targets;
      d["setpoint_c"] = s.setpoint_c;
      d["rate"] = s.rate;
      out.push_back(std::move(d));
    }
    return out;
  }

 private:
  std::shared_ptr<Recording> rec_;
};

PyRecording open_run(const std::string& path, bool accept_damaged) {
  return guarded([&] {
    cli::DatasetArgs d;
    d.inputs = {path};
    d.accept_damaged = accept_damaged;
    if (!d.is_run()) {
      const Quiet quiet;  // the import's warnings are the recording's events
      return PyRecording(d.open());
    }
    Recording rec = Recording::open(path, SampleLoading::kStream, TruthLoading::kStream);
    d.checked(rec);
    return PyRecording(std::move(rec));
  });
}

PyRecording open_dataset(const std::vector<std::string>& inputs, const std::optional<std::string>& format, const std::string& mapping,
                         const std::string& experiment, bool accept_damaged, const py::dict& options) {
  return guarded([&] {
    const Quiet quiet;
    return PyRecording(dataset_args(inputs, format, mapping, experiment, accept_damaged, options).open());
  });
}

// ---- commands -----------------------------------------------------------------------------------

// (exit code, --json document as text)
py::tuple outcome(const cli::Outcome& o) { return py::make_tuple(cli::to_int(o.code), o.doc.dump()); }

py::tuple import_run(const std::vector<std::string>& inputs, const std::string& output, const std::string& name,
                     const std::optional<std::string>& format, const std::string& mapping, const std::string& experiment,
                     const py::dict& options) {
  return guarded([&] {
    const Quiet quiet;
    cli::ImportArgs a;
    a.data = dataset_args(inputs, format, mapping, experiment, false, options);
    a.output = output;
    a.name = name;
    return outcome(cli::run_import(a));
  });
}

// One instrument model of a fit: its parameters' names in θ order, θ and the covariance over θ.
py::dict instrument_dict(const estimation::InstrumentModel& m) {
  std::vector<std::string> names;
  for (const auto& p : m.parameters) names.push_back(p.name);
  py::dict d;
  d["status"] = std::string(estimation::to_string(m.status));
  d["names"] = names;
  d["theta"] = m.theta;
  d["covariance"] = m.covariance;
  return d;
}

py::dict fit(const std::vector<std::string>& inputs, const std::string& model, const std::optional<std::string>& format,
             const std::string& mapping, const std::string& experiment, bool accept_damaged, const py::dict& options,
             const std::string& out, const std::optional<std::string>& estimator, const std::string& db) {
  return guarded([&] {
    const Quiet quiet;
    cli::FitArgs a;
    a.data = dataset_args(inputs, format, mapping, experiment, accept_damaged, options);
    a.model = model;
    a.out = out;
    set_given(a.estimator, estimator);
    a.db = db;
    const cli::FitCommandOutcome o = cli::run_fit(a);
    const estimation::FitResult& r = o.fit.result;
    py::dict d;
    d["exit_code"] = cli::to_int(o.fit.exit_code());
    d["doc"] = o.doc.dump();
    d["summary"] = estimation::to_json(r.summary).dump();
    d["brief"] = r.BriefReport();
    d["text"] = r.text;
    py::dict instruments;
    if (r.accelerometer) instruments["accelerometer"] = instrument_dict(*r.accelerometer);
    if (r.gyroscope) instruments["gyroscope"] = instrument_dict(*r.gyroscope);
    d["instruments"] = instruments;
    return d;
  });
}

// The runner's progress as a dict (RunProgress, core/runner.hpp).
py::dict progress_dict(const RunProgress& p) {
  py::dict d;
  d["step"] = p.step;
  d["step_count"] = p.step_count;
  d["step_label"] = p.step_label;
  d["phase"] = std::string(to_string(p.phase));
  d["item"] = p.item;
  d["item_count"] = p.item_count;
  d["run_time_s"] = p.run_time_s;
  d["remaining_s"] = p.remaining_s;
  d["samples"] = p.samples;
  d["setpoint_c"] = p.setpoint_c;
  d["air_c"] = p.air_c;
  d["die_c"] = p.die_c;
  return d;
}

// `stend run`: the progress callback called every period_s of wall time; Ctrl-C (KeyboardInterrupt)
// or an exception in the callback stops the run cleanly, as Ctrl-C does in the program.
py::tuple run(const std::string& file, const std::string& output, const std::string& name, const std::string& clock,
              const std::optional<std::string>& store, const std::string& db, bool allow_plugins,
              const py::object& progress, const std::optional<double>& period_s) {
  std::atomic<bool> stop{false};
  std::optional<py::error_already_set> raised;
  cli::RunHooks hooks;
  hooks.stop = &stop;
  set_given(hooks.period_s, period_s);
  hooks.on_progress = [&](const RunProgress& p) {
    if (raised) return;
    try {
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (!progress.is_none()) progress(progress_dict(p));
    } catch (py::error_already_set& e) {
      raised.emplace(std::move(e));
      stop.store(true);
    }
  };
  cli::RunArgs a;
  a.file = file;
  a.output = output;
  a.name = name;
  a.clock = clock;
  set_given(a.store, store);
  a.db = db;
  a.allow_plugins = allow_plugins;
  const py::tuple o = guarded([&] {
    const Quiet quiet;
    return outcome(cli::run_run(a, hooks));
  });
  if (raised) throw *raised;
  return o;
}

py::tuple apply(const std::string& cal, const std::vector<std::string>& inputs, const std::string& output,
                const std::vector<std::string>& assumptions, bool validate, const std::vector<std::string>& rotations,
                const std::optional<double>& rebias_from_start_s, const std::optional<double>& gravity_mps2,
                const std::optional<double>& confidence, const std::string& validation_out,
                const std::optional<std::string>& format, const std::string& mapping, const std::string& experiment,
                bool accept_damaged, const py::dict& options) {
  return guarded([&] {
    const Quiet quiet;
    cli::ApplyArgs a;
    a.cal = cal;
    a.data = dataset_args(inputs, format, mapping, experiment, accept_damaged, options);
    a.output = output;
    a.json = validation_out;
    a.validate = validate;
    a.rotations = rotations;
    a.assumptions = assumptions;
    set_given(a.options.rebias_from_start_s, rebias_from_start_s);
    set_given(a.options.gravity_mps2, gravity_mps2);
    set_given(a.options.confidence, confidence);
    return outcome(cli::run_apply(a));
  });
}

// A calibration applied to samples in memory (bytes of ImuSample) → the calibrated samples.
py::array_t<std::uint8_t> apply_samples(const std::string& cal_path, const std::vector<std::string>& assumptions,
                                        const py::array_t<std::uint8_t, py::array::c_style>& raw_bytes) {
  return guarded([&] {
    const calibration::Calibration cal = cli::load_stated_calibration(cal_path, assumptions);
    Recording raw;
    raw.samples.resize(static_cast<std::size_t>(raw_bytes.size()) / sizeof(ImuSample));
    std::memcpy(static_cast<void*>(raw.samples.data()), raw_bytes.data(), raw.samples.size() * sizeof(ImuSample));
    const Recording calibrated = calibration::apply_calibration(raw, cal);
    std::vector<ImuSample> out(raw.samples.size());
    if (!out.empty()) calibrated.sample_source().read(0, out.size(), out.data());
    return owned_bytes(std::move(out));
  });
}

py::tuple gap(const std::vector<std::string>& inputs, const std::string& model, const std::string& out,
              const std::optional<std::string>& fold_by, const std::optional<int>& max_steps,
              const std::optional<int>& max_folds, const std::optional<double>& alpha, const std::string& db,
              const std::optional<std::string>& format, const std::string& mapping, const std::string& experiment,
              bool accept_damaged, const py::dict& options) {
  return guarded([&] {
    const Quiet quiet;
    cli::GapArgs a;
    a.data = dataset_args(inputs, format, mapping, experiment, accept_damaged, options);
    a.model = model;
    a.json = out;
    set_given(a.fold_by, fold_by);
    set_given(a.max_steps, max_steps);
    set_given(a.max_folds, max_folds);
    set_given(a.alpha, alpha);
    a.db = db;
    return outcome(cli::run_gap(a));
  });
}

py::tuple export_run(const std::string& run, const std::string& to, const std::string& output, const std::string& db,
                     const std::string& procedure, const std::optional<std::string>& from,
                     const std::optional<std::string>& rostopic, const std::optional<int>& px4_id,
                     const std::optional<int>& px4_instance, bool accept_damaged,
                     const std::vector<std::string>& assume) {
  return guarded([&] {
    const Quiet quiet;
    cli::ExportArgs a;
    a.assumptions = assume;
    a.run = run;
    a.format = to;
    a.output = output;
    a.db = db;
    a.procedure = procedure;
    set_given(a.options.from, from);
    set_given(a.options.rostopic, rostopic);
    set_given(a.options.px4_device_id, px4_id);
    set_given(a.options.px4_instance, px4_instance);
    a.options.accept_damaged = accept_damaged;
    return outcome(cli::run_export(a));
  });
}

// `stend deviations`: of a file's column as the program reads it, or of `values` (frequency or
// phase, one per tau0) given as an array.
py::tuple deviations(const std::string& file, const std::optional<std::vector<double>>& values, bool phase,
                     const std::optional<double>& tau0_s, const std::optional<double>& rate_hz,
                     const std::optional<std::string>& column, const std::optional<std::size_t>& skip_lines,
                     const std::vector<std::string>& kinds, const std::optional<std::string>& tau,
                     const std::optional<std::uint64_t>& max_m, const std::optional<double>& confidence,
                     const std::string& unit) {
  return guarded([&] {
    const Quiet quiet;
    cli::DeviationsArgs a;
    a.file = file;
    set_given(a.column.column, column);
    set_given(a.column.skip_lines, skip_lines);
    a.phase = phase;
    set_given(a.tau0_s, tau0_s);
    set_given(a.rate_hz, rate_hz);
    a.kinds = kinds;
    set_given(a.tau, tau);
    set_given(a.max_m, max_m);
    set_given(a.confidence, confidence);
    a.unit = unit;
    if (!values) return outcome(cli::run_deviations(a));
    return outcome(cli::deviations_of({*values, 1, ""}, a));
  });
}

}  // namespace

}  // namespace stend::python

PYBIND11_MODULE(_stend, m) {
  namespace sp = stend::python;
  m.doc() = "The compiled part of the stend package: use `import stend` (docs/python.md).";
  m.def("version", [] { return std::string(stend::version()); });
  m.def("sample_layout", &sp::sample_layout);
  m.def("export_formats", [] { return stend::reporting::export_formats(); });
  py::class_<sp::PyRecording>(m, "Recording")
      .def("size", &sp::PyRecording::size)
      .def("dir", &sp::PyRecording::dir)
      .def("in_memory", &sp::PyRecording::in_memory)
      .def("read", &sp::PyRecording::read)
      .def("memory", [](py::object self) { return self.cast<const sp::PyRecording&>().memory(self); })
      .def("truth", &sp::PyRecording::truth)
      .def("info", &sp::PyRecording::info)
      .def("segments", &sp::PyRecording::segments);
  m.def("open_run", &sp::open_run);
  m.def("open_dataset", &sp::open_dataset);
  m.def("import_run", &sp::import_run);
  m.def("fit", &sp::fit);
  m.def("run", &sp::run);
  m.def("apply", &sp::apply);
  m.def("apply_samples", &sp::apply_samples);
  m.def("gap", &sp::gap);
  m.def("export_run", &sp::export_run);
  m.def("deviations", &sp::deviations);
}
