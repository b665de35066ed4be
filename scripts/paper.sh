#!/usr/bin/env bash
# The main job: install what is missing, build, and run the paper's experiment on the
# simulated bench (MPU6050 Z channel tilted 0…44° in 2° steps in a chamber held at 25 °C),
# then fit the paper's model to the recording and print the results.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
build=${STEND_BUILD_DIR:-build}
out=${STEND_RUNS_DIR:-runs}
"$build/bin/stend" run configs/paper_mpu6050_z.yaml --output "$out" --name "paper_mpu6050_z-$(date -u +%Y%m%dT%H%M%SZ)" | tee "$build/last-run.txt"
run_dir=$(sed -n 's/^run folder: //p' "$build/last-run.txt")
if "$build/bin/stend" --help | grep -q '^  fit'; then
  "$build/bin/stend" fit "$run_dir" --model configs/models/paper_z_channel.yaml
fi
