"""stend from Python: the `stend` program's commands as functions, recordings as NumPy arrays.

    import stend
    rec = stend.open("runs/six_position-…")            # a run folder (or a dataset file)
    result = stend.fit(rec, "estimators/batch_lsq/examples/paper_z_channel.yaml")
    print(result)                                       # parameters, std errors, verdicts

Every function calls the same library code as the command of the same name (app/commands.hpp),
with its options as keyword arguments (None: the program's own default); what the program reports
as an error is raised as stend.Error (its message and exit code). docs/python.md.
"""
import builtins
import json
import os
import tempfile

def _import_numpy():
    """NumPy; an interpreter of the same Python version without one of its own (e.g. a pyenv build
    first on PATH) uses Debian's python3-numpy, which the module is built against."""
    try:
        import numpy
        return numpy
    except ImportError as missing:
        import sys
        debian = "/usr/lib/python3/dist-packages"
        if debian not in sys.path and os.path.isdir(os.path.join(debian, "numpy")):
            sys.path.append(debian)
            try:
                import numpy
                return numpy
            except ImportError:
                pass
        raise ImportError(f"stend needs NumPy, which {sys.executable} lacks: use Debian's python3 (/usr/bin/python3, "
                          "apt-get install python3-numpy), the one the module is built for (docs/python.md)") from missing


np = _import_numpy()

from . import _stend
from .errors import Error, FitFailed, InputError, IoFailure, Stopped, UsageError, raise_outcome
from .recording import SAMPLE_DTYPE, Recording
from .results import FitResult, InstrumentModel, Parameter

__version__ = _stend.version()
__all__ = ["open", "import_", "fit", "run", "apply", "gap", "export", "deviations", "Recording", "FitResult", "Parameter",
           "InstrumentModel", "SAMPLE_DTYPE", "Error", "UsageError", "InputError", "FitFailed", "IoFailure",
           "Stopped", "__version__"]


def _inputs(files):
    """One path or several (IMU-TK: ACC and GYRO) as a list of strings."""
    if isinstance(files, (str, os.PathLike)):
        return [os.fspath(files)]
    return [os.fspath(f) for f in files]


def _source(data, format=None, mapping=None, experiment=None, accept_damaged=False, options=None):
    """What a command reads: a Recording (as it was opened) or paths with the import options."""
    if isinstance(data, Recording):
        s = dict(data.source)
        if data.path:
            s = {"inputs": [data.path], "format": None, "mapping": "", "experiment": "", "options": {}}
        s["accept_damaged"] = accept_damaged or s.get("accept_damaged", False)
        return s
    return {"inputs": _inputs(data), "format": format, "mapping": os.fspath(mapping) if mapping else "",
            "experiment": os.fspath(experiment) if experiment else "", "accept_damaged": accept_damaged,
            "options": dict(options or {})}


def _args(s):
    return (s["format"], s["mapping"], s["experiment"], s["accept_damaged"], s["options"])


def open(path, *, accept_damaged=False):
    """A run folder (samples and truth left in the store, read in chunks), or a dataset file read
    through the importers with its format detected (as `stend fit FILE` reads it)."""
    s = _source(path, accept_damaged=accept_damaged)
    if len(s["inputs"]) == 1 and os.path.isdir(s["inputs"][0]):
        return Recording(_stend.open_run(s["inputs"][0], accept_damaged), s)
    return Recording(_stend.open_dataset(s["inputs"], *_args(s)), s)


def import_(files, output=None, *, format=None, mapping=None, experiment=None, name="", **options):
    """Another tool's log as a Recording — `stend import FILES [-o OUTPUT] --experiment … --KEY VALUE`.

    With ``output`` the log is streamed into a new run folder (as `stend import -o`; bounded memory)
    and that folder is opened; without, it is read into memory. ``options`` are the import keys of
    the command line with '_' for '-' (accel="ax,ay,az" or ["ax", "ay", "az"], accel_lsb="1/16384g",
    time_unit="ms", …; `stend import --help`); ``experiment`` the procedure file."""
    s = _source(files, format, mapping, experiment, False, options)
    if output is None:
        return Recording(_stend.open_dataset(s["inputs"], *_args(s)), s)
    code, doc = _stend.import_run(s["inputs"], os.fspath(output), name, s["format"], s["mapping"], s["experiment"],
                                  s["options"])
    if code != 0:
        raise_outcome(code, json.loads(doc), "stend import")
    return open(json.loads(doc)["run_dir"])


