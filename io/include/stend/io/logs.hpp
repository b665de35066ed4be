// Importers of flight-controller and dataset logs: PX4 ULog, ArduPilot DataFlash, EuRoC/ASL CSV.
// Each fills the Recording as importers.hpp describes (t_s relative to the first sample, SI values,
// kGapBefore where the timestamps jump by more than 1.5 median intervals or the log records lost
// data, one "info" event with every assumption) and throws ImportError naming the file and the
// byte offset (binary logs) or line (CSV) of malformed input. Repeated or decreasing timestamps do
// not stop an import: they are kept in file order and counted in the info event.
//
// looks_like_* decide by content (magic bytes, the column-name line), never by the file name.
#pragma once

#include <stend/io/importers.hpp>

#include <filesystem>

namespace stend::io {

// ---------------------------------------------------------------------------------------------
// PX4 ULog (docs.px4.io "ULog File Format"): a 16-byte header (magic "ULog" 01 12 35, version,
// start time [µs]), then definitions (F formats, I/M info, P/Q parameters, B flag bits) and data
// (A subscriptions, D data, L/C log strings, S sync markers, O dropouts).
//
// IMU samples come from one instance of sensor_accel + sensor_gyro (x y z [m/s², rad/s],
// temperature [°C], time = timestamp_sample [µs]) or of sensor_combined (accelerometer_m_s2 at
// timestamp + accelerometer_timestamp_relative, gyro_rad at timestamp; no temperature). The gyro
// is linearly interpolated at the accelerometer times when their timestamps differ.
enum class UlogSource {
  kAuto,             // sensor_accel + sensor_gyro when the chosen instance holds at least half as
                     // many samples as sensor_combined (PX4 often logs them sparsely), else
                     // sensor_combined
  kSensorAccelGyro,  // sensor_accel + sensor_gyro
  kSensorCombined,   // sensor_combined
};

struct UlogOptions {
  UlogSource source = UlogSource::kAuto;
  int instance = -1;  // multi-instance id of the topic(s); −1 = the instance with the most samples

  bool IsValid(std::string* error = nullptr) const;  // a known source, an instance >= −1
};

bool looks_like_ulog(const std::filesystem::path& file);
Recording import_ulog(const std::filesystem::path& file, const UlogOptions& options = {});
// The same, streaming (as import_csv with a SampleSink): the file is read through bounded buffers
// and the samples go to `out` a chunk at a time.
void import_ulog(const std::filesystem::path& file, const UlogOptions& options, Recording& rec, SampleSink& out);

// ---------------------------------------------------------------------------------------------
// ArduPilot DataFlash (.BIN): messages 0xA3 0x95 <type> <payload>, each type defined by an FMT
// message (type 128: Type, Length, Name[4], Format[16], Columns[64]). IMU samples come from `IMU`
// messages (TimeUS [µs], I = instance, GyrX..Z [rad/s], AccX..Z [m/s²], T [°C]; logs before
// ArduPilot 4.0 name the instances IMU, IMU2, IMU3). FMTU/UNIT/MULT, where present, are checked:
// the gyro may be logged in rad/s or deg/s, the rest must be m/s/s and degC.
struct DataflashOptions {
  int instance = -1;  // IMU instance (the I field); −1 = the instance with the most samples

  bool IsValid(std::string* error = nullptr) const;  // an instance −1 … 255
};

bool looks_like_dataflash(const std::filesystem::path& file);
Recording import_dataflash(const std::filesystem::path& file, const DataflashOptions& options = {});
// The same, streaming (as import_ulog with a SampleSink).
void import_dataflash(const std::filesystem::path& file, const DataflashOptions& options, Recording& rec,
                      SampleSink& out);

// ---------------------------------------------------------------------------------------------
// EuRoC MAV / ASL dataset IMU file mav0/imu0/data.csv: the column-name line
//   #timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],
//   a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]
// then one sample per line (integer nanoseconds, rad/s, m/s²). `path` is the csv file or a folder
// holding mav0/imu0/data.csv (or imu0/data.csv, or data.csv).
struct EurocOptions {
  SensorIdentity identity;  // the file does not name the sensor

  bool IsValid(std::string* /*error*/ = nullptr) const { return true; }  // any identity
};

bool looks_like_euroc(const std::filesystem::path& path);
Recording import_euroc(const std::filesystem::path& path, const EurocOptions& options = {});
// The same, streaming (as import_csv with a SampleSink): the samples go to `out` a chunk at a time.
void import_euroc(const std::filesystem::path& path, const EurocOptions& options, Recording& rec, SampleSink& out);

}  // namespace stend::io
