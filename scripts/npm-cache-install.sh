#!/usr/bin/env bash
# Installs the npm packages pinned by FOLDER/package-lock.json into the Stend node cache, never
# into the source tree: ${STEND_NODE_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/stend/node}/NAME.
#   scripts/npm-cache-install.sh NAME FOLDER "what is missing without npm"
# Without npm it says what is missing and succeeds (what needs the packages skips or does without).
set -euo pipefail
name=$1 folder=$2 without=$3
cache="${STEND_NODE_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/stend/node}/$name"
if ! command -v npm >/dev/null; then
  echo "$name: npm not found; $without"
  exit 0
fi
mkdir -p "$cache"
cp "$folder/package.json" "$folder/package-lock.json" "$cache/"
npm ci --prefix "$cache" --no-audit --no-fund --loglevel=error
echo "$name: packages in $cache/node_modules"
