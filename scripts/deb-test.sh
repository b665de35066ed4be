#!/usr/bin/env bash
# Builds the Debian package (cpack -G DEB in BUILD_DIR), checks its dependencies (from
# dpkg-shlibdeps) and installs it into a fresh temporary root with `dpkg -x`, then runs
# `stend run configs/paper_mpu6050_z.yaml` from <root>/usr/share/stend as a user would — the
# program, its library and its plugins from the root only (the host provides the Debian
# libraries the package depends on). scripts/deb-chroot-test.sh does the same in a clean Debian 12
# chroot with the dependencies installed by apt. docs/install.md.
# Usage: scripts/deb-test.sh [BUILD_DIR]   (default build)
set -euo pipefail
build=$(cd "${1:-build}" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

(cd "$build" && cpack -G DEB -B "$tmp/pkg" > "$tmp/cpack.log" 2>&1) || { tail -30 "$tmp/cpack.log"; fail "cpack"; }
deb=$(ls "$tmp"/pkg/*.deb)
echo "package:  $(basename "$deb"), $(du -h "$deb" | cut -f1) ($(dpkg-deb -f "$deb" Installed-Size) KiB installed)"
depends=$(dpkg-deb -f "$deb" Depends)
echo "depends:  $depends"
# (Ceres is linked statically by its CMake package here; its own run-time libraries — glog, cholmod,
# spqr — appear instead.)
for lib in libsz2 libyaml-cpp libmodbus libhidapi libmatio libpq5 libgoogle-glog libcholmod libc6 libstdc++6; do
  [[ "$depends" == *"$lib"* ]] || fail "Depends lacks $lib"
done
if dpkg-deb -c "$deb" | grep -E 'stend_test|test_mean_accel|test-plugins'; then fail "test plugins in the package"; fi

root=$tmp/root
mkdir -p "$root"
dpkg -x "$deb" "$root"
"$root/usr/bin/stend" --version
if "$root/usr/bin/stend" --version | grep -q "build tree"; then fail "the packaged stend searches the build tree"; fi
"$root/usr/bin/stend" plugins --json > "$tmp/plugins.json"
# The Python module from the package's dist-packages (python/, docs/python.md).
package=$(find "$root/usr/lib" -path '*/dist-packages/stend/__init__.py' | head -1)
[ -n "$package" ] || fail "the package holds no Python module stend"
PYTHONPATH=$(dirname "$(dirname "$package")") /usr/bin/python3 -c "import stend; print('python:   stend', stend.__version__)" \
  || fail "import stend from the package"
(cd "$root/usr/share/stend" && "$root/usr/bin/stend" run configs/paper_mpu6050_z.yaml --quiet --output "$tmp/runs" \
   --name paper --json > "$tmp/run.json") || { cat "$tmp/run.json"; fail "stend run from the package"; }
python3 - "$tmp/run.json" "$tmp/plugins.json" "$root" <<'PY'
import json, sys
run, plugins, root = json.load(open(sys.argv[1])), json.load(open(sys.argv[2])), sys.argv[3]
assert run["status"] == "complete" and run["fit"]["ok"], run
loaded = [p["file"] for p in plugins["plugins"] if p["loaded"] and "shadowed_by" not in p]
assert loaded and all(f.startswith(root + "/usr/lib/") for f in loaded), loaded
PY
echo "PASS: the .deb installs into a fresh root and runs the paper's experiment from it"
