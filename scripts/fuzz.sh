#!/usr/bin/env bash
# Fuzzes Stend's parsers with libFuzzer (clang; ASan + UBSan), each target for a set time, from its
# seed corpus (fuzz/corpus/<target>/) and regression set (fuzz/regressions/<target>/).
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]      (default: 60 s, every target)
# Targets are the folder names under fuzz/corpus/ (import_csv, experiment, run_h5, modbus_rtu, …).
# The build lives in build-fuzz/ (STEND_FUZZ_BUILD_DIR overrides); each target works in
# build-fuzz/fuzz-work/<target>/ (corpus/: the seeds plus what libFuzzer adds; artifacts/: crash-*,
# leak-*, timeout-*, oom-* reproducers; log). The source tree is never written unless
# STEND_FUZZ_UPDATE_CORPUS=1, which merges new coverage back into fuzz/corpus/<target>/.
# Exit status: 0 when every target ran clean, 1 when any target crashed, leaked, hung or ran out of
# memory (the reproducer's path is printed; replay it with build-fuzz/bin/fuzz_<target> FILE).
# On a machine shared with other work, STEND_FUZZ_BUDGET=cpu counts SECONDS_PER_TARGET as the
# fuzzer's own CPU time (user + system) instead of the wall clock, and STEND_FUZZ_TIMEOUT (default
# 10 s) raises the wall-clock time one input may take before it counts as a hang — run at idle
# priority (chrt --idle 0) a starved fuzzer otherwise reports false hangs.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
seconds="${1:-60}"
[ $# -gt 0 ] && shift
build="${STEND_FUZZ_BUILD_DIR:-$root/build-fuzz}"
timeout_s="${STEND_FUZZ_TIMEOUT:-10}"  # one input taking longer (wall clock) is a hang
rss_limit_mb=2048
max_len=65536     # fuzz/fuzz_support.hpp kMaxInputBytes

if [ $# -gt 0 ]; then
  targets=("$@")
else
  mapfile -t targets < <(ls "$root/fuzz/corpus")
fi
for t in "${targets[@]}"; do
  [ -d "$root/fuzz/corpus/$t" ] || { echo "fuzz.sh: no target '$t' (fuzz/corpus/ lists them)" >&2; exit 2; }
done

launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ "${launcher[@]}" \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" \
  -DSTEND_FUZZ=ON -DSTEND_WERROR=OFF -DSTEND_BUILD_TESTS=OFF -DSTEND_BUILD_BENCHMARKS=OFF >/dev/null
ninja -C "$build" "${targets[@]/#/fuzz_}"

# Runs one target into $2/log; returns libFuzzer's exit status (0: clean).
run_fuzzer() {
  local t="$1" work="$2" wall="$seconds"
  [ "${STEND_FUZZ_BUDGET:-wall}" = cpu ] && wall=$((seconds * 1000))
  ASAN_OPTIONS="${ASAN_OPTIONS:-}:detect_leaks=1" UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
    "$build/bin/fuzz_$t" -max_total_time="$wall" -timeout="$timeout_s" -rss_limit_mb="$rss_limit_mb" \
    -max_len="$max_len" -print_final_stats=1 -artifact_prefix="$work/artifacts/" "$work/corpus" \
    >"$work/log" 2>&1 &
  local pid=$! started=$SECONDS
  if [ "${STEND_FUZZ_BUDGET:-wall}" = cpu ]; then
    local tick; tick=$(getconf CLK_TCK)
    while kill -0 "$pid" 2>/dev/null; do
      local cpu; cpu=$(awk -v t="$tick" '{print int(($14 + $15) / t)}' "/proc/$pid/stat" 2>/dev/null || echo 0)
      if [ "$cpu" -ge "$seconds" ]; then
        kill -INT "$pid"
        wait "$pid"
        echo "fuzz.sh: stopped after ${cpu} s CPU, $((SECONDS - started)) s wall" >>"$work/log"
        return 0
      fi
      sleep 5
    done
  fi
  wait "$pid"
  local rc=$?
  echo "fuzz.sh: $((SECONDS - started)) s wall" >>"$work/log"
  return "$rc"
}

failed=0
summary=()
for t in "${targets[@]}"; do
  work="$build/fuzz-work/$t"
  mkdir -p "$work/corpus" "$work/artifacts"
  cp -n "$root/fuzz/corpus/$t/"* "$work/corpus/"
  [ -d "$root/fuzz/regressions/$t" ] && cp -n "$root/fuzz/regressions/$t/"* "$work/corpus/"
  echo "== $t: ${seconds} s"
  set +e
  run_fuzzer "$t" "$work"
  rc=$?
  set -e
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/log" | tail -1)
  [ -n "$execs" ] || execs=$(grep -o '^#[0-9]*' "$work/log" | tail -1 | tr -d '#')
  cov=$(grep -o 'cov: [0-9]* ft: [0-9]*' "$work/log" | tail -1)
  corpus=$(ls "$work/corpus" | wc -l)
  if [ "$rc" -eq 0 ]; then
    summary+=("$(printf '%-22s ok     %10s execs  %-22s corpus %s' "$t" "${execs:-?}" "${cov:-cov: ?}" "$corpus")")
  else
    failed=1
    artifact=$(ls -t "$work/artifacts/" 2>/dev/null | head -1)
    summary+=("$(printf '%-22s FAILED %10s execs  %-22s reproducer %s' "$t" "${execs:-?}" "${cov:-cov: ?}" \
      "${artifact:+$work/artifacts/$artifact}")")
    grep -m1 -E 'ERROR: |runtime error|SUMMARY' "$work/log" || true
    echo "   log: $work/log"
  fi
  if [ "${STEND_FUZZ_UPDATE_CORPUS:-0}" = 1 ]; then
    "$build/bin/fuzz_$t" -merge=1 -max_len="$max_len" "$root/fuzz/corpus/$t" "$work/corpus" >>"$work/log" 2>&1
  fi
done

echo
echo "fuzz.sh: ${seconds} s per target (build: $build)"
printf '%s\n' "${summary[@]}"
exit "$failed"
