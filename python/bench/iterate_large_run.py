#!/usr/bin/env python3
"""Iterates a large simulated run from Python a chunk at a time and reports the peak resident
memory (issue 39: a 10^8-sample run within 256 MB). The run is made by the `stend` program in a
temporary folder (removed afterwards: about 14 bytes per sample on disk, 1.4 GB for 10^8).

Usage: PYTHONPATH=build/python python3 python/bench/iterate_large_run.py [SAMPLES] [STEND]
       (default 10^8 samples, build/bin/stend)"""
import pathlib
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

import stend

RATE_HZ = 1000  # [Hz]
LIMIT_MB = 256  # [MB] peak resident memory of this process


def make_run(folder, samples, program):
    config = folder / "large.yaml"
    config.write_text(f"""experiment: {{name: large, seed: 8}}
bench:
  sensor: {{plugin: sim_imu, config: {{output_rate_hz: {RATE_HZ}, lowpass_hz: 200}}}}
  fixtures: [{{id: table, plugin: sim_one_axis_table}}]
  mounting: {{on: table}}
procedure:
  - record: {{duration_s: {samples // RATE_HZ}, label: static}}
""")
    subprocess.run([program, "run", str(config), "--quiet", "--output", str(folder), "--name", "large"], check=True,
                   stdout=subprocess.DEVNULL)
    return folder / "large"


def iterate(run_dir):
    rec = stend.open(run_dir)
    n, total = 0, np.zeros(3)
    for chunk in rec.chunks(1 << 16):
        n += len(chunk)
        total += chunk["accel_mps2"].sum(axis=0)  # [m/s^2]
    return len(rec), n, total / max(n, 1)


def main():
    samples = int(float(sys.argv[1])) if len(sys.argv) > 1 else 10**8
    program = sys.argv[2] if len(sys.argv) > 2 else "build/bin/stend"
    folder = pathlib.Path(tempfile.mkdtemp(prefix="stend-large-"))
    try:
        start = time.monotonic()
        run_dir = make_run(folder, samples, program)
        made = time.monotonic()
        size, n, mean = iterate(run_dir)
        read = time.monotonic()
        peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"{size} samples ({size * 104 / 2**20:.0f} MB as ImuSamples, "
              f"{sum(f.stat().st_size for f in run_dir.iterdir()) / 2**20:.0f} MB on disk): run made in "
              f"{made - start:.0f} s, iterated in chunks of 65536 in {read - made:.0f} s; peak RSS {peak_mb:.0f} MB "
              f"(limit {LIMIT_MB} MB); mean a = {mean.round(4)} m/s^2")
        assert n == size and peak_mb <= LIMIT_MB
    finally:
        shutil.rmtree(folder)


if __name__ == "__main__":
    main()
