#!/usr/bin/env bash
# The run store at scale: write a long 1 kHz record with `stend run`, then time the commands that
# read it back.
#
#   bench/run_store_bench.sh [BUILD] [SAMPLES] [WORK]
#       BUILD    build folder (default build)
#       SAMPLES  samples to record, e.g. 1e7 (default 1e8: 27.8 h at 1 kHz)
#       WORK     folder for the record (default a temporary folder, removed at the end)
#
# 1. writes bench/run_store_1khz.yaml (configs/long_static.yaml at 1 kHz) shortened to SAMPLES
#    samples: `stend run CONFIG -o WORK --name run -q`, timed once (wall, CPU, peak RSS), in
#    multiples of real time (recorded run time / wall time), and the run's size on disk in bytes
#    and bytes per sample (samples as `stend info` counts them);
# 2. times `stend info RUN` and `stend fit RUN --model estimators/allan/example/allan.yaml
#    --out WORK/fit.json` three times each with /usr/bin/time (medians of wall, CPU, peak RSS);
# 3. runs bench/allantools_vs_stend.sh on the same run when that script exists
#    (`BUILD=… bench/allantools_vs_stend.sh RUN`), otherwise says it is skipped;
# 4. prints the table, and the limits of fit (bench/limits_bench, LIMITS_BENCH; bench/lib.sh): one
#    memory pass over the samples, and reading the run's bytes once (the Allan peer: step 3).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
samples=$(awk -v n="${2:-1e8}" 'BEGIN { printf "%d", n }')
stend=$build/bin/stend
config=$root/bench/run_store_1khz.yaml
model=$root/estimators/allan/example/allan.yaml
peer=$root/bench/allantools_vs_stend.sh
repeats=3
[ -x "$stend" ] || { echo "missing $stend: build first (scripts/build.sh)" >&2; exit 1; }
[ "$samples" -ge 1000 ] || { echo "SAMPLES must be at least 1000 (got ${2:-})" >&2; exit 1; }

if [ -n "${3:-}" ]; then
  work=$3
  mkdir -p "$work"
  [ -z "$(find "$work" -maxdepth 1 -name 'run*')" ] || { echo "$work has a run already: choose an empty WORK folder" >&2; exit 1; }
else
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
fi
rate_hz=1000
duration_s=$(awk -v n="$samples" -v r="$rate_hz" 'BEGIN { printf "%.3f", n / r }')
sed "s/duration_s: 100000,/duration_s: $duration_s,/" "$config" >"$work/experiment.yaml"
grep -q "duration_s: $duration_s," "$work/experiment.yaml" || { echo "$config: no 'duration_s: 100000,' to replace" >&2; exit 1; }

tmp=$work
# shellcheck source=bench/lib.sh
. "$root/bench/lib.sh"
# One timed command: appends "wall cpu maxrss_kb" to FILE; its output goes to FILE.out (this
# script's own timed: lib.sh's drops the output).
timed() {
  local file=$1
  shift
  if ! /usr/bin/time -f "%e %U %S %M" -o "$work/t" "$@" >"$file.out" 2>&1; then
    cat "$file.out" >&2
    echo "failed: $*" >&2
    exit 1
  fi
  awk '{ printf "%s %.3f %s\n", $1, $2 + $3, $4 }' "$work/t" >>"$file"
}

echo "recording $samples samples ($duration_s s at $rate_hz Hz) into $work/run …"
timed "$work/write.times" "$stend" run "$work/experiment.yaml" -o "$work" --name run -q
# The run as the store names it: a folder "run" (or a file "run.<ext>").
run=$(find "$work" -maxdepth 1 -name 'run*' | head -1)
[ -n "$run" ] || { echo "stend run wrote no run into $work" >&2; exit 1; }
bytes=$(du -sb "$run" | cut -f1)

for _ in $(seq "$repeats"); do
  timed "$work/info.times" "$stend" info "$run"
  timed "$work/fit.times" "$stend" fit "$run" --model "$model" --out "$work/fit.json"
done
recorded=$(sed -n 's/^data: *\([0-9]*\) samples.*/\1/p' "$work/info.times.out")
[ -n "$recorded" ] || { echo "stend info printed no sample count:" >&2; cat "$work/info.times.out" >&2; exit 1; }

echo
echo "record: bench/run_store_1khz.yaml, $recorded samples x 6 channels at $rate_hz Hz ($(awk -v d="$duration_s" 'BEGIN { printf "%.2f", d / 3600 }') h)"
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg), $(nproc) cores; medians of $repeats for info and fit"
read -r run_wall run_cpu run_rss <"$work/write.times"
printf '%-34s %10s %10s %12s  %s\n' "command" "wall [s]" "CPU [s]" "peak RSS" "figure"
printf '%-34s %10s %10s %12s  %s\n' "stend run (write)" "$run_wall" "$run_cpu" "$(echo "$run_rss" | mib) MiB" \
  "$(awk -v d="$duration_s" -v w="$run_wall" -v c="$run_cpu" -v n="$recorded" \
    'BEGIN { printf "%.0fx real time (%.0fx per CPU s), %.0f ns/sample wall", d / w, d / c, 1e9 * w / n }')"
printf '%-34s %10s %10s %12s  %s\n' "run folder" "" "" "" \
  "$(awk -v b="$bytes" -v n="$recorded" 'BEGIN { printf "%.3f GB, %.1f bytes/sample", b / 1e9, b / n }')"
for what in info fit; do
  label="stend $what"
  [ "$what" = fit ] && label="stend fit (allan.yaml, 6 channels)"
  printf '%-34s %10s %10s %12s\n' "$label" "$(column_median "$work/$what.times" 1)" \
    "$(column_median "$work/$what.times" 2)" "$(column_median "$work/$what.times" 3 | mib) MiB"
done

fit_wall=$(column_median "$work/fit.times" 1)
files=()
while IFS= read -r f; do files+=(--read "$f"); done < <(find "$run" -type f)
if limits --memory "${files[@]}" --passes 5; then
  memory_limit_line "$recorded" "$fit_wall" "stend fit"
  read_limit_line "$fit_wall" "stend fit"
fi

echo
if [ -x "$peer" ] || [ -f "$peer" ]; then
  echo "allantools on the same run ($peer):"
  BUILD=$build bash "$peer" "$run"
else
  echo "allantools peer skipped: $peer does not exist yet"
fi
