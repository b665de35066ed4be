// Chunked reading of a recording's samples (samples.hpp).
#include "stend/samples.hpp"

#include <algorithm>
#include <stdexcept>

namespace stend {

const char* to_string(Channel c) {
  switch (c) {
    case Channel::kTime: return "t_s";
    case Channel::kAx: return "ax";
    case Channel::kAy: return "ay";
    case Channel::kAz: return "az";
    case Channel::kGx: return "gx";
    case Channel::kGy: return "gy";
    case Channel::kGz: return "gz";
    case Channel::kTemperature: return "temp_c";
    case Channel::kFlags: return "flags";
  }
  return "?";
}

double value_of(const ImuSample& s, Channel c) {
  switch (c) {
    case Channel::kTime: return s.t_s;
    case Channel::kAx: return s.accel_mps2.x();
    case Channel::kAy: return s.accel_mps2.y();
    case Channel::kAz: return s.accel_mps2.z();
    case Channel::kGx: return s.gyro_radps.x();
    case Channel::kGy: return s.gyro_radps.y();
    case Channel::kGz: return s.gyro_radps.z();
    case Channel::kTemperature: return s.temperature_c;
    case Channel::kFlags: return static_cast<double>(s.flags);
  }
  return 0.0;
}

void SampleSource::read_column(Channel c, std::uint64_t first, std::size_t count,
                               double* out) const {
  std::vector<ImuSample> buf(std::min(count, kDefaultChunkSamples));
  std::size_t done = 0;
  while (done < count) {
    const std::size_t n = std::min(buf.size(), count - done);
    read(first + done, n, buf.data());
    for (std::size_t i = 0; i < n; ++i) out[done + i] = value_of(buf[i], c);
    done += n;
  }
}

namespace {
void check_range(const SampleSource& src, std::uint64_t first, std::size_t count) {
  if (first + count > src.size())
    throw std::out_of_range("sample range beyond the end of the recording");
}
}  // namespace

void MemorySamples::read(std::uint64_t first, std::size_t count, ImuSample* out) const {
  check_range(*this, first, count);
  std::copy_n(data_->begin() + static_cast<std::ptrdiff_t>(first), count, out);
}

void MemorySamples::read_column(Channel c, std::uint64_t first, std::size_t count,
                                double* out) const {
  check_range(*this, first, count);
  for (std::size_t i = 0; i < count; ++i) out[i] = value_of((*data_)[first + i], c);
}

void for_each_chunk(const SampleSource& src, std::uint64_t first, std::uint64_t last,
                    const ChunkFn& fn, std::size_t chunk_samples) {
  last = std::min(last, src.size());
  if (first >= last) return;
  chunk_samples = std::max<std::size_t>(chunk_samples, 1);
  if (const auto* memory = dynamic_cast<const MemorySamples*>(&src)) {  // the same chunks, not copied
    const ImuSample* data = memory->samples().data();
    for (std::uint64_t i = first; i < last; i += chunk_samples)
      fn(data + i, static_cast<std::size_t>(std::min<std::uint64_t>(chunk_samples, last - i)), i);
    return;
  }
  std::vector<ImuSample> buf(static_cast<std::size_t>(std::min<std::uint64_t>(chunk_samples, last - first)));
  for (std::uint64_t i = first; i < last;) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(buf.size(), last - i));
    src.read(i, n, buf.data());
    fn(buf.data(), n, i);
    i += n;
  }
}

void for_each_chunk(const SampleSource& src, const ChunkFn& fn, std::size_t chunk_samples) {
  for_each_chunk(src, 0, src.size(), fn, chunk_samples);
}

ImuSample sample_at(const SampleSource& src, std::uint64_t i) {
  ImuSample s;
  src.read(i, 1, &s);
  return s;
}

std::uint64_t lower_bound_time(const SampleSource& src, double t_s) {
  std::uint64_t lo = 0, hi = src.size();
  ImuSample s;
  while (lo < hi) {
    const std::uint64_t mid = lo + (hi - lo) / 2;
    src.read(mid, 1, &s);
    if (s.t_s < t_s) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

IndexRange index_range(const SampleSource& src, double t0_s, double t1_s) {
  IndexRange r;
  r.first = lower_bound_time(src, t0_s);
  r.last = std::max(r.first, lower_bound_time(src, t1_s));
  return r;
}

std::vector<ImuSample> read_interval(const SampleSource& src, double t0_s, double t1_s) {
  const IndexRange r = index_range(src, t0_s, t1_s);
  std::vector<ImuSample> out(static_cast<std::size_t>(r.size()));
  if (!out.empty()) src.read(r.first, out.size(), out.data());
  return out;
}

std::vector<double> read_column(const SampleSource& src, Channel c, std::uint64_t first,
                                std::uint64_t last) {
  last = std::min(last, src.size());
  std::vector<double> out(static_cast<std::size_t>(last > first ? last - first : 0));
  if (!out.empty()) src.read_column(c, first, out.size(), out.data());
  return out;
}

}  // namespace stend
