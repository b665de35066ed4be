#!/usr/bin/env bash
# Installs the npm packages the `stend` program embeds (the live view's charts: uPlot, pinned in
# live/web/package-lock.json) into a cache folder, never into the source tree:
# ${STEND_NODE_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/stend/node}/live_view. CMake looks there (or
# at -DSTEND_UPLOT_DIR=…/node_modules/uplot/dist) and embeds the files into the build; without
# them the live view shows its numbers and says that the charts were not built in.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cache="${STEND_NODE_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/stend/node}/live_view"
if ! command -v npm >/dev/null; then
  echo "vendor-web-deps: npm not found; the live view will be built without charts"
  exit 0
fi
mkdir -p "$cache"
cp "$here/live/web/package.json" "$here/live/web/package-lock.json" "$cache/"
npm ci --prefix "$cache" --no-audit --no-fund --loglevel=error
echo "vendor-web-deps: packages in $cache/node_modules (re-run cmake to embed them)"
