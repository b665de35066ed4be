"""The typed result of ``stend.fit``: what `stend fit` prints and writes (docs/schemas/fit.schema.json)."""
import json
import math
from dataclasses import asdict, dataclass

import numpy as np


def _number(v):
    """A JSON number or null as a float (NaN for null)."""
    return math.nan if v is None else float(v)


@dataclass(frozen=True)
class Parameter:
    """One fitted parameter: estimate and 1-sigma standard error in ``unit``, the interval at the fit's
    confidence, and the verdict ("determined", "imprecise" or "not identifiable"; ``reason`` says why)."""
    name: str
    unit: str
    estimate: float
    std_error: float
    interval: tuple
    verdict: str
    identifiable: bool
    tolerance: float
    reason: str

    @classmethod
    def from_json(cls, p):
        lo, hi = (p.get("interval") or [None, None])[:2]
        return cls(p["name"], p.get("unit", ""), _number(p.get("value")), _number(p.get("std_error")),
                   (_number(lo), _number(hi)), p.get("verdict", ""), bool(p.get("identifiable")),
                   _number(p.get("tolerance")), p.get("reason") or "")


@dataclass(frozen=True)
class InstrumentModel:
    """One instrument's fitted model: its parameters' names in the order of ``theta`` and the
    covariance over theta (0 in the rows and columns not estimated)."""
    instrument: str
    status: str
    names: list
    theta: np.ndarray
    covariance: np.ndarray


class FitResult:
    """A fit's outcome as `stend fit` gives it: ``ok``, ``status``, ``exit_code`` (0, 2 not applicable,
    3 failed), ``parameters``, ``covariance`` (of the one instrument fitted; ``instruments`` for each),
    ``summary`` (the one-line verdict), ``text`` (the printed table), ``document`` (the results file's
    JSON) and ``outcome`` (`stend fit --json`)."""

    def __init__(self, native):
        self.outcome = json.loads(native["doc"])
        self.exit_code = native["exit_code"]
        summary = json.loads(native["summary"])
        self.status = summary.get("status", "failed")
        self.message = summary.get("message", "")
        self.estimator = self.outcome.get("estimator", "")
        self.confidence = _number(summary.get("confidence"))
        self.dof = summary.get("dof")
        self.notes = list(summary.get("notes", []))
        self.parameters = [Parameter.from_json(p) for p in summary.get("parameters", [])]
        self.summary = native["brief"]
        self.text = native["text"]
        self.document = self.outcome.get("document")
        self.results_file = self.outcome.get("results_file")
        self.instruments = {name: InstrumentModel(name, m["status"], list(m["names"]), np.asarray(m["theta"]),
                                                  np.asarray(m["covariance"]))
                            for name, m in native["instruments"].items()}

    @property
    def ok(self):
        return self.status == "ok"

    @property
    def covariance(self):
        """The covariance over theta of the instrument fitted (None when none or several)."""
        return next(iter(self.instruments.values())).covariance if len(self.instruments) == 1 else None

    def __getitem__(self, name):
        """The parameter of that name."""
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def to_dict(self):
        """Every field as plain Python values (NaN as None), arrays as nested lists."""
        def clean(v):
            if isinstance(v, float) and math.isnan(v):
                return None
            if isinstance(v, (list, tuple)):
                return [clean(x) for x in v]
            return v
        return {"ok": self.ok, "status": self.status, "message": self.message, "exit_code": self.exit_code,
                "estimator": self.estimator, "confidence": clean(self.confidence), "dof": self.dof,
                "parameters": [{k: clean(v) for k, v in asdict(p).items()} for p in self.parameters],
                "notes": self.notes, "summary": self.summary, "results_file": self.results_file,
                "instruments": {n: {"status": m.status, "names": m.names, "theta": clean(m.theta.tolist()),
                                    "covariance": clean(m.covariance.tolist())} for n, m in self.instruments.items()},
                "document": self.document}

    def to_json(self, indent=2):
        return json.dumps(self.to_dict(), indent=indent)

    def __repr__(self):
        rows = [f"  {p.name:<16} {p.estimate:>12.6g} ± {p.std_error:<10.3g} {p.unit:<10} {p.verdict}"
                for p in self.parameters]
        return "\n".join([f"<stend.FitResult {self.summary}>"] + rows)
