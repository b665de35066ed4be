// Noise processes of the error-model vocabulary: the non-deterministic part of a sensor's error.
//
// terms.hpp defines the deterministic terms (bias, scale, cross-axis …); this file defines the
// random ones, each once, with its exact discretization at a sample period dt and the theory an
// estimator or the gap diagnoser compares against (variance, Allan variance). Everything is
// deterministic from a seed.
//
// Conventions (state them whenever a number is quoted):
//   white noise      density N  [unit/√Hz], ONE-SIDED amplitude spectral density as in datasheets
//                    ("400 µg/√Hz"). Sampled at fs = 1/dt with no filtering below Nyquist, the
//                    samples are i.i.d. with σ = N·√(fs/2). Allan variance N²/(2τ).
//                    (IEEE-952 angle/velocity random walk coefficient = N/√2.)
//   bias instability first-order Gauss–Markov process, stationary standard deviation σ [unit] and
//                    correlation time τc [s]: dx/dt = −x/τc + √(2σ²/τc)·w(t). Exact
//                    discretization x[k+1] = φ·x[k] + σ·√(1−φ²)·ξ, φ = exp(−dt/τc). Its Allan
//                    deviation peaks at ≈ 0.6174·σ at τ ≈ 1.89·τc (allan::kGaussMarkovPeak*).
//                    Several GM processes may be summed to shape a flicker-like plateau.
//   random walk      coefficient K [unit/√s] (m/s^2.5 for an accelerometer, rad/s^1.5 for a gyro):
//                    dx/dt = K·w(t), w unit-intensity white noise, so Var[x(t) − x(0)] = K²·t.
//                    Exact discretization x[k+1] = x[k] + K·√dt·ξ. Allan variance K²·τ/3.
//                    (IEEE-952 rate random walk coefficient = K.)
// where ξ are independent standard normal numbers drawn from Rng.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace stend::model {

// ---------------------------------------------------------------------------------------------
// Random numbers: xoshiro256++ (Blackman & Vigna) seeded through splitmix64, with a ziggurat
// normal sampler (Marsaglia & Tsang, 256 layers, in Doornik's ZIGNOR form: the layer index and the
// uniform come from independent bits; 98.5 % of draws are accepted at the first test). A few ns per
// normal number; satisfies UniformRandomBitGenerator, so the std:: distributions work with it too.
class Rng {
 public:
  using result_type = std::uint64_t;

  explicit Rng(std::uint64_t seed = 1) noexcept { reseed(seed); }

  void reseed(std::uint64_t seed) noexcept {
    std::uint64_t z = seed;
    for (auto& s : s_) s = splitmix64(z);
    have_half_ = false;
  }

  static constexpr result_type min() noexcept { return 0; }
  static constexpr result_type max() noexcept { return std::numeric_limits<result_type>::max(); }

  result_type operator()() noexcept {
    const std::uint64_t result = rotl(s_[0] + s_[3], 23) + s_[0];
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }

  // Uniform in the open interval (0, 1).
  double uniform() noexcept {
    return (static_cast<double>((*this)() >> 11) + 0.5) * 0x1.0p-53;
  }

  // Standard normal. The common case (inside a layer's rectangle, ~98.8 %) is inlined.
  // Each 64-bit draw serves two normals: 32 bits each, 8 for the layer and 24 for the uniform,
  // so a sample's resolution inside a layer is ≈ 4e-7·σ.
  double normal() noexcept {
    if (have_half_) {
      have_half_ = false;
      return from_half(half_);
    }
    const std::uint64_t bits = (*this)();
    half_ = static_cast<std::uint32_t>(bits);
    have_half_ = true;
    return from_half(static_cast<std::uint32_t>(bits >> 32));
  }

  // n standard normals into out[0..n) — the same numbers as n calls of normal(), two per 64-bit
  // draw in a tight loop (faster when a sample needs many).
  void fill_normal(double* out, int n) noexcept {
    int k = 0;
    if (have_half_ && k < n) out[k++] = normal();
    for (; k + 1 < n; k += 2) {
      const std::uint64_t bits = (*this)();
      out[k] = from_half(static_cast<std::uint32_t>(bits >> 32));
      out[k + 1] = from_half(static_cast<std::uint32_t>(bits));
    }
    if (k < n) out[k] = normal();
  }

