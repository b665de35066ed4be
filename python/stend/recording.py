"""A recording (a run folder, or another tool's log opened through the importers) as NumPy arrays.

Samples are read through the store: ``Recording.samples`` reads them all, ``Recording.chunks(n)``
a chunk at a time (memory bounded by the chunk, not by the record's length).
"""
import json

import numpy as np

from . import _stend


def _sample_dtype():
    """The NumPy dtype of one sample, laid out as the C++ ImuSample (no copy between the two)."""
    at = _stend.sample_layout()
    fields = [  # name, type, offset
        ("t_s", "<f8", at["t_s"]),                       # [s] sample time on the run clock
        ("accel_mps2", ("<f8", (3,)), at["accel_mps2"]),  # [m/s^2] specific force, sensor frame
        ("gyro_radps", ("<f8", (3,)), at["gyro_radps"]),  # [rad/s] angular rate
        ("temperature_c", "<f8", at["temperature_c"]),    # [degC] die temperature (NaN: not measured)
        ("accel_counts", ("<i4", (3,)), at["accel_counts"]),  # raw counts
        ("gyro_counts", ("<i4", (3,)), at["gyro_counts"]),
        ("temperature_counts", "<i4", at["temperature_counts"]),
        ("flags", "<u4", at["flags"]),                   # SampleFlags (gap before, saturated, …)
    ]
    return np.dtype({"names": [f[0] for f in fields], "formats": [f[1] for f in fields],
                     "offsets": [f[2] for f in fields], "itemsize": at["itemsize"]})


SAMPLE_DTYPE = _sample_dtype()

# What a segment row holds (docs/recording-format.md).
_SEGMENT_FIELDS = [("id", "<i8"), ("step", "<i8"), ("kind", "U16"), ("label", None), ("repeat", "<i8"),
                   ("orientation", "<i8"), ("t_start_s", "<f8"), ("t_end_s", "<f8"), ("settled", "?"),
                   ("complete", "?"), ("targets", None), ("setpoint_c", "<f8"), ("rate", "<f8")]


def samples_from_bytes(raw):
    """Bytes of C++ ImuSamples as a structured array (a view, no copy)."""
    return raw.view(SAMPLE_DTYPE)


def _text_width(rows, key):
    return max([1] + [len(r[key]) for r in rows])


class Recording:
    """A recording: ``samples``, ``truth`` and ``segments`` as NumPy structured arrays, ``header``
    and ``events`` as dicts (the header is ``stend info --json`` of it, without segments and events).

    ``source`` remembers how it was opened (inputs and import options), so that ``stend.fit``,
    ``stend.gap`` and ``stend.apply`` read it exactly as the program does."""

    def __init__(self, native, source):
        self._native = native
        self.source = source  # dict: inputs, format, mapping, experiment, accept_damaged, options
        self._info = json.loads(native.info())
        self._samples = None

    @property
    def path(self):
        """The run folder ("" for a dataset file opened in memory)."""
        return self._native.dir()

    def __len__(self):
        return self._native.size()

    @property
    def header(self):
        """``stend info --json`` of the recording, without its segments and events."""
        return {k: v for k, v in self._info.items() if k not in ("segments", "events")}

    @property
    def events(self):
        """Faults, warnings, notes: a list of dicts (t_s, level, source, message)."""
        return list(self._info["events"])

    @property
    def samples(self):
        """Every sample (structured array, SAMPLE_DTYPE). A run folder's are read from the store once;
        a dataset opened in memory is viewed without a copy. For long records use chunks()."""
        if self._samples is None:
            raw = self._native.memory() if self._native.in_memory() else self._native.read(0, len(self))
            self._samples = samples_from_bytes(raw)
        return self._samples

    def chunks(self, n=65536, first=0, last=None):
        """Samples [first, last) in chunks of n (structured arrays), read through the store: memory
        holds one chunk at a time."""
        if n < 1:
            raise ValueError("chunks: n must be at least 1")
        end = len(self) if last is None else min(last, len(self))
        for start in range(first, end, n):
            yield samples_from_bytes(self._native.read(start, min(n, end - start)))

    @property
    def truth(self):
        """The bench truth: a structured array with ``t_s`` [s] and one float field per truth column
        (``table.angle.cmd_deg``, ``f_x_mps2``, …; units in the names)."""
        t, values, columns = self._native.truth()
        dtype = np.dtype([("t_s", "<f8")] + [(c, "<f8") for c in columns])
        out = np.empty(len(t), dtype=dtype)
        out["t_s"] = t
        for k, c in enumerate(columns):
            out[c] = values[:, k]
        return out

    @property
    def segments(self):
        """The segments (poses, rates, turns, records): a structured array, one row per segment."""
        rows = self._native.segments()
        dtype = [(name, kind or f"U{_text_width(rows, name)}") for name, kind in _SEGMENT_FIELDS]
        return np.array([tuple(r[name] for name, _ in _SEGMENT_FIELDS) for r in rows], dtype=dtype)

    def __repr__(self):
        h = self.header
        where = self.path or ", ".join(self.source.get("inputs", []))
        return (f"<stend.Recording {where}: {len(self)} samples, {len(self._info['segments'])} segments, "
                f"{h.get('truth_rows', 0)} truth rows, {len(self.events)} events; status {h.get('status')}>")
