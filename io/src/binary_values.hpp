// Numbers stored as raw bytes — a NumPy array's dtype ('<f8', '>i2', '|u1'), a raw record's field
// (i16, f64) — and their conversion to double: the one decoding the npy and records readers share.
// Internal to stend_io.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>

namespace stend::io::detail {

// How one value is stored: its kind, its size and its byte order.
struct ValueType {
  char kind = 'f';          // 'i' signed integer, 'u' unsigned integer, 'f' IEEE float
  std::size_t bytes = 8;    // 1, 2, 4 or 8 (floats: 4 or 8)
  bool big_endian = false;  // most significant byte first
};

// Whether Stend reads values of this kind and size.
inline bool readable(char kind, std::size_t bytes) {
  switch (kind) {
    case 'i': case 'u': return bytes == 1 || bytes == 2 || bytes == 4 || bytes == 8;
    case 'f': return bytes == 4 || bytes == 8;
    default: return false;
  }
}

// "float64", "int16", "uint8"; " big-endian" appended for a multi-byte big-endian type.
inline std::string type_name(const ValueType& t) {
  const std::string bits = std::to_string(t.bytes * 8);
  std::string s = (t.kind == 'f' ? "float" : t.kind == 'i' ? "int" : "uint") + bits;
  if (t.big_endian && t.bytes > 1) s += " big-endian";
  return s;
}

namespace values_impl {

// The value of type V whose bytes start at p, in the byte order stated.
template <class V>
V load(const std::uint8_t* p, bool big_endian) {
  std::uint8_t b[sizeof(V)];
  std::memcpy(b, p, sizeof(V));
  if (big_endian) std::reverse(b, b + sizeof(V));  // the host is little-endian (import_common.hpp)
  V v;
  std::memcpy(&v, b, sizeof(V));
  return v;
}

template <class V>
void convert(const std::uint8_t* p, std::size_t n, std::size_t stride, bool big_endian, double* out, std::size_t out_stride) {
  for (std::size_t i = 0; i < n; ++i) out[i * out_stride] = static_cast<double>(load<V>(p + i * stride, big_endian));
}

}  // namespace values_impl

// n values of type t, the first at p and each `stride` bytes after the last, as doubles into
// out[0], out[out_stride], … (t readable).
inline void to_doubles(const ValueType& t, const std::uint8_t* p, std::size_t n, std::size_t stride, double* out,
                       std::size_t out_stride) {
  using namespace values_impl;
  const bool be = t.big_endian;
  switch (t.kind == 'f' ? 100 + t.bytes : t.kind == 'u' ? 200 + t.bytes : t.bytes) {
    case 1: return convert<std::int8_t>(p, n, stride, be, out, out_stride);
    case 2: return convert<std::int16_t>(p, n, stride, be, out, out_stride);
    case 4: return convert<std::int32_t>(p, n, stride, be, out, out_stride);
    case 8: return convert<std::int64_t>(p, n, stride, be, out, out_stride);
    case 201: return convert<std::uint8_t>(p, n, stride, be, out, out_stride);
    case 202: return convert<std::uint16_t>(p, n, stride, be, out, out_stride);
    case 204: return convert<std::uint32_t>(p, n, stride, be, out, out_stride);
    case 208: return convert<std::uint64_t>(p, n, stride, be, out, out_stride);
    case 104: return convert<float>(p, n, stride, be, out, out_stride);
    default: return convert<double>(p, n, stride, be, out, out_stride);
  }
}

}  // namespace stend::io::detail
