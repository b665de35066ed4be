#!/usr/bin/env bash
# The main job: install what is missing, build, and run the paper's experiment on the
# simulated bench (MPU6050 Z channel tilted 0…44° in 2° steps in a chamber held at 25 °C);
# `stend run` then fits the paper's model (the experiment's estimation section) and writes
# the results into the run folder; then the gap diagnosis (twin against the recording) and the
# report (report.html with plots, rebuilt to include the diagnosis).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
build=${STEND_BUILD_DIR:-build}
runs=${STEND_RUNS_DIR:-runs}
name=paper_mpu6050_z-$(date -u +%Y%m%dT%H%M%SZ)
"$build/bin/stend" run configs/paper_mpu6050_z.yaml --output "$runs" --name "$name"
echo
"$build/bin/stend" gap "$runs/$name" --model estimators/batch_lsq/examples/paper_z_channel.yaml
"$build/bin/stend" report "$runs/$name"
