// Reading a simulated plugin's validated Params into its C++ configuration.
//
// The host fills every schema key (with the schema's default_yaml) before create(), so in normal
// use every key is present. Code that builds a simulated object directly (tests, device emulators)
// may pass only the keys it cares about: a missing key keeps the C++ default given here, and each
// plugin's tests check that these defaults equal the schema's. A key the plugin does not read is an
// error (it catches a schema key the reader misspells).
#pragma once

#include <stend/sdk.hpp>

#include <Eigen/Core>
#include <cstdint>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace stend::sim {

class ParamReader {
 public:
  ParamReader(const Params& p, std::string plugin) : p_(p), plugin_(std::move(plugin)) {}

  double number(const std::string& k, double def) {
    if (!take(k)) return def;
    return p_.number(k);
  }
  std::int64_t integer(const std::string& k, std::int64_t def) {
    if (!take(k)) return def;
    const Params::Value& v = p_.values().at(k);
    if (const auto* i = std::get_if<std::int64_t>(&v)) return *i;
    if (const auto* d = std::get_if<double>(&v)) {
      if (*d == static_cast<double>(static_cast<std::int64_t>(*d))) return static_cast<std::int64_t>(*d);
    }
    throw std::invalid_argument(plugin_ + ": parameter '" + k + "' is not an integer");
  }
  bool boolean(const std::string& k, bool def) {
    if (!take(k)) return def;
    return p_.boolean(k);
  }
  std::string string(const std::string& k, const std::string& def) {
    if (!take(k)) return def;
    return p_.string(k);
  }
  Eigen::Vector3d vec3(const std::string& k, const Eigen::Vector3d& def) {
    if (!take(k)) return def;
    return p_.vec3(k);
  }
  Eigen::Matrix3d mat3(const std::string& k, const Eigen::Matrix3d& def) {
    if (!take(k)) return def;
    return p_.mat3(k);
  }
  Params::Matrix matrix(const std::string& k, const Params::Matrix& def) {
    if (!take(k)) return def;
    const Params::Matrix& m = p_.matrix(k);
    if (m.size() != 3) throw std::invalid_argument(plugin_ + ": parameter '" + k + "' must have 3 rows");
    for (const auto& row : m)
      if (row.size() != m[0].size())
        throw std::invalid_argument(plugin_ + ": parameter '" + k + "' rows must have equal length");
    return m;
  }

  // Throws std::invalid_argument naming any key of the Params that was never read.
  void finish() const {
    for (const auto& kv : p_.values())
      if (!used_.count(kv.first))
        throw std::invalid_argument(plugin_ + ": unknown parameter '" + kv.first + "'");
  }

 private:
  bool take(const std::string& k) {
    used_.insert(k);
    return p_.has(k);
  }
  const Params& p_;
  std::string plugin_;
  std::set<std::string> used_;
};

}  // namespace stend::sim
