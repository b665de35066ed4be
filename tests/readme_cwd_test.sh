#!/usr/bin/env bash
# The README's first commands ("Using it") and its `stend compare` line, run as written from an
# empty current directory (the program, configs/ and estimators/ reached by absolute paths, the
# run folder's placeholder replaced by the folder the run made): every command must succeed and
# the directory must then hold nothing but what the run names — runs/ with the run folder and the
# results database beside it. Results of a dataset file go nowhere without --out; compare writes
# its HTML report only with -o.
# Usage: readme_cwd_test.sh SOURCE_DIR BUILD_DIR SHARED_DATA_DIR
set -uo pipefail
src=$(cd "$1" && pwd) build=$(cd "$2" && pwd) data=$3
cwd=$(mktemp -d)
trap 'rm -rf "$cwd"' EXIT
commands=$(awk '/^## Using it/ {on = 1; next} on && /^$/ && seen {exit}
                on && /^    build\/bin\/stend / {seen = 1; sub(/^    /, ""); sub(/ *#.*$/, ""); print}' "$src/README.md")
commands+=$'\n'$(grep -E '^    build/bin/stend compare ' "$src/README.md" | sed 's/^    //; s/ *#.*$//')
count=$(printf '%s\n' "$commands" | grep -c .)
if [ "$count" -lt 6 ]; then
  echo "FAIL: found only $count commands in the README's \"Using it\" block"
  exit 1
fi
failed=0
cd "$cwd"
while IFS= read -r cmd; do
  if [[ "$cmd" == *../shared/data/* ]] && [ ! -d "$data" ]; then
    echo "skip  $cmd ($data is absent)"
    continue
  fi
  run=$(find runs -mindepth 1 -maxdepth 1 -type d 2>/dev/null | head -1)
  line=${cmd//build\/bin\/stend/$build/bin/stend}
  line=${line//configs\//$src/configs/}
  line=${line//estimators\//$src/estimators/}
  line=${line//..\/shared\/data\//$data/}
  line=${line//runs\/<run folder>/$run}
  if out=$(bash -c "$line" 2>&1 </dev/null); then
    echo "ok    $cmd"
  else
    echo "FAIL  $cmd (exit $?)"
    printf '%s\n' "$out" | tail -15 | sed 's/^/      /'
    failed=$((failed + 1))
  fi
done <<< "$commands"
extra=$(find . -mindepth 1 -maxdepth 1 ! -name runs; find runs -mindepth 1 -maxdepth 1 ! -type d ! -name stend-results.sqlite)
if [ -n "$extra" ]; then
  echo "FAIL: the commands left files in the current directory: $extra"
  failed=$((failed + 1))
fi
folders=$(find runs -mindepth 1 -maxdepth 1 -type d | wc -l)
if [ "$folders" -ne 1 ]; then
  echo "FAIL: expected the one run folder in runs/, found $folders"
  failed=$((failed + 1))
fi
echo "$((count - failed)) of $count README commands left the current directory as expected"
[ "$failed" -eq 0 ]
