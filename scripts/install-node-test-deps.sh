#!/usr/bin/env bash
# Installs the npm packages the ROS 2 bag tests write their bags with (io/tests/rosbag2_writer:
# @mcap/core, @foxglove/rosmsg2-serialization, …) from its package-lock.json into a cache folder,
# never into the source tree: ${STEND_NODE_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/stend/node}.
# The tests look there (or in STEND_NODE_CACHE) and skip, saying so, when it is absent.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cache="${STEND_NODE_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/stend/node}/rosbag2_writer"
if ! command -v npm >/dev/null; then
  echo "install-node-test-deps: npm not found; the ROS 2 bag tests will be skipped"
  exit 0
fi
mkdir -p "$cache"
cp "$here/io/tests/rosbag2_writer/package.json" "$here/io/tests/rosbag2_writer/package-lock.json" "$cache/"
npm ci --prefix "$cache" --no-audit --no-fund --loglevel=error
echo "install-node-test-deps: packages in $cache/node_modules"
