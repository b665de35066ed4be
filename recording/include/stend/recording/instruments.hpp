// Which instruments a recording holds: the one rule every consumer asks before it reads a value.
//
// A sensor or an imported log may lack the accelerometer (a gyro-only log: SensorInfo::has_accel
// false), the gyroscope (has_gyro false) or the temperature (has_temperature false). An absent
// instrument's values are never data: every sample carries NaN in its SI values and 0 in its
// counts (blank_absent, applied by the run store's writer and by the import gate), and every
// analysis asks has_instrument / has_channel rather than reading the flags itself.
#pragma once

#include <stend/recording/samples.hpp>  // Channel
#include <stend/sdk.hpp>

#include <string>
#include <vector>

namespace stend::model {
enum class Instrument;  // stend/model/terms.hpp: kAccelerometer, kGyroscope
}

namespace stend {

// Whether the sensor `info` describes has `instrument` (SensorInfo::has_accel, has_gyro).
bool has_instrument(const SensorInfo& info, model::Instrument instrument);
// Whether channel `c` carries data: time and flags always, ax ay az with the accelerometer,
// gx gy gz with the gyroscope, temp_c with has_temperature.
bool has_channel(const SensorInfo& info, Channel c);
// The instrument a channel belongs to: ax ay az the accelerometer, gx gy gz the gyroscope.
// Requires such a channel.
model::Instrument instrument_of(Channel c);
// "accelerometer" | "gyroscope".
const char* instrument_name(model::Instrument instrument);
// The instruments present, the accelerometer first (may be empty for a damaged header).
std::vector<model::Instrument> present_instruments(const SensorInfo& info);
// The value channels present, in Channel order (ax … gz, then temp_c).
std::vector<Channel> present_channels(const SensorInfo& info);
// What the recording holds, for people: "accelerometer, gyroscope, temperature";
// "gyroscope (no accelerometer, no temperature)".
std::string instruments_text(const SensorInfo& info);
// "the recording has no accelerometer (its source holds no accelerometer data)".
std::string absent_text(model::Instrument instrument);

// Sets the values of everything `info` says is absent to NaN (SI) and 0 (counts).
void blank_absent(const SensorInfo& info, ImuSample& s);

}  // namespace stend
