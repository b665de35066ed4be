#!/usr/bin/env bash
# Every shipped procedure on the twin: build/bin/procedure_coverage plays each procedure of
# configs/procedures/ on SEEDS simulated sensors with planted errors, writes each as a log with its
# quirks, imports, aligns and fits it with the shipped model, and prints the Markdown table of
# docs/real-data.md ("Shipped procedures on the twin: interval coverage"): per procedure the share of
# seeds whose 95 % interval holds the planted value, minimum and median over the parameters it
# identifies, and the parameters below 90 %. Prints the machine and the command first. Extra
# arguments go to the program (--procedure NAME, --quirks LIST, --detail, --bias-instability,
# --first SEED).
#
#   bench/procedure_coverage.sh [SEEDS] [ARGS...]    (default: 100 seeds)
set -euo pipefail
cd "$(dirname "$0")/.."
seeds=${1:-100}
shift || true
program=build/bin/procedure_coverage
[ -x "$program" ] || { echo "build it first: cmake --build build --target procedure_coverage" >&2; exit 2; }
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "commit:  $(git rev-parse --short HEAD 2>/dev/null || echo '?')"
echo "command: nice $program --seeds $seeds $*"
echo
nice "$program" --seeds "$seeds" "$@"
