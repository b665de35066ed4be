#!/usr/bin/env bash
# Multi-position calibration, whole process, Stend beside IMU-TK on the same record.
#
#   bench/imutk_vs_stend.sh [RUNS]        (default 9; BUILD=build dir, IMUTK=imu_tk source dir)
#
# 1. makes the record: `stend run configs/multi_position_38.yaml` (52,822 samples at 100 Hz, 38
#    poses and rate steps; planted accelerometer and gyro errors) into a temporary folder;
# 2. exports it as IMU-TK text files (`t x y z`, m/s² and rad/s) with stend_imutk_peer. IMU-TK takes
#    its detection threshold from the first INIT seconds, which must be still: its files start at
#    the first pose (the table's first 2.6 s of motion, 260 samples, left out; Stend reads them all);
# 3. builds IMU-TK from ../shared/peers/imu_tk with its own build.sh (-O3) into the temporary folder
#    (skipped with a message when the peer is absent: Stend is then timed alone);
# 4. times each whole process RUNS times, alternating, with /usr/bin/time: Stend
#    `stend fit RUN --model estimators/ceres_nonlinear/examples/unknown_orientations.yaml --out F`
#    (read the run, detect, accelerometer + gyro fits, covariances, write the results), IMU-TK
#    `imutk_calib ACC GYRO g 2 0 1 PREFIX` (read both files, detect, accelerometer + gyro fits,
#    write the results);
# 5. prints medians of wall and CPU (user + system) time, peak RSS, the ratios, and one residual for
#    both: RMS of |calibrated interval mean| − g over the static intervals Stend's fit used (the same
#    intervals for both; stend_imutk_peer residual), then the same-run ratio and the limit: one
#    memory pass over the samples (6 channels of doubles) at the bandwidth bench/limits_bench
#    measures (LIMITS_BENCH, default BUILD/bin/limits_bench; bench/lib.sh).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD:-$root/build}
runs=${1:-9}
imutk_src=${IMUTK:-$root/../shared/peers/imu_tk}
stend=$build/bin/stend
peer=$build/bin/stend_imutk_peer
model=$root/estimators/ceres_nonlinear/examples/unknown_orientations.yaml
for b in "$stend" "$peer"; do
  [ -x "$b" ] || { echo "missing $b: build first (scripts/build.sh)" >&2; exit 1; }
done

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=bench/lib.sh
. "$root/bench/lib.sh"
"$stend" run "$root/configs/multi_position_38.yaml" -o "$tmp" --name mp38 -q >/dev/null
run=$tmp/mp38
csv=$tmp/mp38_csv  # the same run in the CSV layout, for awk
"$stend" export "$run" --to csv -o "$csv" >/dev/null
"$peer" export "$run" "$tmp/acc_all.txt" "$tmp/gyro_all.txt"
first_pose_s=$(awk -F, 'NR == 2 { print $8 }' "$csv/segments.csv")
awk -v t0="$first_pose_s" '$1 >= t0' "$tmp/acc_all.txt" >"$tmp/acc.txt"
awk -v t0="$first_pose_s" '$1 >= t0' "$tmp/gyro_all.txt" >"$tmp/gyro.txt"
gravity=$(sed -n 's/.*"gravity_mps2": *\([0-9.eE+-]*\).*/\1/p' "$run/run.json" | head -1)

imutk=""
if [ -x "$imutk_src/build.sh" ]; then
  if "$imutk_src/build.sh" "$tmp/imutk" >"$tmp/imutk_build.log" 2>&1; then
    imutk=$tmp/imutk/imutk_calib
  else
    tail -5 "$tmp/imutk_build.log"
    echo "IMU-TK did not build (it needs libceres-dev, libgoogle-glog-dev, libgflags-dev, libboost-dev): timing Stend alone"
  fi
else
  echo "IMU-TK not found at $imutk_src (../shared/peers/imu_tk): timing Stend alone"
fi

for _ in $(seq "$runs"); do
  timed "$tmp/stend.times" "$stend" fit "$run" --model "$model" --out "$tmp/stend.json"
  [ -z "$imutk" ] || timed "$tmp/imutk.times" "$imutk" "$tmp/acc.txt" "$tmp/gyro.txt" "$gravity" 2 0 1 "$tmp/imutk_out"
done

samples=$(($(wc -l <"$csv/imu.csv") - 1))
echo "record: configs/multi_position_38.yaml, $samples samples; $runs runs each, alternating"
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg), $(nproc) cores"
printf '%-8s %12s %12s %14s\n' "" "wall med [s]" "CPU med [s]" "peak RSS [MiB]"
for who in stend imutk; do
  [ -f "$tmp/$who.times" ] || continue
  printf '%-8s %12s %12s %14s\n' "$who" "$(column_median "$tmp/$who.times" 1)" \
    "$(column_median "$tmp/$who.times" 2)" "$(column_median "$tmp/$who.times" 3 | awk '{ printf "%.1f", $1 / 1024 }')"
done
if [ -n "$imutk" ]; then
  "$peer" residual "$run" "$tmp/stend.json" "$tmp/imutk_out"
  peer_line IMU-TK "$tmp/imutk.times" "$tmp/stend.times"
fi
if limits --memory; then memory_limit_line "$samples" "$(column_median "$tmp/stend.times" 1)"; fi
