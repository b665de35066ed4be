#!/usr/bin/env python3
"""Builds a rosbag2 SQLite3 bag folder (metadata.yaml + <name>_0.db3) in rosbag2's schema (storage
schema version 3, as `ros2 bag record` writes it since Humble) from the topics and CDR payloads
write_bags.cjs put into sqlite.json:  write_db3.py OUT_DIR  → OUT_DIR/sqlite_bag/; and, crafted,
OUT_DIR/many_topics.db3: the same messages beside 100 000 more topics (std_msgs/msg/String, none
with a message); and long_temperature_<order>.db3, a long Imu topic beside a sparse Temperature topic
(see long_temperature_bag)."""
import base64
import json
import os
import sqlite3
import struct
import sys

QOS = "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n"
TOPICS = [(1, "/imu/data", "sensor_msgs/msg/Imu"), (2, "/imu/temperature", "sensor_msgs/msg/Temperature"),
          (3, "/odom", "nav_msgs/msg/Odometry")]


EXTRA_TOPICS = 100000


def write_db3(path, rows, topics, encoded=False):
    db = sqlite3.connect(path)
    db.executescript("""
        CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
        CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, metadata TEXT NOT NULL);
        CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
                            serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
        CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL,
                              data BLOB NOT NULL);
        CREATE INDEX timestamp_idx ON messages (timestamp ASC);
        INSERT INTO schema VALUES (3, 'humble');
    """)
    db.executemany("INSERT INTO topics VALUES (?, ?, ?, 'cdr', ?)", [(i, n, t, QOS) for i, n, t in topics])
    db.executemany("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)",
                   [(r["topic"], int(r["timestamp"]), r["data"] if encoded else base64.b64decode(r["data"]))
                    for r in rows])
    db.commit()


T0 = 1700000000 * 10**9
LONG_IMU = 51000          # Imu messages at 1 kHz: stamp T0 + i ms, linear_acceleration.x = 0.1 i
LONG_TEMPERATURE_S = 17   # a Temperature message every 17 s: 20 + j °C at T0 + 17j s, j = 0, 1, 2


def cdr(stamp_ns, values):
    """XCDR1 little endian: header (stamp, frame_id "imu"), then float64s (aligned without padding)."""
    return (b"\0\1\0\0" + struct.pack("<iII", stamp_ns // 10**9, stamp_ns % 10**9, 4) + b"imu\0" +
            struct.pack("<%dd" % len(values), *values))


def long_temperature_bag(path, stamps_in_order):
    """51 000 Imu messages beside 3 Temperature messages 17 000 Imu messages apart (more than the
    importer holds for a cursor behind the other), record time = stamp; the Temperature stamps in
    order, or reversed in the file (each value stays with its stamp), which makes the importer read
    that topic whole and sorted before the Imu messages."""
    rows = []
    for i in range(LONG_IMU):
        imu = [0, 0, 0, 1] + [0] * 9 + [0, 0.01 * i, 0] + [0] * 9 + [0.1 * i, 0, 9.8] + [0] * 9
        rows.append({"topic": 1, "timestamp": T0 + i * 10**6, "data": cdr(T0 + i * 10**6, imu)})
    n = LONG_IMU // 1000 // LONG_TEMPERATURE_S
    for k in range(n):
        j = k if stamps_in_order else n - 1 - k
        stamp = T0 + j * LONG_TEMPERATURE_S * 10**9
        rows.append({"topic": 2, "timestamp": T0 + k * LONG_TEMPERATURE_S * 10**9, "data": cdr(stamp, [20.0 + j, 0.0])})
    rows.sort(key=lambda r: (r["timestamp"], r["topic"]))
    write_db3(path, rows, TOPICS, encoded=True)


def main(out):
    rows = json.load(open(os.path.join(out, "sqlite.json")))["rows"]
    extra = [(len(TOPICS) + 1 + k, "/crafted/topic_%d" % k, "std_msgs/msg/String") for k in range(EXTRA_TOPICS)]
    write_db3(os.path.join(out, "many_topics.db3"), rows, TOPICS + extra)
    long_temperature_bag(os.path.join(out, "long_temperature_sorted.db3"), True)
    long_temperature_bag(os.path.join(out, "long_temperature_reversed.db3"), False)
    bag = os.path.join(out, "sqlite_bag")
    os.makedirs(bag, exist_ok=True)
    db_name = "sqlite_bag_0.db3"
    write_db3(os.path.join(bag, db_name), rows, TOPICS)
    stamps = [int(r["timestamp"]) for r in rows]
    with open(os.path.join(bag, "metadata.yaml"), "w") as f:
        f.write(f"""rosbag2_bagfile_information:
  version: 5
  storage_identifier: sqlite3
  duration:
    nanoseconds: {max(stamps) - min(stamps)}
  starting_time:
    nanoseconds_since_epoch: {min(stamps)}
  message_count: {len(rows)}
  topics_with_message_count: []
  compression_format: ""
  compression_mode: ""
  relative_file_paths:
    - {db_name}
  files: []
""")


if __name__ == "__main__":
    main(sys.argv[1])
