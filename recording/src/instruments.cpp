// Which instruments a recording holds. See stend/recording/instruments.hpp.
#include <stend/recording/instruments.hpp>

#include <stend/model/terms.hpp>

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace stend {

bool has_instrument(const SensorInfo& info, model::Instrument instrument) {
  return instrument == model::Instrument::kAccelerometer ? info.has_accel : info.has_gyro;
}

model::Instrument instrument_of(Channel c) {
  switch (c) {
    case Channel::kAx:
    case Channel::kAy:
    case Channel::kAz: return model::Instrument::kAccelerometer;
    case Channel::kGx:
    case Channel::kGy:
    case Channel::kGz: return model::Instrument::kGyroscope;
    default: throw std::invalid_argument(std::string("instrument_of: channel ") + to_string(c) + " is no instrument's");
  }
}

bool has_channel(const SensorInfo& info, Channel c) {
  switch (c) {
    case Channel::kTime:
    case Channel::kFlags: return true;
    case Channel::kTemperature: return info.has_temperature;
    default: return has_instrument(info, instrument_of(c));
  }
}

const char* instrument_name(model::Instrument instrument) {
  return instrument == model::Instrument::kAccelerometer ? "accelerometer" : "gyroscope";
}

std::vector<model::Instrument> present_instruments(const SensorInfo& info) {
  std::vector<model::Instrument> out;
  for (auto i : {model::Instrument::kAccelerometer, model::Instrument::kGyroscope})
    if (has_instrument(info, i)) out.push_back(i);
  return out;
}

std::vector<Channel> present_channels(const SensorInfo& info) {
  std::vector<Channel> out;
  for (Channel c : {Channel::kAx, Channel::kAy, Channel::kAz, Channel::kGx, Channel::kGy, Channel::kGz,
                    Channel::kTemperature})
    if (has_channel(info, c)) out.push_back(c);
  return out;
}

std::string instruments_text(const SensorInfo& info) {
  std::string present, absent;
  const auto add = [](std::string& list, const std::string& what) { list += (list.empty() ? "" : ", ") + what; };
  for (auto i : {model::Instrument::kAccelerometer, model::Instrument::kGyroscope})
    has_instrument(info, i) ? add(present, instrument_name(i)) : add(absent, std::string("no ") + instrument_name(i));
  info.has_temperature ? add(present, "temperature") : add(absent, "no temperature");
  if (absent.empty()) return present;
  if (present.empty()) return "nothing (" + absent + ")";
  return present + " (" + absent + ")";
}

std::string absent_text(model::Instrument instrument) {
  const std::string name = instrument_name(instrument);
  return "the recording has no " + name + " (its source holds no " + name + " data)";
}

void blank_absent(const SensorInfo& info, ImuSample& s) {
  if (!info.has_accel) {
    s.accel_mps2.setConstant(kNaN);
    for (auto& c : s.accel_counts) c = 0;
  }
  if (!info.has_gyro) {
    s.gyro_radps.setConstant(kNaN);
    for (auto& c : s.gyro_counts) c = 0;
  }
  if (!info.has_temperature) {
    s.temperature_c = kNaN;
    s.temperature_counts = 0;
  }
}

}  // namespace stend
