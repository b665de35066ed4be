// Lenient reads of a results document's fields, for the code that draws or exports what a
// document says: a field that is missing, null or of another type reads as NaN or "" — never a
// default presented as a result, and never an exception in the middle of a report.
#pragma once

#include <stend/sdk.hpp>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>

namespace stend::estimation {

// j[key] as a number; NaN when absent or not a number.
inline double number_field(const nlohmann::json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return kNaN;
  return j[key].get<double>();
}
// a[i] as a number; NaN when a is not an array, i is past its end or a[i] is not a number.
inline double number_at(const nlohmann::json& a, std::size_t i) {
  if (!a.is_array() || i >= a.size() || !a[i].is_number()) return kNaN;
  return a[i].get<double>();
}
// j[key] as a string; "" when absent or not a string.
inline std::string text_field(const nlohmann::json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_string()) return {};
  return j[key].get<std::string>();
}

}  // namespace stend::estimation
