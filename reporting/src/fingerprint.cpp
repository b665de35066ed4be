// Procedure fingerprint: canonical YAML text + SHA-256 (see fingerprint.hpp).
#include "stend/reporting/fingerprint.hpp"

#include "stend/errors.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <map>

namespace stend::reporting {

namespace {

std::string quote(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (c == '\n') {
      o += "\\n";
      continue;
    }
    o += c;
  }
  return o + "\"";
}

std::string canonical_scalar(const std::string& s) {
  double v = 0.0;
  const char* b = s.data();
  const char* e = b + s.size();
  if (!s.empty() && *b == '+') ++b;
  const auto r = std::from_chars(b, e, v);
  if (r.ec == std::errc() && r.ptr == e && b != e) return fmt::format("{}", v == 0.0 ? 0.0 : v);
  std::string lower = s;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (lower == "true" || lower == "false") return lower;
  if (lower == "null" || lower == "~") return "null";
  return quote(s);
}

void canonical(const YAML::Node& n, std::string& out) {
  if (!n.IsDefined()) {
    out += "null";
    return;
  }
  switch (n.Type()) {
    case YAML::NodeType::Null:
    case YAML::NodeType::Undefined: out += "null"; return;
    case YAML::NodeType::Scalar: out += canonical_scalar(n.Scalar()); return;
    case YAML::NodeType::Sequence: {
      out += '[';
      bool first = true;
      for (const auto& e : n) {
        if (!first) out += ',';
        first = false;
        canonical(e, out);
      }
      out += ']';
      return;
    }
    case YAML::NodeType::Map: {
      std::map<std::string, YAML::Node> sorted;
      for (const auto& kv : n) {
        const std::string k = kv.first.Scalar();
        if (k == "label" || k == "description") continue;  // descriptive only
        sorted.emplace(k, kv.second);
      }
      out += '{';
      bool first = true;
      for (const auto& [k, v] : sorted) {
        if (!first) out += ',';
        first = false;
        out += quote(k) + ':';
        canonical(v, out);
      }
      out += '}';
      return;
    }
  }
}

// ---- SHA-256, FIPS 180-4 -------------------------------------------------------------------
constexpr std::array<std::uint32_t, 64> kK = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

constexpr std::uint32_t rotr(std::uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }

}  // namespace

std::string sha256_hex(const std::string& bytes) {
  std::array<std::uint32_t, 8> h = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
                                    0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
  std::string m = bytes;
  const std::uint64_t bits = static_cast<std::uint64_t>(bytes.size()) * 8u;
  m += static_cast<char>(0x80);
  while (m.size() % 64 != 56) m += '\0';
  for (int i = 7; i >= 0; --i) m += static_cast<char>((bits >> (8 * i)) & 0xffu);
  std::array<std::uint32_t, 64> w{};
  for (std::size_t blk = 0; blk < m.size(); blk += 64) {
    for (std::size_t i = 0; i < 16; ++i) {
      w[i] = 0;
      for (std::size_t b = 0; b < 4; ++b)
        w[i] = (w[i] << 8) | static_cast<unsigned char>(m[blk + 4 * i + b]);
    }
    for (std::size_t i = 16; i < 64; ++i) {
      const std::uint32_t s0 = rotr(w[i - 15], 7) ^ rotr(w[i - 15], 18) ^ (w[i - 15] >> 3);
      const std::uint32_t s1 = rotr(w[i - 2], 17) ^ rotr(w[i - 2], 19) ^ (w[i - 2] >> 10);
      w[i] = w[i - 16] + s0 + w[i - 7] + s1;
    }
    std::uint32_t a = h[0], b = h[1], c = h[2], d = h[3], e = h[4], f = h[5], g = h[6], hh = h[7];
    for (std::size_t i = 0; i < 64; ++i) {
      const std::uint32_t S1 = rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25);
      const std::uint32_t ch = (e & f) ^ (~e & g);
      const std::uint32_t t1 = hh + S1 + ch + kK[i] + w[i];
      const std::uint32_t S0 = rotr(a, 2) ^ rotr(a, 13) ^ rotr(a, 22);
      const std::uint32_t maj = (a & b) ^ (a & c) ^ (b & c);
      const std::uint32_t t2 = S0 + maj;
      hh = g;
      g = f;
      f = e;
      e = d + t1;
      d = c;
      c = b;
      b = a;
      a = t1 + t2;
    }
    h[0] += a; h[1] += b; h[2] += c; h[3] += d; h[4] += e; h[5] += f; h[6] += g; h[7] += hh;
  }
  std::string out;
  for (std::uint32_t v : h) out += fmt::format("{:08x}", v);
  return out;
}

std::string canonical_procedure(const std::string& experiment_yaml) {
  YAML::Node root;
  try {
    root = YAML::Load(experiment_yaml);
  } catch (const YAML::Exception& e) {
    throw InputError(std::string("experiment.yaml does not parse: ") + e.what());
  }
  if (!root.IsMap() || !root["procedure"])
    throw InputError("experiment.yaml has no 'procedure': cannot fingerprint the procedure");
  std::string out = "{\"fixtures\":";
  const YAML::Node bench = root["bench"];
  canonical(bench && bench.IsMap() ? bench["fixtures"] : YAML::Node(), out);
  out += ",\"mounting\":";
  canonical(bench && bench.IsMap() ? bench["mounting"] : YAML::Node(), out);
  out += ",\"procedure\":";
  canonical(root["procedure"], out);
  out += '}';
  return out;
}

std::string procedure_fingerprint(const std::string& experiment_yaml) {
  return sha256_hex(canonical_procedure(experiment_yaml));
}

}  // namespace stend::reporting
