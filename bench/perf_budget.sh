#!/usr/bin/env bash
# The instruction budgets of Stend's key paths: each path runs once under callgrind (valgrind's
# instruction count: deterministic, unlike a time) on a fixed small input, and its count is held
# against the budget in bench/perf_budgets.txt (about 20 % above the count measured when the budget
# was set). A path over its budget fails, saying by how much; timings stay in the benchmarks.
#
#   bench/perf_budget.sh [BUILD_DIR] [SHARED_DATA_DIR]     (defaults: build, ../shared/data)
#   STEND=path/to/stend   times another build of the program (e.g. an older one) against the budgets
#   PERF_BUDGET_MEASURE=1 prints each path's count and the budget it would set, and passes
#
# The paths: calibration (the 38-pose run, Ceres unknown orientations), Allan (720 000 samples × 6,
# the long static run), import of 100 000 CSV rows into run.h5, import of a ULog (skipped without
# ../shared/data), and the run report of the 38-pose run. Exit 77 without valgrind.
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
data=${2:-$root/../shared/data}
stend=${STEND:-$build/bin/stend}
maker=$build/bin/stend  # makes the inputs
budgets=$root/bench/perf_budgets.txt
command -v valgrind >/dev/null || { echo "SKIP: valgrind is not installed (scripts/install-deps.sh installs it)"; exit 77; }
for b in "$stend" "$build/bin/stend"; do [ -x "$b" ] || { echo "missing $b: build first"; exit 1; }; done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# The inputs, made natively by this build (not measured).
"$maker" run "$root/configs/multi_position_38.yaml" -o "$tmp" --name mp38 -q >/dev/null || exit 1
"$maker" run "$root/configs/long_static.yaml" -o "$tmp" --name static -q >/dev/null || exit 1
grep -vE '^ *(deviations|tau):' "$root/estimators/allan/example/allan.yaml" >"$tmp/allan.yaml"
awk 'BEGIN {  # the log of bench/import_bench.sh, 100 000 rows at 1 kHz
  print "t,ax,ay,az,gx,gy,gz"; srand(1)
  for (i = 0; i < 100000; ++i)
    printf "%.6f,%.4f,%.4f,%.4f,%.5f,%.5f,%.5f\n", i / 1000, rand() * 0.02 - 0.01, rand() * 0.02 - 0.01,
           9.81 + rand() * 0.02 - 0.01, rand() * 0.002 - 0.001, rand() * 0.002 - 0.001, rand() * 0.002 - 0.001
}' >"$tmp/log.csv"

# Instructions executed by one command (callgrind's "Collected"), all threads together.
instructions() {
  valgrind --tool=callgrind --callgrind-out-file=/dev/null "$@" 2>"$tmp/cg.log" >/dev/null ||
    { echo "command failed: $*" >&2; tail -5 "$tmp/cg.log" >&2; return 1; }
  sed -n 's/^==[0-9]*== Collected : \([0-9]*\)$/\1/p' "$tmp/cg.log"
}

failed=0
check() {
  local name=$1
  shift
  local count budget
  count=$(instructions "$@") || { failed=1; return; }
  if [ "${PERF_BUDGET_MEASURE:-0}" = 1 ]; then
    printf '%-14s %14s instructions; budget at +20%%: %s\n' "$name" "$count" $((count * 12 / 10))
    return
  fi
  budget=$(awk -v n="$name" '$1 == n { print $2 }' "$budgets")
  if [ -z "$budget" ]; then
    echo "FAIL $name: no budget in $budgets"
    failed=1
    return
  fi
  local pct=$((100 * count / budget))
  if [ "$count" -gt "$budget" ]; then
    echo "FAIL $name: $count instructions, $((pct - 100)) % over its budget of $budget"
    failed=1
  else
    echo "ok   $name: $count instructions, $pct % of its budget of $budget"
  fi
}

check calibration "$stend" fit "$tmp/mp38" --model "$root/estimators/ceres_nonlinear/examples/unknown_orientations.yaml" --out "$tmp/ceres.json"
check allan "$stend" fit "$tmp/static" --model "$tmp/allan.yaml" --out "$tmp/allan.json"
check import_csv "$stend" import "$tmp/log.csv" -o "$tmp/imported" --time t --accel ax,ay,az --gyro gx,gy,gz
if [ -f "$data/logs/ulog/sample_log_small.ulg" ]; then
  check import_ulog "$stend" import "$data/logs/ulog/sample_log_small.ulg" -o "$tmp/ulog"
else
  echo "skip import_ulog: $data/logs/ulog/sample_log_small.ulg is absent"
fi
"$maker" fit "$tmp/mp38" --model "$root/estimators/ceres_nonlinear/examples/unknown_orientations.yaml" >/dev/null || exit 1
check report "$stend" report "$tmp/mp38"
exit $failed
