#!/usr/bin/env bash
# The Debian package in a clean Debian 12 (bookworm) chroot: debootstrap --variant=minbase, then
# `apt-get install ./stend_*.deb` (apt resolves the dependencies dpkg-shlibdeps declared from the
# Debian mirror) and `stend run configs/paper_mpu6050_z.yaml` from /usr/share/stend. Needs root
# and a Debian mirror; takes minutes (documented result in docs/install.md), so it is a script,
# not a ctest (scripts/deb-test.sh is the fast temporary-root check).
# Usage: sudo scripts/deb-chroot-test.sh [BUILD_DIR] [MIRROR]   (default build, http://deb.debian.org/debian)
set -euo pipefail
build=$(cd "${1:-build}" && pwd)
mirror=${2:-http://deb.debian.org/debian}
work=$(mktemp -d /tmp/stend-chroot.XXXXXX)
root=$work/root
cleanup() {
  for m in proc dev/pts dev; do umount "$root/$m" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }
command -v debootstrap > /dev/null || fail "debootstrap is not installed (apt-get install debootstrap)"

(cd "$build" && cpack -G DEB -B "$work/pkg" > "$work/cpack.log" 2>&1) || { tail -30 "$work/cpack.log"; fail "cpack"; }
deb=$(ls "$work"/pkg/*.deb)
start=$(date +%s)
debootstrap --variant=minbase bookworm "$root" "$mirror" > "$work/debootstrap.log" 2>&1 \
  || { tail -30 "$work/debootstrap.log"; fail "debootstrap"; }
echo "debootstrap: $(( $(date +%s) - start )) s"
mount -t proc proc "$root/proc"
mount --bind /dev "$root/dev"
mount --bind /dev/pts "$root/dev/pts"
cp "$deb" "$root/tmp/"
start=$(date +%s)
chroot "$root" /usr/bin/env DEBIAN_FRONTEND=noninteractive bash -c \
  "apt-get update -qq && apt-get install -y -qq --no-install-recommends /tmp/$(basename "$deb")" > "$work/apt.log" 2>&1 \
  || { tail -30 "$work/apt.log"; fail "apt-get install of the package"; }
echo "apt-get install (with dependencies): $(( $(date +%s) - start )) s"
chroot "$root" stend --version
chroot "$root" bash -c "cd /usr/share/stend && stend run configs/paper_mpu6050_z.yaml --quiet --output /tmp/runs --name paper" \
  | tee "$work/run.log"
grep -q "status:     complete" "$work/run.log" || fail "the run did not complete"
grep -q "results:    /tmp/runs/paper/fit.json" "$work/run.log" || fail "the run's model was not fitted"
echo "PASS: stend_*.deb installs on a clean Debian 12 and runs the paper's experiment"
