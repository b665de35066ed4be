#!/usr/bin/env python3
"""Builds a rosbag2 SQLite3 bag folder (metadata.yaml + <name>_0.db3) in rosbag2's schema (storage
schema version 3, as `ros2 bag record` writes it since Humble) from the topics and CDR payloads
write_bags.cjs put into sqlite.json:  write_db3.py OUT_DIR  → OUT_DIR/sqlite_bag/; and, crafted,
OUT_DIR/many_topics.db3: the same messages beside 100 000 more topics (std_msgs/msg/String, none
with a message)."""
import base64
import json
import os
import sqlite3
import sys

QOS = "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n"
TOPICS = [(1, "/imu/data", "sensor_msgs/msg/Imu"), (2, "/imu/temperature", "sensor_msgs/msg/Temperature"),
          (3, "/odom", "nav_msgs/msg/Odometry")]


EXTRA_TOPICS = 100000


def write_db3(path, rows, topics):
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
                   [(r["topic"], int(r["timestamp"]), base64.b64decode(r["data"])) for r in rows])
    db.commit()


def main(out):
    rows = json.load(open(os.path.join(out, "sqlite.json")))["rows"]
    extra = [(len(TOPICS) + 1 + k, "/crafted/topic_%d" % k, "std_msgs/msg/String") for k in range(EXTRA_TOPICS)]
    write_db3(os.path.join(out, "many_topics.db3"), rows, TOPICS + extra)
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
