#!/usr/bin/env python3
"""Octave overlapping Allan deviation with confidence intervals by allantools (the peer).

    allantools_octave.py FILE --rate HZ [--out JSON] [--max-m M] [--allantools DIR]

FILE is a Stend run folder's run.h5 (read with h5py as docs/recording-format.md shows: counts
times the stored LSB plus offset, or the stored SI column, with the exceptions applied) or its
imu.csv (CSV store; read with pandas). For each of the
six channels (ax ay az in m/s², gx gy gz in rad/s) it computes allantools.oadev of the rate data
at τ = m/rate, m = 1, 2, 4, … ≤ min(max_m, N/2), and the one-sigma interval from allantools'
Greenhall EDF for white noise (ci.edf_greenhall, overlapping) and its chi-squared interval
(ci.confidence_interval) — what a user of allantools writes to get Stend's table. Writes
{"channel": {"m": [...], "adev": [...], "lo": [...], "hi": [...]}} as JSON.
"""
import argparse
import json
import os
import sys

CHANNELS = {"ax": "ax_mps2", "ay": "ay_mps2", "az": "az_mps2",
            "gx": "gx_radps", "gy": "gy_radps", "gz": "gz_radps"}


def read_h5(path):
    import h5py
    names = list(CHANNELS)
    with h5py.File(path, "r", swmr=True) as f:
        g = f["samples"]
        exceptions = g["exceptions"][:]
        out = {}
        for k, name in enumerate(names):
            if CHANNELS[name] in g:
                out[name] = g[CHANNELS[name]][:]
                continue
            d = g[name + "_counts"]
            v = d[:] * d.attrs["lsb"] + d.attrs["offset"]
            for i, ch, _, x in exceptions:
                if int(ch) == k:
                    v[int(i)] = x
            out[name] = v
        return out


def read_columns(path):
    if path.endswith((".h5", ".hdf5")):
        return read_h5(path)
    import pandas as pd
    frame = pd.read_csv(path, usecols=list(CHANNELS.values()), dtype="float64")
    return {c: frame[col].to_numpy() for c, col in CHANNELS.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file")
    ap.add_argument("--rate", type=float, required=True, help="sample rate [Hz]")
    ap.add_argument("--out", default="-")
    ap.add_argument("--max-m", type=int, default=1 << 22)
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--allantools", default=os.path.join(here, "..", "..", "shared", "peers", "allantools"))
    args = ap.parse_args()
    sys.path.insert(0, args.allantools)
    import numpy as np
    import allantools
    from allantools import ci

    result = {}
    for name, y in read_columns(args.file).items():
        n = len(y)
        ms = [1 << k for k in range(64) if (1 << k) <= args.max_m and 2 * (1 << k) <= n]
        taus = np.array(ms, dtype=float) / args.rate
        t, adev, _, _ = allantools.oadev(y, rate=args.rate, data_type="freq", taus=taus)
        m_used = [int(round(v * args.rate)) for v in t]
        lo, hi = [], []
        for m, dev in zip(m_used, adev):
            edf = ci.edf_greenhall(alpha=0, d=2, m=m, N=n + 1, overlapping=True, modified=False)
            a, b = ci.confidence_interval(dev, edf, ci=ci.ONE_SIGMA_CI)
            lo.append(float(a))
            hi.append(float(b))
        result[name] = {"m": m_used, "adev": [float(v) for v in adev], "lo": lo, "hi": hi}
    text = json.dumps(result, indent=1)
    if args.out == "-":
        print(text)
    else:
        with open(args.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
