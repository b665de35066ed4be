// ROS bags → a Recording (see importers.hpp for what every importer fills).
//
// Formats:
//   ROS 1 bag v2.0 ("#ROSBAG V2.0" magic), read by Stend's own reader (records, index, chunks
//   stored / bz2 / lz4, each length checked); messages sensor_msgs/Imu and
//   sensor_msgs/Temperature (ROS 1 serialization).
//   rosbag2: a folder with metadata.yaml and its storage files (SQLite3 .db3, or MCAP), a single
//   .db3 file, or a single MCAP file; messages sensor_msgs/msg/Imu and sensor_msgs/msg/Temperature
//   in CDR (XCDR1, little or big endian). Storage is recognised by content (SQLite header with the
//   rosbag2 tables `topics` and `messages`; MCAP magic "\x89MCAP0\r\n"), never by extension.
//
// Each Imu message is one sample:
//   t_s         header.stamp − the first message's header.stamp [s]. When any header stamp is
//               zero (a driver that does not stamp), every sample takes the bag's record time
//               instead and the info event says so.
//   accel_mps2  linear_acceleration [m/s²]      gyro_radps  angular_velocity [rad/s]
//   temperature_c  the latest Temperature message on `temperature_topic` at or before the sample
//               (the first one for samples before it) [°C]; 0 and has_temperature false without it
//   counts      0 (a bag holds SI values only)
//   flags       kGapBefore after an interval longer than 1.5 median intervals (the median of the
//               first 65 536 intervals, as every log importer takes it)
// Stamps that do not increase are kept as recorded (a later repair step fixes them); the info
// event counts them. Identity: model = the topic, serial = the messages' header.frame_id, unless
// the options give them.
#pragma once

#include <stend/io/importers.hpp>

#include <filesystem>
#include <string>

namespace stend::io {

struct RosbagOptions {
  // The Imu topic; empty = the only Imu topic of the bag (several → ImportError listing them).
  std::string topic;
  // A Temperature topic to take the temperature from; empty = none.
  std::string temperature_topic;
  SensorIdentity identity;     // empty fields are filled from the bag (see above)
  double gravity_mps2 = 0.0;   // 0 = unknown (a bag does not state it)

  bool IsValid(std::string* error = nullptr) const;  // gravity >= 0
};

// True when `path` is a file starting with the ROS 1 bag v2.0 magic.
bool looks_like_rosbag1(const std::filesystem::path& path);
Recording import_rosbag1(const std::filesystem::path& path, const RosbagOptions& options = {});
// The same, streaming: two passes over the topic, a chunk of the bag at a time (memory holds one
// chunk and a few numbers per chunk and connection; when the bag's chunks overlap in time, the
// place of each message of the topic as well); the samples go to `out` a chunk at a time, `rec` receives the rest
// (header filled before the first samples reach `out`; events at t = 0, RunSink places them).
void import_rosbag1(const std::filesystem::path& path, const RosbagOptions& options, Recording& rec, SampleSink& out);

// True when `path` is an MCAP file, a rosbag2 SQLite3 file, or a folder holding one of them.
bool looks_like_rosbag2(const std::filesystem::path& path);
Recording import_rosbag2(const std::filesystem::path& path, const RosbagOptions& options = {});
// The same, streaming: the storage is read a message at a time (SQLite3: stepping the messages
// query; MCAP: a record, or one decompressed chunk, at a time), in three passes (topics, scan,
// samples); memory does not grow with the bag.
void import_rosbag2(const std::filesystem::path& path, const RosbagOptions& options, Recording& rec, SampleSink& out);

}  // namespace stend::io
