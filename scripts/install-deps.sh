#!/usr/bin/env bash
# Installs the Debian packages Stend builds against, skipping what is already there.
set -euo pipefail
packages=(
  cmake ninja-build g++ pkg-config git
  libeigen3-dev libceres-dev libyaml-cpp-dev nlohmann-json3-dev libfmt-dev libspdlog-dev
  libcli11-dev libmodbus-dev libhidapi-dev libmatio-dev libhdf5-dev libsqlite3-dev libssl-dev
  libdeflate-dev  # recording: run.h5's sample chunks deflated by Stend (hdf5_chunks.hpp)
  python3-h5py python3-numpy  # core tests: a run.h5 read with h5py alone
  libgtest-dev libgmock-dev libbenchmark-dev
  libbz2-dev libzstd-dev liblz4-dev  # io: chunk compression of ROS 1 bags (bz2, lz4) and MCAP (lz4, zstd)
  libxxhash-dev  # io: lz4 frames' content checksums (XXH32), verified by Stend
  librosbag-storage-dev librosbag-dev lz4  # io tests: ROS 1 bags written with rosbag::Bag; lz4 MCAP chunks (npm packages: install-node-test-deps.sh)
  zlib1g-dev chromium  # reporting: PNG check of report screenshots; headless-browser test of the reports
  octave  # reporting: octave-cli loads the MATLAB export in a test (~1 min to install, no recommends)
  python3-numpy python3-pandas python3-scipy  # bench: allantools (the Allan peer, ../shared/peers) on Debian's numpy, pandas, scipy; pandas + h5py: the CSV import peer (bench/pandas_import.py)
  python3-rosbag  # bench: import_log_bench.sh writes a long ROS 1 bag
  libpq-dev  # reporting: the PostgreSQL results store (libpq)
  postgresql slurm-wlm munge  # tests and bench: a real PostgreSQL cluster and a single-node Slurm started in a temp dir (docs/lab-scale.md)
  clang libclang-rt-14-dev  # scripts/fuzz.sh: the fuzz targets under libFuzzer, ASan and UBSan
  libcpp-httplib-dev  # live/: the live view's loopback HTTP server (its charts, uPlot, from npm: vendor-web-deps.sh)
  gcc-avr avr-libc binutils-avr  # firmware/bench_mcu: the bench microcontroller's firmware (ATmega328P)
  simavr libsimavr-dev libelf-dev  # emulators/firmware: that firmware in the loop under simavr (libsimavr needs libelf)
  valgrind  # the perf test: instruction counts of the key paths under callgrind (bench/perf_budget.sh)
  python3-pybind11 python3-pytest  # python/: the module `stend` (pybind11) and its tests against the program (pytest)
  python3-matplotlib jupyter-nbconvert python3-nbclient python3-ipykernel  # docs/notebooks, executed by the suite
  python3-jsonschema  # tests: `--json` outputs checked against docs/schemas (tests/check_json_schema.py)
  dpkg-dev  # cpack -G DEB: dpkg-shlibdeps computes the package's dependencies (scripts/deb-test.sh)
  debootstrap  # scripts/deb-chroot-test.sh: the .deb on a clean Debian 12 chroot
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  "$(dirname "$0")/install-node-test-deps.sh"
  "$(dirname "$0")/vendor-web-deps.sh"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
"$(dirname "$0")/install-node-test-deps.sh"
"$(dirname "$0")/vendor-web-deps.sh"
