#!/usr/bin/env bash
# Install what is missing, build with warnings as errors, and run every test (ctest + GoogleTest).
# STEND_SANITIZE=1 builds into build-asan with AddressSanitizer and UBSan instead, at -O1 with line
# tables (what the sanitizers' authors advise: half the compile time of -O2 -g, reports keep file:line).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
if [ "${STEND_SANITIZE:-0}" = 1 ]; then
  export STEND_BUILD_DIR=${STEND_BUILD_DIR:-build-asan}
  scripts/build.sh -DSTEND_WERROR=ON -DSTEND_SANITIZE=ON -DSTEND_BUILD_BENCHMARKS=OFF \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG"
else
  scripts/build.sh -DSTEND_WERROR=ON
fi
build=${STEND_BUILD_DIR:-build}
ctest --test-dir "$build" --output-on-failure -j "${STEND_JOBS:-$(nproc)}"
