#!/usr/bin/env bash
# Issue 40's 100-seed figures: the false discovery rule over the candidate family (Benjamini–
# Yekutieli) on the twin — with no unmodelled effect, the share of 100 null runs that name any term
# (target <= 5 %); with one planted term at 5x the floor, the share named first (target >= 90 %,
# aliases counted as declared) — and 100 runs of every design case (folds, aliases, placement).
# Writes OUT/error_rate.txt and .json; the figures go into docs/gap-diagnosis.md ("Error rate").
#   diagnosis/bench/validate_error_rate.sh [OUT_DIR]
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
out="${1:-$root/runs/gap-error-rate}"
stend="${STEND_BIN:-$root/${STEND_BUILD_DIR:-build}/bin/stend}"
[[ -x "$stend" ]] || { echo "validate_error_rate.sh: $stend not built (scripts/build.sh)" >&2; exit 2; }
mkdir -p "$out"
args=(gap validate --seeds 100 --sizes 5 --null 100 --oov 10 --design-runs 100 --noise-seeds 0 --noise-null 0)
{
  echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(uname -sr)"
  echo "command: $stend ${args[*]}"
  echo "date:    $(date -u +%Y-%m-%dT%H:%M:%SZ)"
} | tee "$out/error_rate.txt"
"$stend" "${args[@]}" --out "$out/error_rate.json" | tee -a "$out/error_rate.txt"
