// Writes ROS 2 test bags with the formats' own writers (@mcap/core McapWriter,
// @foxglove/rosmsg2-serialization MessageWriter) for io/tests/rosbag_test.cpp:
//   node write_bags.cjs OUT_DIR
// Message i of /imu/data: stamp = 1700000000 s + 5 ms · i (200 Hz) except that message 100
// repeats message 99's stamp and messages 300..302 are missing (a gap); linear_acceleration =
// (0.01 i, −0.02 i, 9.81) m/s², angular_velocity = (0.001 i, 0.002, −0.003 i) rad/s,
// frame_id "imu_link"; log_time = stamp + 1 ms. /imu/temperature at 10 Hz: 25 + 0.1 k °C.
// Files: plain.mcap (no chunks), zstd.mcap, lz4.mcap (chunks of ~4 kB; lz4 through the `lz4`
// command, skipped when absent), nosummary.mcap (chunks, no summary or indexes), two_imu.mcap,
// zero_stamps.mcap (header stamps 0), big_endian.mcap (CDR big endian via CdrWriter), and
// sqlite.json (topics and CDR payloads for the SQLite3 bag the test builds).
"use strict";
const fs = require("fs");
const path = require("path");
const { spawnSync } = require("child_process");
const { McapWriter, TempBuffer } = require("@mcap/core");
const { MessageWriter } = require("@foxglove/rosmsg2-serialization");
const { parse } = require("@foxglove/rosmsg");
const { CdrWriter, EncapsulationKind } = require("@foxglove/cdr");
const zstd = require("@foxglove/wasm-zstd");

const HEADER = "builtin_interfaces/Time stamp\nstring frame_id\n";
const IMU_DEF = `std_msgs/Header header
geometry_msgs/Quaternion orientation
float64[9] orientation_covariance
geometry_msgs/Vector3 angular_velocity
float64[9] angular_velocity_covariance
geometry_msgs/Vector3 linear_acceleration
float64[9] linear_acceleration_covariance
================================================================================
MSG: std_msgs/Header
${HEADER}================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Quaternion
float64 x 0
float64 y 0
float64 z 0
float64 w 1
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
`;
const TEMP_DEF = `std_msgs/Header header
float64 temperature
float64 variance
================================================================================
MSG: std_msgs/Header
${HEADER}================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
`;

const N = 600;
const T0 = 1700000000n * 1000000000n;
const imuWriter = new MessageWriter(parse(IMU_DEF, { ros2: true }));
const tempWriter = new MessageWriter(parse(TEMP_DEF, { ros2: true }));

function stampNs(i) {
  return T0 + BigInt(i === 100 ? 99 : i) * 5000000n;
}
const indices = [...Array(N).keys()].filter((i) => i < 300 || i > 302);
function time(ns) {
  return { sec: Number(ns / 1000000000n), nanosec: Number(ns % 1000000000n) };
}
function imu(i, zero) {
  return {
    header: { stamp: zero ? { sec: 0, nanosec: 0 } : time(stampNs(i)), frame_id: "imu_link" },
    orientation: { x: 0, y: 0, z: 0, w: 1 },
    orientation_covariance: new Array(9).fill(0),
    angular_velocity: { x: 0.001 * i, y: 0.002, z: -0.003 * i },
    angular_velocity_covariance: new Array(9).fill(0),
    linear_acceleration: { x: 0.01 * i, y: -0.02 * i, z: 9.81 },
    linear_acceleration_covariance: new Array(9).fill(0),
  };
}
// The same message through CdrWriter in big endian, field by field in the definition's order.
function imuBigEndian(i) {
  const w = new CdrWriter({ kind: EncapsulationKind.CDR_BE });
  const t = time(stampNs(i));
  w.int32(t.sec);
  w.uint32(t.nanosec);
  w.string("imu_link");
  const m = imu(i, false);
  for (const v of [0, 0, 0, 1]) w.float64(v);
  for (let k = 0; k < 9; ++k) w.float64(0);
  for (const v of [m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z]) w.float64(v);
  for (let k = 0; k < 9; ++k) w.float64(0);
  for (const v of [m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z]) w.float64(v);
  for (let k = 0; k < 9; ++k) w.float64(0);
  return w.data;
}
function temperature(k) {
  return { header: { stamp: time(T0 + BigInt(k) * 100000000n), frame_id: "imu_link" }, temperature: 25 + 0.1 * k, variance: 0 };
}

