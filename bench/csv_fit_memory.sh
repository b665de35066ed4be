#!/usr/bin/env bash
# Peak memory and time of `stend fit` run directly on a CSV file (no `stend import` first): a 1 kHz
# log of ROWS rows (t, accelerometer, gyroscope, temperature; mawk's rand with a fixed seed) fitted
# with the Allan example model under /usr/bin/time -v. Files above 32 MB go through a scratch run
# store in $TMPDIR (app/fit.cpp), so the peak does not grow with the file; 10⁷ rows is ~660 MB.
# Then the limit (bench/limits_bench, LIMITS_BENCH; bench/lib.sh): parsing the file at
# std::from_chars speed.
#
#   bench/csv_fit_memory.sh [STEND] [ROWS]    (defaults: build/bin/stend 10000000)
set -euo pipefail
cd "$(dirname "$0")/.."
stend=${1:-build/bin/stend}
rows=${2:-10000000}
root=$PWD
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
. bench/lib.sh
awk -v n="$rows" 'BEGIN { srand(1); print "t,ax,ay,az,gx,gy,gz,temp"
  for (i = 0; i < n; ++i)
    printf "%.4f,%.5f,%.5f,%.5f,%.6f,%.6f,%.6f,25.0\n", i / 1000, 0.01 * rand(), 0.01 * rand(), 9.81 + 0.01 * rand(),
           0.001 * rand(), 0.001 * rand(), 0.001 * rand() }' >"$tmp/log.csv"
/usr/bin/time -v "$stend" fit "$tmp/log.csv" --time t --accel ax,ay,az --gyro gx,gy,gz --temperature temp \
  --model estimators/allan/example/allan.yaml --out "$tmp/fit.json" >"$tmp/out" 2>"$tmp/time" ||
  { cat "$tmp/out" "$tmp/time" >&2; exit 1; }
awk -v rows="$rows" -v bytes="$(stat -c %s "$tmp/log.csv")" -F': ' '
  /User time/ {u = $2} /System time/ {s = $2}
  /Elapsed \(wall clock\)/ {n = split($2, t, ":"); w = 0; for (i = 1; i <= n; ++i) w = w * 60 + t[i]}
  /Maximum resident set size/ {r = $2 / 1024}
  END {printf "rows %d  file %.0f MB  cpu %.1f s  wall %.1f s  peak RSS %.1f MiB\n", rows, bytes / 1e6, u + s, w, r
       print w >"'"$tmp/wall"'"}' "$tmp/time"
no_peer "fit on a CSV file"
if limits --parse-file "$tmp/log.csv" --passes 5; then parse_limit_line "$(limit parse_file_bytes)" "$(cat "$tmp/wall")"; fi
