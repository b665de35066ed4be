#!/usr/bin/env bash
# Installs the npm packages the ROS 2 bag tests write their bags with (io/tests/rosbag2_writer:
# @mcap/core, @foxglove/rosmsg2-serialization, …) into the node cache (npm-cache-install.sh):
# …/stend/node/rosbag2_writer. The tests look there (or in STEND_NODE_CACHE) and skip, saying so,
# when it is absent.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$here/scripts/npm-cache-install.sh" rosbag2_writer "$here/io/tests/rosbag2_writer" \
  "the ROS 2 bag tests will be skipped"
