# Sourced by the tests that run a document's commands exactly as written (readme_datasets_test.sh,
# procedures_doc_test.sh): a scratch copy of the repository root to run them in, one command run
# and judged, and the check that nothing was written outside runs/.

# doc_scratch SOURCE_DIR BUILD_DIR SHARED_DATA_DIR: $scratch/repo holds links to the sources and the
# build, ../shared/data beside it when present; removed on exit. The work tree's own build and run
# folders are left out: the commands write a fresh runs/ (run folders a user has already made there
# would otherwise stop `stend import -o runs/…`).
doc_scratch() {
  local src=$1 build=$2 data=$3 entry name
  scratch=$(mktemp -d)
  trap 'rm -rf "$scratch"' EXIT
  mkdir -p "$scratch/repo" "$scratch/shared"
  [ -d "$data" ] && ln -s "$(cd "$data" && pwd)" "$scratch/shared/data"
  for entry in "$src"/*; do
    name=$(basename "$entry")
    [ "$name" = build ] || [ "$name" = runs ] || ln -s "$entry" "$scratch/repo/$name"
  done
  ln -s "$build" "$scratch/repo/build"
  failed=0
}

# doc_run COMMAND [FORBIDDEN_REGEX]: runs it with bash in the current directory; prints "ok" or
# "FAIL" with the end of its output and counts a failure in $failed. A command that exits 0 but
# prints a line matching FORBIDDEN_REGEX fails too.
doc_run() {
  local cmd=$1 forbidden=${2:-} out rc
  if out=$(bash -c "$cmd" 2>&1); then
    if [ -n "$forbidden" ] && grep -qE "$forbidden" <<< "$out"; then
      echo "FAIL  $cmd (exit 0, but it printed what it must not)"
      grep -E "$forbidden" <<< "$out" | head -5 | sed 's/^/      /'
      failed=$((failed + 1))
    else
      echo "ok    $cmd"
    fi
  else
    rc=$?
    echo "FAIL  $cmd (exit $rc)"
    printf '%s\n' "$out" | tail -15 | sed 's/^/      /'
    failed=$((failed + 1))
  fi
}

# doc_check_only_runs: only the run folders the commands name may appear in $scratch/repo (a
# dataset file's results are written only with --out).
doc_check_only_runs() {
  local extra
  extra=$(find "$scratch/repo" -mindepth 1 -maxdepth 1 ! -type l ! -name runs)
  if [ -n "$extra" ]; then
    echo "FAIL: the commands wrote outside runs/: $extra"
    failed=$((failed + 1))
  fi
}