  // An independent stream: this generator advanced by 2^128 draws.
  void jump() noexcept {
    static constexpr std::uint64_t kJump[] = {0x180ec6d33cfd0abaULL, 0xd5a61266f0c9392cULL,
                                              0xa9582618e03fc9aaULL, 0x39abdc4529b1661cULL};
    std::array<std::uint64_t, 4> t{};
    for (std::uint64_t j : kJump)
      for (int b = 0; b < 64; ++b) {
        if (j & (std::uint64_t{1} << b))
          for (int k = 0; k < 4; ++k) t[static_cast<std::size_t>(k)] ^= s_[static_cast<std::size_t>(k)];
        (*this)();
      }
    s_ = t;
    have_half_ = false;
  }

 private:
  static constexpr int kLayers = 256;
  static constexpr double kR = 3.6541528853610088;  // start of the tail
  static constexpr double kV = 4.92867323399e-3;    // area of each layer

  struct Tables {
    std::array<double, kLayers + 1> x{};      // layer edges, x[1] = R, x[kLayers] = 0
    std::array<double, kLayers + 1> f{};      // exp(−x²/2) at the edges
    std::array<double, kLayers> ratio{};      // x[i+1]/x[i]: the part of layer i under the curve
    Tables() noexcept {
      double fx = std::exp(-0.5 * kR * kR);
      x[0] = kV / fx;
      x[1] = kR;
      x[kLayers] = 0.0;
      for (int i = 2; i < kLayers; ++i) {
        const auto k = static_cast<std::size_t>(i);
        x[k] = std::sqrt(-2.0 * std::log(kV / x[k - 1] + fx));
        fx = std::exp(-0.5 * x[k] * x[k]);
      }
      for (std::size_t i = 0; i <= static_cast<std::size_t>(kLayers); ++i) f[i] = std::exp(-0.5 * x[i] * x[i]);
      for (std::size_t i = 0; i < static_cast<std::size_t>(kLayers); ++i) ratio[i] = x[i + 1] / x[i];
    }
  };
  static const Tables& tables() noexcept {
    static const Tables t;
    return t;
  }

  // One normal from 32 bits: the upper 24 for the uniform u in (−1, 1), the lower 8 for the layer.
  // Bits drawn by the slow path come after the pair h was taken from, as in normal().
  [[gnu::always_inline]] double from_half(std::uint32_t h) noexcept {
    const Tables& z = tables();
    const double u = (static_cast<double>(h >> 8) + 0.5) * 0x1.0p-23 - 1.0;  // (−1, 1)
    const unsigned i = h & 0xFFu;
    if (std::fabs(u) < z.ratio[i]) return u * z.x[i];
    return normal_slow(u, i);
  }

  // The wedges and the tail; loops with fresh draws until a sample is accepted.
  [[gnu::noinline]] double normal_slow(double u, unsigned i) noexcept {
    const Tables& z = tables();
    for (;;) {
      if (i == 0) return tail(u < 0.0);
      // The wedge of layer i between x[i+1] and x[i]: accept under the curve.
      const double x = u * z.x[i];
      if (z.f[i] + uniform() * (z.f[i + 1] - z.f[i]) < std::exp(-0.5 * x * x)) return x;
      const std::uint64_t bits = (*this)();
      u = 2.0 * ((static_cast<double>(bits >> 11) + 0.5) * 0x1.0p-53) - 1.0;
      i = static_cast<unsigned>(bits & 0xFFu);
      if (std::fabs(u) < z.ratio[i]) return u * z.x[i];
    }
  }

  double tail(bool negative) noexcept {
    double x, y;
    do {
      x = std::log(uniform()) / kR;
      y = std::log(uniform());
    } while (-2.0 * y < x * x);
    return negative ? x - kR : kR - x;
  }

  static std::uint64_t rotl(std::uint64_t x, int k) noexcept { return (x << k) | (x >> (64 - k)); }
  static std::uint64_t splitmix64(std::uint64_t& state) noexcept {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }

