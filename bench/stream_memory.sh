#!/usr/bin/env bash
# Peak memory of the analyses against the length of the record: the six-position experiment
# (configs/six_position.yaml, 200 Hz) with each position recorded SHORT_S and LONG_S seconds, then
# `stend info` (loading only), `stend fit` (batch_lsq, bias and scale) and `stend gap` on each run,
# under /usr/bin/time -v. Prints one line per command and length: samples, wall time [s], peak RSS
# [MiB]; then the limit (bench/limits_bench, LIMITS_BENCH; bench/lib.sh): one memory pass over the
# long record's samples, beside fit and gap. The analyses read the samples through the run store's
# SampleSource, so their own memory does not grow with the record; what grows is the store's (a CSV
# run folder is read whole).
#
#   bench/stream_memory.sh [STEND] [SHORT_S] [LONG_S]    (defaults: build/bin/stend 20 2000)
set -euo pipefail
cd "$(dirname "$0")/.."
stend=${1:-build/bin/stend}
short_s=${2:-20}
long_s=${3:-2000}
model=diagnosis/examples/bias_scale.yaml
root=$PWD
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
. bench/lib.sh

peak() {  # command… → "wall_s peak_MiB"
  /usr/bin/time -v "$@" >"$tmp/out" 2>"$tmp/time" || { cat "$tmp/out" "$tmp/time" >&2; exit 1; }
  awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, t, ":"); w = 0; for (i = 1; i <= n; ++i) w = w * 60 + t[i]}
              /Maximum resident set size/ {r = $2 / 1024} END {printf "%.2f %.1f\n", w, r}' "$tmp/time"
}

printf '%-6s %10s %8s %10s %10s\n' command samples record_s wall_s peak_MiB
for record_s in "$short_s" "$long_s"; do
  sed "s/record_s: 20/record_s: $record_s/" configs/six_position.yaml >"$tmp/six_$record_s.yaml"
  "$stend" run "$tmp/six_$record_s.yaml" --quiet --output "$tmp" --name "six_$record_s" >/dev/null
  run=$tmp/six_$record_s
  samples=$("$stend" info "$run" | sed -n 's/^data: *\([0-9]*\) samples.*/\1/p' | head -1)
  for cmd in info fit gap; do
    case $cmd in
      info) args=(info "$run") ;;
      fit) args=(fit "$run" --model "$model" --out "$tmp/fit.json") ;;
      gap) args=(gap "$run" --model "$model" --out "$tmp/gap.json") ;;
    esac
    read -r wall rss < <(peak "$stend" "${args[@]}")
    printf '%-6s %10d %8s %10s %10s\n' "$cmd" "$samples" "$record_s" "$wall" "$rss"
    echo "$wall" >"$tmp/$cmd.wall"  # the long record's, kept for the limit
  done
done
no_peer "fit and gap"
if limits --memory; then
  for cmd in fit gap; do memory_limit_line "$samples" "$(cat "$tmp/$cmd.wall")" "stend $cmd"; done
fi
