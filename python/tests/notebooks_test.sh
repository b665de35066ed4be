#!/usr/bin/env bash
# Executes every notebook of docs/notebooks/ with jupyter nbconvert (Debian's jupyter-nbconvert,
# nbclient, ipykernel) into a temporary folder: the committed notebooks keep no outputs, and nothing
# is written into the work tree. Exit 77 (skipped) without ../shared/data, which they read.
# Usage: notebooks_test.sh SOURCE_DIR SHARED_DATA_DIR   (PYTHONPATH must reach the stend module)
set -euo pipefail
src=$1 data=$2
if [ ! -d "$data" ]; then
  echo "SKIP: $data is absent (the notebooks read the real recordings in ../shared/data beside the repository)"
  exit 77
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# The notebooks' run folders (tempfile) go under $tmp too.
export STEND_SOURCE_DIR=$src STEND_SHARED_DATA_DIR=$data TMPDIR=$tmp MPLCONFIGDIR=$tmp/matplotlib \
  JUPYTER_RUNTIME_DIR=$tmp/runtime PYDEVD_DISABLE_FILE_VALIDATION=1
for nb in "$src"/docs/notebooks/*.ipynb; do
  echo "executing $(basename "$nb")"
  jupyter nbconvert --to notebook --execute --ExecutePreprocessor.timeout=300 --output-dir "$tmp" "$nb"
done
echo "PASS: every notebook of docs/notebooks ran"
