#!/usr/bin/env bash
# `stend import` of a long generic CSV log: wall time, CPU and peak RSS against the length of the
# log, beside its peer and its limit. Writes a 1 kHz log of SAMPLES lines (t [s], accel [m/s²], gyro
# [rad/s], 4–5 decimals, with awk), then imports it into a run folder under /usr/bin/time; prints
# samples, log size, wall [s], user + system CPU [s], peak RSS [MiB] and the run folder's size
# (medians of RUNS). The import streams the samples into the run store a chunk at a time
# (io::import_dataset with a RunSink), so its memory does not grow with the log; STEND may be any
# build of `stend` (e.g. an older one, for a before/after).
# The peer, timed alternately with Stend: bench/pandas_import.py (pandas read_csv, then an h5py
# gzip write as the run store's), with Debian's python3-pandas and python3-h5py; the limits
# (bench/limits_bench, LIMITS_BENCH): parsing the log at std::from_chars speed, reading its bytes.
#
#   bench/import_bench.sh [STEND] [SAMPLES] [RUNS]    (defaults: build/bin/stend 10000000 1)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
stend=${1:-build/bin/stend}
n=${2:-10000000}
runs=${3:-1}
python=/usr/bin/python3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
. bench/lib.sh

awk -v n="$n" 'BEGIN {
  print "t,ax,ay,az,gx,gy,gz"; srand(1)
  for (i = 0; i < n; ++i)
    printf "%.6f,%.4f,%.4f,%.4f,%.5f,%.5f,%.5f\n", i / 1000, rand() * 0.02 - 0.01, rand() * 0.02 - 0.01,
           9.81 + rand() * 0.02 - 0.01, rand() * 0.002 - 0.001, rand() * 0.002 - 0.001, rand() * 0.002 - 0.001
}' >"$tmp/log.csv"
log_mb=$(du -m "$tmp/log.csv" | cut -f1)
peer=yes
"$python" -c 'import pandas, h5py' 2>/dev/null || { peer=""; echo "peer: skipped: Debian's python3-pandas or python3-h5py is absent"; }

for _ in $(seq "$runs"); do
  rm -rf "$tmp/run"
  timed "$tmp/stend.times" "$stend" import "$tmp/log.csv" -o "$tmp/run" --time t --accel ax,ay,az --gyro gx,gy,gz
  [ -z "$peer" ] || timed "$tmp/pandas.times" "$python" bench/pandas_import.py "$tmp/log.csv" "$tmp/pandas.h5"
done
run_mb=$(du -m "$tmp/run" | tail -1 | cut -f1)
printf "%-10s %8s %8s %8s %10s %8s\n" samples log_MB wall_s cpu_s peak_MiB run_MB
printf "%-10s %8s %8s %8s %10s %8s\n" "$n" "$log_mb" "$(column_median "$tmp/stend.times" 1)" \
  "$(column_median "$tmp/stend.times" 2)" "$(column_median "$tmp/stend.times" 3 | mib)" "$run_mb"
if [ -n "$peer" ]; then
  echo "pandas: peak $(column_median "$tmp/pandas.times" 3 | mib) MiB, its HDF5 $(du -m "$tmp/pandas.h5" | cut -f1) MB"
  peer_line "pandas read_csv + h5py gzip write" "$tmp/pandas.times" "$tmp/stend.times"
fi
if limits --parse-file "$tmp/log.csv" --read "$tmp/log.csv" --passes 5; then
  parse_limit_line "$(stat -c %s "$tmp/log.csv")" "$(column_median "$tmp/stend.times" 1)"
  read_limit_line "$(column_median "$tmp/stend.times" 1)"
fi
