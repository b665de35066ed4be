# shellcheck shell=bash disable=SC2154  # tmp, root and build: set by the sourcing script
# Sourced by the bench scripts: timing, medians, and the closing lines that hold Stend against its
# peer (same run) and against the machine's physical limit (bench/limits_bench.cpp). The script
# sets tmp (its scratch folder) and root, and build where it has one, before sourcing this.
#
#   LIMITS_BENCH=path/to/limits_bench   (default BUILD/bin/limits_bench: build/bin/limits_bench)
limits_bench=${LIMITS_BENCH:-${build:-$root/build}/bin/limits_bench}

# timed FILE COMMAND…: runs COMMAND, appends "wall cpu maxrss_kb" to FILE (seconds to the
# microsecond, bench/rusage.py: wait4's user + system time); on failure prints COMMAND's errors
# and exits.
timed() {
  local file=$1
  shift
  python3 "$root/bench/rusage.py" "$file" "$tmp/err" "$@" || { cat "$tmp/err" >&2; exit 1; }
}
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
column_median() { awk -v c="$2" '{ print $c }' "$1" | median; }  # FILE COLUMN (1 wall, 2 CPU, 3 RSS)
mib() { awk '{ printf "%.1f", $1 / 1024 }'; }

# peer_line PEER PEER_TIMES STEND_TIMES: the peer's median wall and CPU time over Stend's (timed's
# files, filled in the same run, alternating).
peer_line() {
  awk -v who="$1" -v pw="$(column_median "$2" 1)" -v pc="$(column_median "$2" 2)" -v sw="$(column_median "$3" 1)" \
    -v sc="$(column_median "$3" 2)" -v n="$(wc -l <"$3")" 'BEGIN {
      printf "peer:  %s / Stend, same run (medians of %d): wall %.3g s / %.3g s = %.2fx, CPU %.3g s / %.3g s = %.2fx\n",
             who, n, pw, sw, pw / sw, pc, sc, pc / sc }'
}
no_peer() { echo "peer:  none in ../shared/peers for $1"; }

# limits ARGS…: runs limits_bench ARGS (its `key value` lines into $tmp/limits); false, saying so,
# when the program is absent. limit KEY: a value it printed.
limits() {
  if [ ! -x "$limits_bench" ]; then
    echo "limit: skipped: $limits_bench is absent (build the target limits_bench, or set LIMITS_BENCH)"
    return 1
  fi
  "$limits_bench" "$@" >"$tmp/limits"
}
limit() { awk -v k="$1" '$1 == k { print $2 }' "$tmp/limits"; }

# limit_line WHAT LIMIT_S STEND_S [WHO]: the limit's time, and Stend's speed (median wall) as a
# percentage of the limit's (LIMIT_S / STEND_S); WHO names the command (default Stend).
limit_line() {
  awk -v what="$1" -v l="$2" -v s="$3" -v who="${4:-Stend}" 'BEGIN {
    printf "limit: %s takes %.3g s: %s (%.3g s wall) runs at %.2g %% of that speed\n", what, l, who, s, 100 * l / s }'
}
# memory_limit_line SAMPLES STEND_S [WHO]: one read pass over SAMPLES × 6 channels of doubles at the
# bandwidth measured by `limits --memory`.
memory_limit_line() {
  local gbps bytes
  gbps=$(limit memory_read_GBps)
  bytes=$(awk -v n="$1" 'BEGIN { printf "%.0f", n * 6 * 8 }')
  limit_line "one memory pass over the samples ($1 x 6 doubles, $(awk -v b="$bytes" 'BEGIN { printf "%.1f", b / 1e6 }') MB at $gbps GB/s)" \
    "$(awk -v b="$bytes" -v g="$gbps" 'BEGIN { print b / (g * 1e9) }')" "$2" "${3:-}"
}
# read_limit_line STEND_S [WHO]: reading the files given to `limits --read` once, page cache warm,
# and again from the device past the page cache (O_DIRECT: a file not read lately), where the
# file system allows that.
read_limit_line() {
  local files="the file's" mb
  [ "$(limit read_files)" = 1 ] || files="the $(limit read_files) files'"
  mb=$(awk -v b="$(limit read_bytes)" 'BEGIN { printf "%.1f", b / 1e6 }')
  limit_line "reading $files bytes once ($mb MB at $(limit read_MBps) MB/s)" "$(limit read_s)" "$1" "${2:-}"
  [ -z "$(limit read_direct_s)" ] ||
    limit_line "reading $files bytes once from the device, uncached ($mb MB at $(limit read_direct_MBps) MB/s, O_DIRECT)" \
      "$(limit read_direct_s)" "$1" "${2:-}"
}
# parse_limit_line BYTES STEND_S: parsing BYTES of text at the from_chars speed measured by `limits
# --parse-file`.
parse_limit_line() {
  limit_line "parsing the text at from_chars speed ($(awk -v b="$1" 'BEGIN { printf "%.1f", b / 1e6 }') MB at $(limit parse_MBps) MB/s)" \
    "$(awk -v b="$1" -v r="$(limit parse_MBps)" 'BEGIN { print b / (r * 1e6) }')" "$2"
}