class _ModelFile:
    """A model given as a path, or as a dict written to a temporary YAML file for the call."""

    def __init__(self, model):
        self.model, self.tmp = model, None

    def __enter__(self):
        if isinstance(self.model, dict):
            self.tmp = tempfile.TemporaryDirectory(prefix="stend-model-")
            path = os.path.join(self.tmp.name, "model.yaml")
            with builtins.open(path, "w") as f:
                json.dump(self.model, f)  # JSON is YAML
            return path
        return os.fspath(self.model)

    def __exit__(self, *exc):
        if self.tmp is not None:
            self.tmp.cleanup()


def fit(data, model, *, out=None, estimator=None, db="", format=None, mapping=None, experiment=None,
        accept_damaged=False, **options):
    """Fits a model — `stend fit DATA --model MODEL [-o OUT]`: the results go where `stend fit` writes
    them (a run folder's results file and report; a dataset file's only with ``out``).

    ``data``: a Recording, a run folder or dataset file(s); ``model``: a model file or a dict of its
    keys. Returns a FitResult (``ok`` False and ``exit_code`` 3 for a fit that failed: it says why)."""
    s = _source(data, format, mapping, experiment, accept_damaged, options)
    with _ModelFile(model) as path:
        return FitResult(_stend.fit(s["inputs"], path, *_args(s), os.fspath(out) if out else "", estimator, db))


def run(experiment, *, progress=None, output="", name="", clock="", store=None, db="", allow_plugins=False,
        progress_period_s=None):
    """Runs an experiment — `stend run EXPERIMENT`: records a run folder, fits the model the
    experiment names, writes the report. ``progress(dict)`` is called every progress_period_s [s] of
    wall time (step, step_count, step_label, phase, run_time_s, remaining_s, samples, …); Ctrl-C or an
    exception in it stops the run cleanly. Returns the summary (`stend run --json`) with the run as
    ``summary["recording"]``; raises stend.Error when the run does not complete or its fit fails."""
    code, doc = _stend.run(os.fspath(experiment), os.fspath(output), name, clock, store, db, allow_plugins,
                           progress, progress_period_s)
    summary = json.loads(doc)
    if code != 0:
        raise_outcome(code, summary, "stend run")
    summary["recording"] = open(summary["run_dir"])
    return summary


def _sample_array(data):
    """Samples to calibrate as a SAMPLE_DTYPE array: one already, a Recording's, or a dict of
    accel_mps2 (N×3) [m/s^2], gyro_radps (N×3) [rad/s], temperature_c (N) [degC] and t_s (N) [s]."""
    if isinstance(data, Recording):
        return data.samples
    if isinstance(data, np.ndarray) and data.dtype == SAMPLE_DTYPE:
        return data
    accel = np.asarray(data["accel_mps2"], dtype=float)
    out = np.zeros(len(accel), dtype=SAMPLE_DTYPE)
    out["accel_mps2"] = accel
    for key in ("gyro_radps", "temperature_c", "t_s"):
        if key in data:
            out[key] = np.asarray(data[key], dtype=float)
    return out


def apply(calibration, data, output=None, *, assume=(), validate=False, expect_rotation=(), rebias_from_start_s=None,
          gravity_mps2=None, confidence=None, validation_out=None, format=None, mapping=None, experiment=None,
          accept_damaged=False, **options):
    """Applies a fitted calibration (a results file, or the run folder holding one).

    To arrays: ``data`` a SAMPLE_DTYPE array or a dict of accel_mps2 / gyro_radps / temperature_c
    arrays → the calibrated samples (SAMPLE_DTYPE), in memory.
    To a recording — `stend apply CAL DATA -o OUTPUT --validate --expect-rotation x:90 --assume …`:
    ``data`` a run folder, dataset file(s) or a Recording opened from one → the command's --json
    document (``validation``: PASS/FAIL per check; ``ok`` False when it failed, exit code 3)."""
    assume = [assume] if isinstance(assume, str) else list(assume)
    if isinstance(data, (np.ndarray, dict)):
        raw = np.ascontiguousarray(_sample_array(data))
        return _stend.apply_samples(os.fspath(calibration), assume, raw.view(np.uint8).reshape(-1)).view(SAMPLE_DTYPE)
    s = _source(data, format, mapping, experiment, accept_damaged, options)
    rotations = [expect_rotation] if isinstance(expect_rotation, str) else list(expect_rotation)
    code, doc = _stend.apply(os.fspath(calibration), s["inputs"], os.fspath(output) if output else "", assume,
                             validate, rotations, rebias_from_start_s, gravity_mps2, confidence,
                             os.fspath(validation_out) if validation_out else "", *_args(s))
    result = json.loads(doc)
    result["exit_code"] = code
    result["ok"] = code == 0
    return result


