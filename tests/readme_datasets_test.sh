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
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
mkdir -p "$scratch/repo" "$scratch/shared"
ln -s "$(cd "$data" && pwd)" "$scratch/shared/data"
# The work tree's own build and run folders are left out: the commands write a fresh runs/ (run
# folders a user has already made there would otherwise stop `stend import -o runs/…`).
for entry in "$src"/*; do
  name=$(basename "$entry")
  [ "$name" = build ] || [ "$name" = runs ] || ln -s "$entry" "$scratch/repo/$name"
done
ln -s "$build" "$scratch/repo/build"
commands=$(awk '/<!-- datasets:begin -->/ {inblock = 1} /<!-- datasets:end -->/ {inblock = 0}
                /^    build\/bin\/stend [^\\]*$/ && (inblock || /\.\.\/shared\/data|datasets\//) {
                  sub(/^    /, ""); sub(/ *#.*$/, ""); print }' "$src/README.md")
count=$(printf '%s\n' "$commands" | grep -c .)
if [ "$count" -lt 10 ]; then
  echo "FAIL: found only $count README commands on the real recordings"
  exit 1
fi
failed=0
cd "$scratch/repo"
while IFS= read -r cmd; do
  if out=$(bash -c "$cmd" 2>&1); then
    echo "ok    $cmd"
  else
    rc=$?
    echo "FAIL  $cmd (exit $rc)"
    printf '%s\n' "$out" | tail -15 | sed 's/^/      /'
    failed=$((failed + 1))
  fi
done <<< "$commands"
# Only the run folders the commands name may appear: nothing else in the scratch root (a dataset
# file's results are written only with --out, which these commands do not give).
extra=$(find "$scratch/repo" -mindepth 1 -maxdepth 1 ! -type l ! -name runs)
if [ -n "$extra" ]; then
  echo "FAIL: the commands wrote outside runs/: $extra"
  failed=$((failed + 1))
fi
echo "$((count - failed)) of $count README commands on ../shared/data succeeded"
[ "$failed" -eq 0 ]
