#!/usr/bin/env bash
# Installs the npm packages the `stend` program embeds (the live view's charts: uPlot, pinned in
# live/web/package-lock.json) into the node cache (npm-cache-install.sh): …/stend/node/live_view.
# CMake looks there (or at -DSTEND_UPLOT_DIR=…/node_modules/uplot/dist) and embeds the files into
# the build; without them the live view shows its numbers and says that the charts were not built in.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$here/scripts/npm-cache-install.sh" live_view "$here/live/web" \
  "the live view will be built without charts (re-run cmake after installing them)"