  std::array<std::uint64_t, 4> s_{};
  std::uint32_t half_ = 0;  // the unused half of the last draw, for normal()
  bool have_half_ = false;
};

// ---------------------------------------------------------------------------------------------
// The processes. Each is constructed for one sample period dt [s] and advanced one sample at a
// time with an Rng; none allocates after construction.

namespace detail {
inline void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}
inline void check_dt(double dt) {
  require(std::isfinite(dt) && dt > 0.0, "noise: sample period must be > 0 s");
}
}  // namespace detail

// White noise from a one-sided density N [unit/√Hz]: σ = N·√(1/(2·dt)).
class WhiteNoise {
 public:
  WhiteNoise() = default;
  WhiteNoise(double density, double dt) {
    detail::check_dt(dt);
    detail::require(std::isfinite(density) && density >= 0.0, "white noise: density must be >= 0");
    sigma_ = sigma_from_density(density, dt);
  }
  static double sigma_from_density(double density, double dt) { return density * std::sqrt(0.5 / dt); }
  static double density_from_sigma(double sigma, double dt) { return sigma * std::sqrt(2.0 * dt); }

  double sigma() const { return sigma_; }
  bool active() const { return sigma_ > 0.0; }
  double sample(Rng& rng) const { return sigma_ * rng.normal(); }

 private:
  double sigma_ = 0.0;
};

// First-order Gauss–Markov process (stationary std σ, correlation time τc), exact discretization.
class GaussMarkov {
 public:
  GaussMarkov() = default;
  GaussMarkov(double sigma, double correlation_s, double dt) {
    detail::check_dt(dt);
    detail::require(std::isfinite(sigma) && sigma >= 0.0, "Gauss-Markov: sigma must be >= 0");
    detail::require(std::isfinite(correlation_s) && correlation_s > 0.0,
                    "Gauss-Markov: correlation time must be > 0 s");
    sigma_ = sigma;
    phi_ = std::exp(-dt / correlation_s);
    // √(1−φ²) computed without cancellation for dt ≪ τc: 1−φ² = −expm1(−2dt/τc).
    drive_ = sigma * std::sqrt(-std::expm1(-2.0 * dt / correlation_s));
  }

  double sigma() const { return sigma_; }
  double phi() const { return phi_; }
  double drive() const { return drive_; }
  bool active() const { return sigma_ > 0.0; }
  double value() const { return x_; }

  void reset(double x = 0.0) { x_ = x; }
  // Start in the stationary distribution N(0, σ²) (the default for a sensor that was powered on
  // long before the run).
  void reset_stationary(Rng& rng) { x_ = sigma_ * rng.normal(); }
  double step(Rng& rng) { return step_with(rng.normal()); }
  // One step driven by the standard normal xi.
  double step_with(double xi) {
    x_ = phi_ * x_ + drive_ * xi;
    return x_;
  }

 private:
  double sigma_ = 0.0, phi_ = 0.0, drive_ = 0.0, x_ = 0.0;
};

// Random walk with coefficient K [unit/√s]: Var[x(t) − x(0)] = K²·t.
class RandomWalk {
 public:
  RandomWalk() = default;
  RandomWalk(double coefficient, double dt) {
    detail::check_dt(dt);
    detail::require(std::isfinite(coefficient) && coefficient >= 0.0,
                    "random walk: coefficient must be >= 0");
    k_ = coefficient;
    drive_ = coefficient * std::sqrt(dt);
  }
  double coefficient() const { return k_; }
  double drive() const { return drive_; }
  bool active() const { return k_ > 0.0; }
  double value() const { return x_; }
  void reset(double x = 0.0) { x_ = x; }
  double step(Rng& rng) { return step_with(rng.normal()); }
  double step_with(double xi) {
    x_ += drive_ * xi;
    return x_;
  }

 private:
  double k_ = 0.0, drive_ = 0.0, x_ = 0.0;
};

struct GaussMarkovSpec {
  double sigma = 0.0;          // stationary standard deviation [unit]
  double correlation_s = 1.0;  // correlation time τc [s]
};

