#!/usr/bin/env bash
# `stend import` of a long generic CSV log: wall time, CPU and peak RSS against the length of the
# log. Writes a 1 kHz log of SAMPLES lines (t [s], accel [m/s²], gyro [rad/s], 4–5 decimals, with
# awk), then imports it into a run folder under /usr/bin/time; prints samples, log size, wall [s],
# user + system CPU [s], peak RSS [MiB] and the run folder's size. The import streams the samples
# into the run store a chunk at a time (io::import_dataset with a RunSink), so its memory does not
# grow with the log; STEND may be any build of `stend` (e.g. an older one, for a before/after).
#
#   bench/import_bench.sh [STEND] [SAMPLES]    (defaults: build/bin/stend 10000000)
set -euo pipefail
cd "$(dirname "$0")/.."
stend=${1:-build/bin/stend}
n=${2:-10000000}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

awk -v n="$n" 'BEGIN {
  print "t,ax,ay,az,gx,gy,gz"; srand(1)
  for (i = 0; i < n; ++i)
    printf "%.6f,%.4f,%.4f,%.4f,%.5f,%.5f,%.5f\n", i / 1000, rand() * 0.02 - 0.01, rand() * 0.02 - 0.01,
           9.81 + rand() * 0.02 - 0.01, rand() * 0.002 - 0.001, rand() * 0.002 - 0.001, rand() * 0.002 - 0.001
}' >"$tmp/log.csv"
log_mb=$(du -m "$tmp/log.csv" | cut -f1)

/usr/bin/time -f "%e %U %S %M" -o "$tmp/time" \
  "$stend" import "$tmp/log.csv" -o "$tmp/run" --time t --accel ax,ay,az --gyro gx,gy,gz >/dev/null
run_mb=$(du -m "$tmp/run" | tail -1 | cut -f1)
awk -v n="$n" -v log_mb="$log_mb" -v run_mb="$run_mb" '{
  printf "%-10s %8s %8s %8s %10s %8s\n", "samples", "log_MB", "wall_s", "cpu_s", "peak_MiB", "run_MB"
  printf "%-10s %8s %8s %8.2f %10.1f %8s\n", n, log_mb, $1, $2 + $3, $4 / 1024, run_mb
}' "$tmp/time"
