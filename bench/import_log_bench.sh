#!/usr/bin/env bash
# `stend import` of a long binary log: wall time, CPU and peak RSS. Writes a 1 kHz log of SAMPLES IMU
# samples with python3 (ulog: sensor_accel + sensor_gyro half a period apart, so the gyro is
# interpolated; dataflash: IMU instance 0 and, every other sample, instance 1; rosbag1: a ROS 1 bag
# through Debian's python3-rosbag, lz4 chunks; db3: a rosbag2 SQLite3 file in rosbag2's schema;
# mcap: an MCAP file, uncompressed chunks of about 1 MiB; the bags: sensor_msgs Imu messages
# and a Temperature message each second, imported with --temperature-topic; text: imucal (two
# parts, the second half of the session first, --rate-hz 1000), mpu6050 (Fs,1000 header) and imutk
# (accelerometer and gyro files, the gyro half a period later: interpolated)), then imports it into a
# run folder under /usr/bin/time; prints samples, log size, wall [s], user + system CPU [s], peak RSS
# [MiB]; then the limits (bench/limits_bench, LIMITS_BENCH; bench/lib.sh): reading the log's bytes
# once (page cache warm, and from the device uncached) and, for the text formats, parsing them at
# std::from_chars speed (no peer in ../shared/peers).
# STEND may be any build of `stend` (e.g. an older one).
#
#   bench/import_log_bench.sh ulog|dataflash|rosbag1|db3|mcap|imucal|mpu6050|imutk [STEND] [SAMPLES]
#                                                  (defaults: build/bin/stend 10000000)
set -euo pipefail
cd "$(dirname "$0")/.."
format=$1
stend=${2:-build/bin/stend}
n=${3:-10000000}
root=$PWD
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
. bench/lib.sh

extra=()
case $format in
rosbag1|db3|mcap) extra=(--temperature-topic /temp) ;;
imucal) extra=(--rate-hz 1000) ;;
imutk) extra=("$tmp/log.gyro") ;;
esac
case $format in
rosbag1)  # python3-rosbag is a Debian package: Debian's interpreter
/usr/bin/python3 - "$n" "$tmp/log" <<'PY'
import struct, sys, rosbag, genpy
n, path = int(sys.argv[1]), sys.argv[2]
class Imu: _type, _md5sum, _full_text = "sensor_msgs/Imu", "6a62c6daae103f4ff57a132d6f95cec2", ""
class Temp: _type, _md5sum, _full_text = "sensor_msgs/Temperature", "ff71b307acdbe7c871a5a6d7ed359100", ""
def header(t): return struct.pack("<III", 0, t.secs, t.nsecs) + struct.pack("<I", 3) + b"imu"
with rosbag.Bag(path, "w", compression="lz4") as bag:
    for i in range(n):
        t = genpy.Time(1700000000) + genpy.Duration(0, 1000000 * i)
        if i % 1000 == 0:
            bag.write("/temp", (Temp._type, header(t) + struct.pack("<dd", 25.0, 0.0), Temp._md5sum, Temp), t, raw=True)
        body = struct.pack("<37d", *([0, 0, 0, 1] + [0] * 9 + [0.001, -0.002, 0.003] + [0] * 9 + [0.01, -0.02, -9.8] + [0] * 9))
        bag.write("/imu", (Imu._type, header(t) + body, Imu._md5sum, Imu), t, raw=True)