const lz4Available = spawnSync("lz4", ["-V"]).status === 0;
function lz4(data) {
  const r = spawnSync("lz4", ["-c", "-q"], { input: data, maxBuffer: 1 << 28 });
  if (r.status !== 0) throw new Error("lz4 failed");
  return { compression: "lz4", compressedData: new Uint8Array(r.stdout) };
}

async function writeMcap(file, options, { topics = ["/imu/data"], zero = false, bigEndian = false } = {}) {
  const buffer = new TempBuffer();
  const writer = new McapWriter({ writable: buffer, ...options });
  await writer.start({ profile: "ros2", library: "stend test writer" });
  const imuSchema = await writer.registerSchema({ name: "sensor_msgs/msg/Imu", encoding: "ros2msg", data: new TextEncoder().encode(IMU_DEF) });
  const tempSchema = await writer.registerSchema({ name: "sensor_msgs/msg/Temperature", encoding: "ros2msg", data: new TextEncoder().encode(TEMP_DEF) });
  const channels = [];
  for (const topic of topics) {
    channels.push(await writer.registerChannel({ topic, schemaId: imuSchema, messageEncoding: "cdr", metadata: new Map() }));
  }
  const tempChannel = await writer.registerChannel({ topic: "/imu/temperature", schemaId: tempSchema, messageEncoding: "cdr", metadata: new Map() });
  let seq = 0;
  let k = 0;
  for (const i of indices) {
    const logTime = stampNs(i) + 1000000n;
    while (T0 + BigInt(k) * 100000000n <= logTime) {
      const t = T0 + BigInt(k) * 100000000n;
      await writer.addMessage({ channelId: tempChannel, sequence: seq++, logTime: t, publishTime: t, data: tempWriter.writeMessage(temperature(k)) });
      ++k;
    }
    const data = bigEndian ? imuBigEndian(i) : imuWriter.writeMessage(imu(i, zero));
    for (const channelId of channels) {
      await writer.addMessage({ channelId, sequence: seq++, logTime, publishTime: logTime, data });
    }
  }
  await writer.end();
  fs.writeFileSync(file, buffer.get());
}

async function main() {
  const out = process.argv[2];
  fs.mkdirSync(out, { recursive: true });
  await zstd.isLoaded;
  const chunked = { useChunks: true, chunkSize: 4096 };
  await writeMcap(path.join(out, "plain.mcap"), { useChunks: false });
  await writeMcap(path.join(out, "zstd.mcap"), { ...chunked, compressChunk: (d) => ({ compression: "zstd", compressedData: zstd.compress(d, 3) }) });
  if (lz4Available) await writeMcap(path.join(out, "lz4.mcap"), { ...chunked, compressChunk: lz4 });
  await writeMcap(path.join(out, "nosummary.mcap"), {
    ...chunked, useStatistics: false, useSummaryOffsets: false, repeatSchemas: false, repeatChannels: false,
    useAttachmentIndex: false, useMetadataIndex: false, useMessageIndex: false, useChunkIndex: false,
  });
  await writeMcap(path.join(out, "two_imu.mcap"), chunked, { topics: ["/imu/data", "/imu2/data"] });
  await writeMcap(path.join(out, "zero_stamps.mcap"), chunked, { zero: true });
  await writeMcap(path.join(out, "big_endian.mcap"), chunked, { bigEndian: true });
  // The SQLite3 bag: the same CDR payloads, received at log_time.
  const rows = indices.map((i) => ({ topic: 1, timestamp: (stampNs(i) + 1000000n).toString(), data: Buffer.from(imuWriter.writeMessage(imu(i, false))).toString("base64") }));
  for (let k = 0; k * 100000000 <= (N - 1) * 5000000; ++k) {
    rows.push({ topic: 2, timestamp: (T0 + BigInt(k) * 100000000n).toString(), data: Buffer.from(tempWriter.writeMessage(temperature(k))).toString("base64") });
  }
  fs.writeFileSync(path.join(out, "sqlite.json"), JSON.stringify({ rows, lz4: lz4Available }));
}

main().catch((e) => {
  console.error(e);
  process.exit(1);
});
