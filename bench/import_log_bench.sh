#!/usr/bin/env bash
# `stend import` of a long binary flight-controller log: wall time, CPU and peak RSS. Writes a 1 kHz
# log of SAMPLES IMU samples with python3 (ulog: sensor_accel + sensor_gyro half a period apart, so
# the gyro is interpolated; dataflash: IMU instance 0 and, every other sample, instance 1), then
# imports it into a run folder under /usr/bin/time; prints samples, log size, wall [s], user +
# system CPU [s], peak RSS [MiB]. STEND may be any build of `stend` (e.g. an older one).
#
#   bench/import_log_bench.sh ulog|dataflash [STEND] [SAMPLES]    (defaults: build/bin/stend 10000000)
set -euo pipefail
cd "$(dirname "$0")/.."
format=$1
stend=${2:-build/bin/stend}
n=${3:-10000000}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

python3 - "$format" "$n" "$tmp/log" <<'PY'
import struct, sys
fmt, n, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
out = open(path, "wb", buffering=1 << 20)
if fmt == "ulog":
    out.write(b"ULog\x01\x12\x35\x01" + struct.pack("<Q", 1000))
    def msg(t, body): out.write(struct.pack("<HB", len(body), ord(t)) + body)
    fields = b"uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;float x;float y;float z;float temperature;"
    for topic in (b"sensor_accel", b"sensor_gyro"): msg("F", topic + b":" + fields)
    for i, topic in enumerate((b"sensor_accel", b"sensor_gyro")): msg("A", b"\0" + struct.pack("<H", i) + topic)
    d = struct.Struct("<HQQIffff")
    for i in range(n + 1):
        msg("D", d.pack(1, 1000 * i, 1000 * i, 0x1234, 0.001, -0.002, 0.003, 25.0))
        if i < n: msg("D", d.pack(0, 1000 * i + 500, 1000 * i + 500, 0x1234, 0.01, -0.02, -9.8, 25.0))
else:
    def fixed(s, k): return (s.encode() + b"\0" * k)[:k]
    def fmt_msg(t, l, name, f, cols): return b"\xA3\x95\x80" + bytes([t, l]) + fixed(name, 4) + fixed(f, 16) + fixed(cols, 64)
    out.write(fmt_msg(0x80, 89, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"))
    out.write(fmt_msg(162, 40, "IMU", "QBfffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,T"))
    m = struct.Struct("<3sQBfffffff")
    for i in range(n):
        out.write(m.pack(b"\xA3\x95\xA2", 1000 * i + 500, 0, 0.001, -0.002, 0.003, 0.01, -0.02, -9.8, 25.0))
        if i % 2 == 0: out.write(m.pack(b"\xA3\x95\xA2", 1000 * i + 500, 1, 0, 0, 0, 0, 0, -9.8, 25.0))
PY
log_mb=$(du -m "$tmp/log" | cut -f1)

/usr/bin/time -f "%e %U %S %M" -o "$tmp/time" "$stend" import "$tmp/log" -o "$tmp/run" >/dev/null
awk -v n="$n" -v log_mb="$log_mb" '{
  printf "%-10s %8s %8s %8s %10s\n", "samples", "log_MB", "wall_s", "cpu_s", "peak_MiB"
  printf "%-10s %8s %8s %8.2f %10.1f\n", n, log_mb, $1, $2 + $3, $4 / 1024
}' "$tmp/time"
