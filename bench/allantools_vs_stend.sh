#!/usr/bin/env bash
# Octave overlapping Allan deviation with intervals, six channels: Stend beside allantools on the
# same recording.
#
#   bench/allantools_vs_stend.sh [RUN] [RUNS]   (RUN: a run folder; default: a fresh
#                                               `stend run configs/long_static.yaml`; RUNS: 3)
#   BUILD=build dir, ALLANTOOLS=allantools source dir (default ../shared/peers/allantools),
#   LIMITS_BENCH=limits program (default BUILD/bin/limits_bench)
#
# 1. Stend: `stend fit RUN --model estimators/allan/example/allan.yaml --out F` without the
#    example's further deviations (read the run, octave OADEV of all six channels, EDF and
#    intervals, noise model, write the results: what allantools computes);
# 2. allantools: bench/allantools_octave.py RUN/run.h5 (h5py; RUN/imu.csv with pandas for a CSV run),
#    allantools.oadev at the same octave τ, Greenhall EDF and chi-squared intervals), run with
#    Debian's python3 (numpy, pandas, scipy: scripts/install-deps.sh);
# 3. each is timed RUNS times, alternating, with /usr/bin/time; prints medians of wall and CPU
#    time and peak RSS, and the largest relative ADEV difference over all channels and τ;
# 4. closes with the same-run ratio to allantools and the limit: one memory pass over the samples
#    (6 channels of doubles) at the bandwidth bench/limits_bench measures (bench/lib.sh).
# Skips allantools with a message when ../shared/peers is absent (Stend is then timed alone).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD:-$root/build}
run=${1:-}
runs=${2:-3}
peer_src=${ALLANTOOLS:-$root/../shared/peers/allantools}
stend=$build/bin/stend
python=/usr/bin/python3
[ -x "$stend" ] || { echo "missing $stend: build first (scripts/build.sh)" >&2; exit 1; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=bench/lib.sh
. "$root/bench/lib.sh"
model=$tmp/allan.yaml
grep -vE '^ *(deviations|tau):' "$root/estimators/allan/example/allan.yaml" >"$model"
if [ -z "$run" ]; then
  "$stend" run "$root/configs/long_static.yaml" -o "$tmp" --name static -q >/dev/null
  run=$tmp/static
fi
data=$run/run.h5
[ -f "$data" ] || data=$run/imu.csv
samples=$("$stend" info "$run" | sed -n 's/^data: *\([0-9]*\) samples.*/\1/p' | head -1)
rate=$(sed -n 's/.*"output_rate_hz": *\([0-9.eE+-]*\).*/\1/p' "$run/run.json" | head -1)

peer=""
if [ -d "$peer_src/allantools" ] && "$python" -c 'import numpy, pandas, scipy' 2>/dev/null; then
  peer=yes
else
  echo "allantools (../shared/peers/allantools) or Debian's python3-numpy/pandas/scipy absent: timing Stend alone"
fi

for _ in $(seq "$runs"); do
  timed "$tmp/stend.times" "$stend" fit "$run" --model "$model" --out "$tmp/stend.json"
  [ -z "$peer" ] || timed "$tmp/allantools.times" "$python" "$root/bench/allantools_octave.py" \
    "$data" --rate "$rate" --allantools "$peer_src" --out "$tmp/allantools.json"
done

echo "record: $data, ${samples:-?} samples at $rate Hz × 6 channels; $runs runs each, alternating"
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg), $(nproc) cores"
printf '%-11s %12s %12s %14s\n' "" "wall med [s]" "CPU med [s]" "peak RSS [MiB]"
for who in stend allantools; do
  [ -f "$tmp/$who.times" ] || continue
  printf '%-11s %12s %12s %14s\n' "$who" "$(column_median "$tmp/$who.times" 1)" \
    "$(column_median "$tmp/$who.times" 2)" "$(column_median "$tmp/$who.times" 3 | awk '{ printf "%.1f", $1 / 1024 }')"
done
if [ -n "$peer" ]; then
  "$python" - "$tmp/stend.json" "$tmp/allantools.json" <<'PY'
import json, sys
stend = json.load(open(sys.argv[1]))
peer = json.load(open(sys.argv[2]))
channels = stend["allan"]["channels"] if "allan" in stend else stend["channels"]
worst, compared = 0.0, 0
for ch in channels:
    ours = {p["m"]: p["adev"] for p in ch["points"]}
    theirs = dict(zip(peer[ch["channel"]]["m"], peer[ch["channel"]]["adev"]))
    for m, v in theirs.items():
        if m in ours:
            worst = max(worst, abs(ours[m] / v - 1.0))
            compared += 1
print(f"ADEV compared at {compared} (channel, tau) points: largest relative difference {worst:.2e}")
PY
fi
[ -z "$peer" ] || peer_line allantools "$tmp/allantools.times" "$tmp/stend.times"
if limits --memory; then memory_limit_line "$samples" "$(column_median "$tmp/stend.times" 1)"; fi
