#!/usr/bin/env bash
# `cmake --install` into a temporary prefix (stripped), then the installed program as a user runs
# it: it finds the installed plugins first and never the build tree's; no test plugin is installed;
# configs, example models, docs, JSON schemas and the SDK are under the prefix; the paper's
# experiment runs from <prefix>/share/stend and fits its model. Prints the installed size.
# Usage: install_test.sh BUILD_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
prefix=$tmp/prefix
fail() { echo "FAIL: $*"; exit 1; }

cmake --install "$build" --prefix "$prefix" --strip > "$tmp/install.log" || { cat "$tmp/install.log"; fail "cmake --install"; }
plugins=$prefix/lib/stend/plugins
[ -d "$plugins" ] || plugins=$(dirname "$(find "$prefix" -path '*/stend/plugins/stend_sim_imu.so' | head -1)")
[ -f "$plugins/stend_sim_imu.so" ] || fail "no stend_sim_imu.so under $prefix"
if find "$prefix" -name 'stend_test*' -o -name 'stend_*test*.so' | grep -q .; then
  fail "test plugins installed: $(find "$prefix" -name 'stend_test*' -o -name 'stend_*test*.so')"
fi
for f in share/stend/configs/paper_mpu6050_z.yaml share/stend/estimators/batch_lsq/examples/paper_z_channel.yaml \
         share/stend/estimators/allan/example/allan.yaml share/stend/diagnosis/examples/bias_scale.yaml \
         share/stend/sdk/template_sensor/CMakeLists.txt share/doc/stend/README.md share/doc/stend/errors.md \
         share/doc/stend/schemas/run.schema.json include/stend/plugin_abi.h; do
  [ -e "$prefix/$f" ] || fail "$f is not installed"
done

# Where the installed program looks: its own tree first, the build tree never.
version=$("$prefix/bin/stend" --version)
echo "$version"
first=$(printf '%s\n' "$version" | sed -n 3p)
[[ "$first" == "$plugins "* ]] || fail "the installed stend does not search its own plugins first: $first"
if printf '%s\n' "$version" | grep -q "build tree"; then fail "the installed stend searches the build tree"; fi
"$prefix/bin/stend" plugins --json > "$tmp/plugins.json"
python3 - "$tmp/plugins.json" "$prefix" <<'PY'
import json, sys
doc, prefix = json.load(open(sys.argv[1])), sys.argv[2]
loaded = [p for p in doc["plugins"] if p["loaded"] and "shadowed_by" not in p]
outside = [p["file"] for p in loaded if not p["file"].startswith(prefix)]
assert len(loaded) >= 5, doc
assert not outside, f"plugins loaded from outside the prefix: {outside}"
PY

# The Python module in the prefix's dist-packages (docs/python.md), when the build made it.
if [ -f "$build/python/stend/__init__.py" ]; then
  package=$(find "$prefix" -path '*/dist-packages/stend/__init__.py' | head -1)
  [ -n "$package" ] || fail "the Python module stend is not installed"
  python=$(sed -n 's/^PYTHON_EXECUTABLE:FILEPATH=//p' "$build/CMakeCache.txt")
  PYTHONPATH=$(dirname "$(dirname "$package")") "${python:-python3}" -c "import stend; print('python: stend', stend.__version__)" \
    || fail "import stend from the prefix"
fi

# The paper's experiment from the installed configs, from an empty current directory.
mkdir "$tmp/cwd"
(cd "$tmp/cwd" && "$prefix/bin/stend" run "$prefix/share/stend/configs/paper_mpu6050_z.yaml" --quiet \
   --output "$tmp/runs" --name paper --json > "$tmp/run.json") || { cat "$tmp/run.json"; fail "stend run"; }
python3 - "$tmp/run.json" <<'PY'
import json, sys
doc = json.load(open(sys.argv[1]))
assert doc["status"] == "complete", doc
assert doc["fit"] and doc["fit"]["ok"], doc
PY
[ -z "$(ls -A "$tmp/cwd")" ] || fail "the run left files in the current directory"
echo "installed size (stripped $(grep -m1 CMAKE_BUILD_TYPE: "$build/CMakeCache.txt" | cut -d= -f2)): $(du -sh "$prefix" | cut -f1)"
echo "PASS"