PY
;;
db3|mcap)
python3 - "$format" "$n" "$tmp/log" <<'PY'
import sqlite3, struct, sys
fmt, n, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
def cdr(t_ns, values):  # XCDR1 little endian: header stamp, frame_id "imu", float64s
    return b"\0\1\0\0" + struct.pack("<iII", t_ns // 10**9, t_ns % 10**9, 4) + b"imu\0" + struct.pack("<%dd" % len(values), *values)
imu = [0, 0, 0, 1] + [0] * 9 + [0.001, -0.002, 0.003] + [0] * 9 + [0.01, -0.02, -9.8] + [0] * 9
def messages():
    for i in range(n):
        t = 1700000000 * 10**9 + 1000000 * i
        if i % 1000 == 0: yield 2, t, cdr(t, [25.0, 0.0])
        yield 1, t, cdr(t, imu)
topics = [(1, "/imu", "sensor_msgs/msg/Imu"), (2, "/temp", "sensor_msgs/msg/Temperature")]
if fmt == "db3":
    db = sqlite3.connect(path)
    db.executescript("""PRAGMA journal_mode = OFF;
        CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
                            serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
        CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL,
                              data BLOB NOT NULL);
        CREATE INDEX timestamp_idx ON messages (timestamp ASC);""")
    db.executemany("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '')", topics)
    db.executemany("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)", messages())
    db.commit()
else:  # MCAP (mcap.dev/spec): records <opcode u8><length u64><content>; chunks of uncompressed records
    out = open(path, "wb", buffering=1 << 20)
    def s(b): return struct.pack("<I", len(b)) + b
    def rec(op, body): return struct.pack("<BQ", op, len(body)) + body
    out.write(b"\x89MCAP0\r\n" + rec(1, s(b"ros2") + s(b"bench")))
    for cid, topic, typ in topics:
        out.write(rec(3, struct.pack("<H", cid) + s(typ.encode()) + s(b"ros2msg") + s(b"")))
        out.write(rec(4, struct.pack("<HH", cid, cid) + s(topic.encode()) + s(b"cdr") + struct.pack("<I", 0)))
    chunk, seq = [], 0
    def flush():
        data = b"".join(chunk)
        out.write(rec(6, struct.pack("<QQQI", 0, 0, len(data), 0) + s(b"") + struct.pack("<Q", len(data)) + data))
        chunk.clear()
    size = 0
    for cid, t, data in messages():
        r = rec(5, struct.pack("<HIQQ", cid, seq, t, t) + data)
        seq += 1
        chunk.append(r); size += len(r)
        if size > 1 << 20: flush(); size = 0
    if chunk: flush()
    out.write(rec(2, struct.pack("<QQI", 0, 0, 0)) + b"\x89MCAP0\r\n")
PY
;;
imucal|mpu6050|imutk)
python3 - "$format" "$n" "$tmp/log" <<'PY'
import sys
fmt, n, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
out = open(path, "w", buffering=1 << 20)
if fmt == "imucal":
    out.write("part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z\n")
    for part, lo, hi in (("z_a", n // 2, n), ("z_p", 0, n // 2)):
        out.writelines("%s,%d,%d,%d,2048,1,-2,%d\n" % (part, i, i % 64, -(i % 32), i % 16) for i in range(lo, hi))
elif fmt == "mpu6050":
    out.write("Fs,1000\nInitialization time,5\nax,ay,az,gx,gy,gz\n")
    out.writelines("%d,%d,16384,1,-2,%d\n" % (i % 64, -(i % 32), i % 16) for i in range(n))
else:
    out.writelines("%.6f %.4f %.4f 9.81\n" % (i / 1000, (i % 64) * 1e-3, -(i % 32) * 1e-3) for i in range(n))
    gyro = open(path + ".gyro", "w", buffering=1 << 20)
    gyro.writelines("%.7f 0.001 -0.002 %.4f\n" % ((i + 0.5) / 1000, (i % 16) * 1e-3) for i in range(-1, n + 1))
PY
;;
*)
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
;;
esac
log_mb=$(du -cm "$tmp"/log* | tail -1 | cut -f1)

timed "$tmp/stend.times" "$stend" import "$tmp/log" "${extra[@]}" -o "$tmp/run"
read -r wall cpu rss <"$tmp/stend.times"
printf "%-10s %8s %8s %8s %10s\n" samples log_MB wall_s cpu_s peak_MiB
printf "%-10s %8s %8s %8.2f %10s\n" "$n" "$log_mb" "$wall" "$cpu" "$(echo "$rss" | mib)"
no_peer "$format import"
args=()
for f in "$tmp"/log*; do args+=(--read "$f"); done
case $format in imucal|mpu6050|imutk) args+=(--parse-file "$tmp/log") ;; esac  # text: parsing is a limit too
if limits "${args[@]}" --passes 5; then
  read_limit_line "$wall"
  [ -z "$(limit parse_MBps)" ] || parse_limit_line "$(limit read_bytes)" "$wall"
fi