// The noise of one channel (one axis of one instrument).
struct NoiseSpec {
  double white_density = 0.0;                  // [unit/√Hz], one-sided
  std::vector<GaussMarkovSpec> bias_instability;  // summed
  double random_walk = 0.0;                    // [unit/√s]
};

// Sum of the processes of a NoiseSpec, advanced one sample at a time. Processes with zero size
// draw no random numbers. Per sample, the order of draws is: white, each GM, random walk.
class NoiseChannel {
 public:
  NoiseChannel() = default;
  NoiseChannel(const NoiseSpec& spec, double dt) : white_(spec.white_density, dt), walk_(spec.random_walk, dt) {
    for (const auto& g : spec.bias_instability) {
      detail::require(std::isfinite(g.sigma) && g.sigma >= 0.0, "Gauss-Markov: sigma must be >= 0");
      if (g.sigma > 0.0) gm_.emplace_back(g.sigma, g.correlation_s, dt);
    }
  }

  // Stationary GM states, random walk at 0.
  void reset(Rng& rng) {
    for (auto& g : gm_) g.reset_stationary(rng);
    walk_.reset();
  }

  // The noise value of the next sample.
  double step(Rng& rng) {
    double v = white_.active() ? white_.sample(rng) : 0.0;
    for (auto& g : gm_) v += g.step(rng);
    if (walk_.active()) v += walk_.step(rng);
    return v;
  }

  // Standard normals one step consumes (in the order step() draws them).
  int draws() const { return (white_.active() ? 1 : 0) + static_cast<int>(gm_.size()) + (walk_.active() ? 1 : 0); }
  // The same step from pre-drawn normals (e.g. Rng::fill_normal for several channels at once);
  // advances z past the draws() numbers used.
  double step(const double*& z) {
    double v = white_.active() ? white_.sigma() * *z++ : 0.0;
    for (auto& g : gm_) v += g.step_with(*z++);
    if (walk_.active()) v += walk_.step_with(*z++);
    return v;
  }

  // Current slowly varying part (GM sum + random walk), without white noise.
  double bias() const {
    double v = walk_.value();
    for (const auto& g : gm_) v += g.value();
    return v;
  }
  bool active() const { return white_.active() || walk_.active() || !gm_.empty(); }
  const WhiteNoise& white() const { return white_; }
  const std::vector<GaussMarkov>& gauss_markov() const { return gm_; }
  const RandomWalk& random_walk() const { return walk_; }

 private:
  WhiteNoise white_;
  std::vector<GaussMarkov> gm_;
  RandomWalk walk_;
};

// ---------------------------------------------------------------------------------------------
// Allan variance σ²(τ) of each process (continuous-time theory; for white noise this is exact for
// samples averaged over τ = n·dt). Sum them for a channel.
namespace allan {
inline double white(double density, double tau) { return density * density / (2.0 * tau); }
inline double random_walk(double coefficient, double tau) { return coefficient * coefficient * tau / 3.0; }
inline double gauss_markov(double sigma, double correlation_s, double tau) {
  const double x = tau / correlation_s;
  if (x < 1e-3)  // series σ²·(2x/3 − x²/2 + 7x³/30), avoids cancellation
    return sigma * sigma * x * (2.0 / 3.0 - x * (0.5 - 7.0 * x / 30.0));
  return sigma * sigma / (x * x) * (2.0 * x - 3.0 + 4.0 * std::exp(-x) - std::exp(-2.0 * x));
}
// Where the Allan deviation of a GM process peaks: τ_peak = 1.8926·τc, σ_A = 0.61736·σ.
inline constexpr double kGaussMarkovPeakTau = 1.8926;
inline constexpr double kGaussMarkovPeakDeviation = 0.61736;
inline double channel(const NoiseSpec& s, double tau) {
  double v = white(s.white_density, tau) + random_walk(s.random_walk, tau);
  for (const auto& g : s.bias_instability) v += gauss_markov(g.sigma, g.correlation_s, tau);
  return v;
}
}  // namespace allan

}  // namespace stend::model