def gap(data, model, *, out=None, fold_by=None, max_steps=None, max_folds=None, alpha=None, db="", format=None,
        mapping=None, experiment=None, accept_damaged=False, **options):
    """Sim-to-real gap diagnosis — `stend gap DATA --model MODEL`: where the twin disagrees, which
    unmodelled effect explains it, how far it shrinks held out. Returns `stend gap --json`'s document
    (``ok``, ``results_file``, ``document``) with ``exit_code``."""
    s = _source(data, format, mapping, experiment, accept_damaged, options)
    with _ModelFile(model) as path:
        code, doc = _stend.gap(s["inputs"], path, os.fspath(out) if out else "", fold_by, max_steps, max_folds, alpha,
                               db, *_args(s))
    result = json.loads(doc)
    result["exit_code"] = code
    return result


def export(run_dir, to, output=None, *, db="", procedure="", from_=None, rostopic=None, px4_id=None, px4_instance=None,
           accept_damaged=False, assume=()):
    """A run's results in another tool's format — `stend export RUN --to FORMAT [-o OUTPUT]`:
    kalibr | matlab | imutk | px4 | json | csv. Returns the files written, notes and warnings.
    ``assume``: values for parameters the fit did not determine (``"bias_x=0"``, as --assume), without
    which such a calibration is refused (stend.Error, exit code 2)."""
    assume = [assume] if isinstance(assume, str) else list(assume)
    if isinstance(run_dir, Recording):
        run_dir = run_dir.path
    if to not in _stend.export_formats():
        raise UsageError(f"--to: {to} not in {{{', '.join(_stend.export_formats())}}}", 1)
    code, doc = _stend.export_run(os.fspath(run_dir) if run_dir else "", to, os.fspath(output) if output else "", db,
                                  procedure, from_, rostopic, px4_id, px4_instance, accept_damaged, assume)
    return json.loads(doc)





_DEVIATION_KINDS = ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev")


def deviations(series, *, tau0_s=None, rate_hz=None, phase=False, column=None, skip_lines=None, kinds=(), tau=None,
               max_m=None, confidence=None, unit=""):
    """Every frequency-stability deviation (ADEV … TOTDEV) with its interval, EDF and noise type —
    `stend deviations FILE --tau0 S [--phase] [--column C] --json`. ``series``: a text file (one value
    per line or a column, as Stable32 and allantools take them) or a 1-D array of values, one per
    tau0_s [s] (or rate_hz [Hz]). Returns the --json document (``ok``; ``deviations`` per kind and
    point: tau_s, m, terms, value, edf, lo, hi, alpha) with ``exit_code`` (3: unusable, ``reason``)."""
    kinds = [kinds] if isinstance(kinds, str) else list(kinds)
    unknown = [k for k in kinds if k not in _DEVIATION_KINDS]
    if unknown:
        raise UsageError(f"--kinds: {unknown[0]} not in {{{', '.join(_DEVIATION_KINDS)}}}", 1)
    if isinstance(series, (str, os.PathLike)):
        file, values = os.fspath(series), None
    else:
        file, values = "(array)", np.asarray(series, dtype=float).ravel().tolist()
    code, doc = _stend.deviations(file, values, phase, tau0_s, rate_hz, None if column is None else str(column),
                                  skip_lines, kinds, tau, max_m,
                                  confidence, unit)
    result = json.loads(doc)
    result["exit_code"] = code
    return result
