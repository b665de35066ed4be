#!/usr/bin/env bash
# The full `stend gap validate` as a benchmark (CI runs a reduced seed count in gap_validate_test):
# 20 seeds per candidate and size, 200 null runs, every design. Writes OUT/validate.txt and
# OUT/validate.json and prints the machine it ran on; the figures go into docs/gap-diagnosis.md.
#   diagnosis/bench/validate_full.sh [OUT_DIR] [extra `stend gap validate` options]
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
out="${1:-$root/runs/gap-validate}"
shift || true
stend="${STEND_BIN:-$root/${STEND_BUILD_DIR:-build}/bin/stend}"
[[ -x "$stend" ]] || { echo "validate_full.sh: $stend not built (scripts/build.sh)" >&2; exit 2; }
mkdir -p "$out"
{
  echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(uname -sr)"
  echo "command: $stend gap validate --seeds 20 --null 200 $*"
  echo "date:    $(date -u +%Y-%m-%dT%H:%M:%SZ)"
} | tee "$out/validate.txt"
"$stend" gap validate --seeds 20 --null 200 --out "$out/validate.json" "$@" | tee -a "$out/validate.txt"
