#!/usr/bin/env bash
# Runs the README's commands on the real recordings (the block between <!-- datasets:begin --> and
# <!-- datasets:end -->, and every other one-line command that reads ../shared/data or datasets/, in
# the README's order) exactly as written, as a new user would from the repository root: every
# command must succeed. They run in a scratch copy of the root (links to the sources and the build)
# with ../shared beside it, so nothing is written into the work tree, whatever its runs/ holds.
# Usage: readme_datasets_test.sh SOURCE_DIR BUILD_DIR SHARED_DATA_DIR. Exit 77 (skipped) without the data.
set -uo pipefail
src=$1 build=$2 data=$3
if [ ! -d "$data" ]; then
  echo "SKIP: $data is absent (the real recordings live in ../shared/data beside the repository)"
  exit 77
fi
. "$(dirname "$0")/doc_commands.sh"
doc_scratch "$src" "$build" "$data"
commands=$(awk '/<!-- datasets:begin -->/ {inblock = 1} /<!-- datasets:end -->/ {inblock = 0}
                /^    build\/bin\/stend [^\\]*$/ && (inblock || /\.\.\/shared\/data|datasets\//) {
                  sub(/^    /, ""); sub(/ *#.*$/, ""); print }' "$src/README.md")
count=$(printf '%s\n' "$commands" | grep -c .)
if [ "$count" -lt 10 ]; then
  echo "FAIL: found only $count README commands on the real recordings"
  exit 1
fi
cd "$scratch/repo"
while IFS= read -r cmd; do
  doc_run "$cmd"
done <<< "$commands"
doc_check_only_runs
echo "$((count - failed)) of $count README commands on ../shared/data succeeded"
[ "$failed" -eq 0 ]
