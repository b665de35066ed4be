"""A run larger than the memory its iteration may take, read from Python a chunk at a time: the
process's peak resident memory stays far below the run's samples in memory (issue 39: a 10^8-sample
run within 256 MB; here 3·10^6 samples, 298 MB as ImuSamples, within 160 MB — the figure for 10^8
is in docs/python.md)."""
import subprocess
import sys
import textwrap

from conftest import PROGRAM

SAMPLES = 3_000_000
RATE_HZ = 1000  # [Hz]

EXPERIMENT = f"""
experiment: {{name: long_record, seed: 7}}
bench:
  sensor: {{plugin: sim_imu, config: {{output_rate_hz: {RATE_HZ}, lowpass_hz: 200}}}}
  fixtures: [{{id: table, plugin: sim_one_axis_table}}]
  mounting: {{on: table}}
procedure:
  - record: {{duration_s: {SAMPLES // RATE_HZ}, label: static}}
"""

ITERATE = textwrap.dedent("""
    import resource, sys
    import numpy as np
    import stend
    rec = stend.open(sys.argv[1])
    n, total = 0, np.zeros(3)
    for chunk in rec.chunks(65536):
        n += len(chunk)
        total += chunk["accel_mps2"].sum(axis=0)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # [MB]
    print(n, len(rec), peak_mb, total[2] / n)
""")


def test_chunks_of_a_long_run_in_bounded_memory(cli, scratch):
    config = scratch / "long_record.yaml"
    config.write_text(EXPERIMENT)
    code, doc, _ = cli.json("run", config, "--quiet", "--output", scratch / "runs", "--name", "long")
    assert code == 0 and doc["samples"] >= SAMPLES
    p = subprocess.run([sys.executable, "-c", ITERATE, doc["run_dir"]], capture_output=True, text=True, check=True)
    n, size, peak_mb, mean_az = p.stdout.split()
    assert int(n) == int(size) == doc["samples"]
    in_memory_mb = int(size) * 104 / 2**20  # sizeof(ImuSample) [B]
    print(f"{size} samples ({in_memory_mb:.0f} MB in memory) iterated in chunks: peak RSS {float(peak_mb):.0f} MB")
    assert float(peak_mb) < 160 < in_memory_mb
    assert 9.7 < float(mean_az) < 9.9  # [m/s^2] Z up
