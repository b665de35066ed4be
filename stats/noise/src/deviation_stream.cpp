// All deviations of one signal in one streaming pass. See stend/noise/deviations.hpp.
#include "stend/noise/deviations.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <numbers>
#include <stdexcept>

#include "kernels.hpp"
#include "noise_identification.hpp"
#include "stend/noise/edf.hpp"

namespace stend::noise {

const char* to_string(DeviationKind k) {
  switch (k) {
    case DeviationKind::kAdev: return "adev";
    case DeviationKind::kOadev: return "oadev";
    case DeviationKind::kMdev: return "mdev";
    case DeviationKind::kTdev: return "tdev";
    case DeviationKind::kHdev: return "hdev";
    case DeviationKind::kOhdev: return "ohdev";
    case DeviationKind::kTotdev: return "totdev";
  }
  return "?";
}

double deviation_edf(DeviationKind kind, int alpha, double m, double n_phase) {
  switch (kind) {
    case DeviationKind::kAdev: return edf_greenhall(alpha, 2, m, n_phase, false, false);
    case DeviationKind::kOadev: return edf_greenhall(alpha, 2, m, n_phase, true, false);
    case DeviationKind::kMdev:
    case DeviationKind::kTdev: return edf_greenhall(alpha, 2, m, n_phase, true, true);
    case DeviationKind::kHdev: return edf_greenhall(alpha, 3, m, n_phase, false, false);
    case DeviationKind::kOhdev: return edf_greenhall(alpha, 3, m, n_phase, true, false);
    case DeviationKind::kTotdev: return edf_totdev(alpha, m, n_phase);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

std::uint64_t stop_ratio(DeviationKind kind) {
  switch (kind) {
    case DeviationKind::kAdev:
    case DeviationKind::kHdev: return 5;
    case DeviationKind::kTotdev: return 2;
    default: return 4;
  }
}

bool DeviationOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* w) {
    if (why) *why = w;
    return false;
  };
  if (max_m == 0) return fail("max_m must be ≥ 1");
  if (!(tau0_s > 0.0) || !std::isfinite(tau0_s)) return fail("tau0_s must be > 0");
  if (!(confidence > 0.0 && confidence < 1.0)) return fail("confidence must be in (0, 1)");
  for (auto m : factors) {
    if (m == 0 || m > max_m) return fail("every factor must be in [1, max_m]");
  }
  return true;
}

std::vector<std::uint64_t> all_factors(std::uint64_t max_m) {
  std::vector<std::uint64_t> out(max_m);
  for (std::uint64_t m = 1; m <= max_m; ++m) out[m - 1] = m;
  return out;
}

std::vector<std::uint64_t> log_factors(std::uint64_t max_m, int per_decade) {
  std::vector<std::uint64_t> out;
  for (int i = 0;; ++i) {
    const auto m = static_cast<std::uint64_t>(std::llround(std::pow(10.0, i / double(per_decade))));
    if (m > max_m) break;
    if (out.empty() || out.back() != m) out.push_back(m);
  }
  return out;
}

class DeviationStream::State {
 public:
  explicit State(DeviationOptions options) : opt_(std::move(options)) {
    std::string why;
    if (!opt_.IsValid(&why)) throw std::invalid_argument("DeviationOptions: " + why);
    if (opt_.factors.empty()) {
      for (std::uint64_t m = 1; m <= opt_.max_m; m *= 2) opt_.factors.push_back(m);
    }
    std::sort(opt_.factors.begin(), opt_.factors.end());
    opt_.factors.erase(std::unique(opt_.factors.begin(), opt_.factors.end()), opt_.factors.end());
    per_m_.resize(opt_.factors.size());
    std::uint64_t generic_max = 0;  // largest factor that is not a power of two
    for (std::size_t i = 0; i < opt_.factors.size(); ++i) {
      const std::uint64_t m = opt_.factors[i];
      if (!std::has_single_bit(m)) {
        generic_max = m;
        continue;
      }
      const auto l = static_cast<std::size_t>(std::countr_zero(m));
      if (levels_.size() <= l) levels_.resize(l + 1);
      levels_[l].factor = static_cast<int>(i);
    }
    for (std::size_t l = 0; l < levels_.size(); ++l) {
      Level& L = levels_[l];
      L.ring = ((std::size_t{2} << l) + kSubBlock + 7) / 8 * 8;  // k ≡ ring position mod 8
      L.v.assign(L.ring, 0.0);
    }
    // History: lags up to 3m for the factors outside the pyramid (and one point for its first
    // difference); the first and the last 2m + 1 points for TOTDEV's ends.
    keep_ = 3 * generic_max + 1;
    block_ = std::max<std::size_t>(keep_, 8192);
    hist_.resize(keep_ + block_);
    head_cap_ = 2 * opt_.factors.back() + 1;
    tail_.assign(head_cap_, 0.0);
  }


  void add_phase(const double* x, std::size_t n) {
    for (std::size_t i = 0; i < n;) {
      const std::size_t take = std::min(n - i, hist_.size() - fill_);
      std::memcpy(hist_.data() + fill_, x + i, take * sizeof(double));
      push_head(x + i, take);
      fill_ += take;
      i += take;
      if (fill_ == hist_.size()) process();
    }
  }

  void add_rate(const double* y, std::size_t n) {
    std::array<double, 1024> x;
    for (std::size_t i = 0; i < n;) {
      const std::size_t take = std::min<std::size_t>(n - i, x.size());
      std::size_t j = 0;
      if (!rate_started_) {
        rate_offset_ = y[i];
        rate_started_ = true;
        x[j++] = 0.0;  // x_0
      }
      const std::size_t now = std::min(take, x.size() - j);  // room after x_0
      integrate(y + i, now, x.data() + j);
      add_phase(x.data(), j + now);
      i += now;
    }
  }

  std::uint64_t phase_points() const { return count_ + (fill_ - done_); }
  std::size_t state_bytes() const {
    std::size_t bytes = sizeof(DeviationStream) + sizeof(*this) +
                        (hist_.size() + head_.capacity() + tail_.size()) * sizeof(double) +
                        per_m_.size() * sizeof(PerM);
    for (const Level& L : levels_) bytes += L.v.size() * sizeof(double);
    return bytes;
  }
  const DeviationOptions& options() const { return opt_; }


  std::vector<DeviationPoint> result(DeviationKind kind) {
    process();
    std::vector<DeviationPoint> out;
    const std::uint64_t N = count_;
    const double tau0 = opt_.tau0_s;
    for (std::size_t i = 0; i < opt_.factors.size(); ++i) {
      const std::uint64_t m = opt_.factors[i];
      const PerM& s = per_m_[i];
      const long double tau = static_cast<long double>(m) * tau0;
      DeviationPoint p;
      p.m = m;
      p.tau_s = static_cast<double>(tau);
      long double var = 0;
      switch (kind) {
        case DeviationKind::kAdev:
          p.terms = s.adev_terms;
          var = s.adev / (2 * tau * tau * p.terms);
          break;
        case DeviationKind::kOadev:
          p.terms = N >= 2 * m + 1 ? N - 2 * m : 0;
          var = s.oadev / (2 * tau * tau * p.terms);
          break;
        case DeviationKind::kMdev:
        case DeviationKind::kTdev:
          p.terms = N + 1 >= 3 * m + 1 ? N + 1 - 3 * m : 0;
          var = s.mdev / (2 * static_cast<long double>(m) * m * tau * tau * p.terms);
          if (kind == DeviationKind::kTdev) var *= tau * tau / 3;
          break;
        case DeviationKind::kHdev:
          p.terms = s.hdev_terms;
          var = s.hdev / (6 * tau * tau * p.terms);
          break;
        case DeviationKind::kOhdev:
          p.terms = N >= 3 * m + 1 ? N - 3 * m : 0;
          var = s.ohdev / (6 * tau * tau * p.terms);
          break;
        case DeviationKind::kTotdev:
          p.terms = (N >= 3 && 2 * m <= N - 1) ? N - 2 : 0;
          if (p.terms) var = (s.oadev + total_ends(m)) / (2 * tau * tau * p.terms);
          break;
      }
      if (p.terms == 0 || m * stop_ratio(kind) > N) continue;
      p.dev = static_cast<double>(std::sqrt(var));
      p.alpha = alpha(i, kind);
      p.edf = deviation_edf(kind, p.alpha, static_cast<double>(m), static_cast<double>(N));
      const auto ci = deviation_interval(p.dev, p.edf, opt_.confidence);
      p.lo = ci.lo;
      p.hi = ci.hi;
      out.push_back(p);
    }
    return out;
  }

 private:
  // x[t] = τ0 · (Σ (y − y_0) so far, through y[t]); the sum carried in long double.
  void integrate(const double* y, std::size_t n, double* x) {
    const std::size_t n8 = n / 8 * 8;
    const double total = detail::prefix_scan8(y, x, n8, static_cast<double>(phase_), rate_offset_);
    long double run = phase_ + static_cast<long double>(total);
    for (std::size_t t = n8; t < n; ++t) {
      run += static_cast<long double>(y[t] - rate_offset_);
      x[t] = static_cast<double>(run);
    }
    phase_ = run;
    if (opt_.tau0_s != 1.0) {
      for (std::size_t t = 0; t < n; ++t) x[t] *= opt_.tau0_s;
    }
  }

  struct PerM {
    long double oadev = 0, adev = 0, mdev = 0, ohdev = 0, hdev = 0;
    std::uint64_t adev_terms = 0, hdev_terms = 0;
    double window = 0;                  // Σ of the last m d2 (MDEV window)
    std::array<noise_id::Lag1, 4> acf;  // decimated phase differenced 0 … 3 times
    std::array<double, 3> prev{};       // last decimated values of differences 0 … 2
  };

  // Phase points k … k + n − 1 into the ring of the last head_cap_ points (TOTDEV's end).
  void push_tail(const double* x, std::uint64_t k, std::size_t n) {
    const std::size_t T = tail_.size();
    if (n > T) {
      x += n - T;
      k += n - T;
      n = T;
    }
    const auto at = static_cast<std::size_t>(k % T);
    const std::size_t first = std::min(n, T - at);
    std::memcpy(tail_.data() + at, x, first * sizeof(double));
    std::memcpy(tail_.data(), x + first, (n - first) * sizeof(double));
  }

  void push_head(const double* x, std::size_t n) {
    const std::size_t take = std::min(n, head_cap_ - std::min(head_cap_, head_.size()));
    head_.insert(head_.end(), x, x + take);
  }

  // Accumulates every phase point in hist_[done_, fill_) (global index count_ + i − done_),
  // then keeps the last keep_ points.
  void process() {
    const std::uint64_t base = count_ - done_;  // global index of hist_[0]
    const double* h = hist_.data();
    // Sub-blocks of kSubBlock points, every factor on each, so the newest points stay in cache.
    // Sub-blocks end at global multiples of kSubBlock, so the vector kernels start at k ≡ 0 mod 8.
    for (std::size_t from = done_, to = 0; from < fill_; from = to) {
      to = std::min<std::size_t>(fill_, (base + from) / kSubBlock * kSubBlock + kSubBlock - base);
      push_tail(h + from, base + from, to - from);
      if (!levels_.empty()) pyramid(h, base, from, to);
      for (std::size_t i = 0; i < opt_.factors.size(); ++i) {
        const std::uint64_t m = opt_.factors[i];
        if (std::has_single_bit(m)) {
          decimate(m, per_m_[i], h, base, from, to);
        } else {
          accumulate(m, per_m_[i], h, base, from, to);
        }
      }
    }
    count_ += fill_ - done_;
    done_ = fill_;
    if (fill_ > keep_) {
      std::memmove(hist_.data(), hist_.data() + fill_ - keep_, keep_ * sizeof(double));
      done_ = fill_ = keep_;
    }
  }

  // Points k = base + [from, to) of one factor m that is not a power of two (h[j] = x_{base+j}).
  static void accumulate(std::uint64_t m, PerM& s, const double* h, std::uint64_t base,
                         std::size_t from, std::size_t to) {
    const std::size_t M = static_cast<std::size_t>(m);
    // Startup (k < 3m) point by point.
    std::size_t j = from;
    for (; j < to && base + j < 3 * m; ++j) {
      const std::uint64_t k = base + j;
      if (k < 2 * m) continue;
      const double d2 = h[j] - 2 * h[j - M] + h[j - 2 * M];
      s.oadev += static_cast<long double>(d2) * d2;
      if (k % m == 0) {
        s.adev += static_cast<long double>(d2) * d2;
        ++s.adev_terms;
      }
      s.window += d2;
      if (k == 3 * m - 1) s.mdev += static_cast<long double>(s.window) * s.window;
    }
    // Steady state (k ≥ 3m), in vector kernels: Σ d2², Σ d3², and the MDEV window as a running
    // sum of d3 (adding d3_k = d2_k − d2_{k−m} slides the window of the last m d2 by one).
    if (j < to) {
      const std::size_t n = to - j;
      double sums[3] = {0, 0, 0};
      s.window = detail::steady_sums(h + j, h + j - M, h + j - 2 * M, h + j - 3 * M, n,
                                     s.window, sums);
      s.oadev += sums[0];
      s.ohdev += sums[1];
      s.mdev += sums[2];
    }
    // Non-overlapped terms and the decimated phase for noise identification.
    const std::uint64_t k0 = base + from;
    const std::uint64_t first = (k0 + m - 1) / m * m;
    decimate(m, s, h, base, from, to);
    // Local sums and count (members would be stored back on every step: s may alias h).
    double a2 = 0, h2 = 0;
    std::uint64_t terms = 0;
    for (std::uint64_t k = std::max(first, 3 * m); k < base + to; k += m) {
      const std::size_t t = static_cast<std::size_t>(k - base);
      const double d2 = h[t] - 2 * h[t - M] + h[t - 2 * M];
      const double d3 = d2 - (h[t - M] - 2 * h[t - 2 * M] + h[t - 3 * M]);
      a2 += d2 * d2;
      h2 += d3 * d3;
      ++terms;
    }
    s.adev += a2;
    s.hdev += h2;
    s.adev_terms += terms;
    s.hdev_terms += terms;
  }

  // The decimated phase x_k, k ≡ 0 mod m, of points k = base + [from, to) for noise
  // identification, while fewer than kNoiseIdPoints are in.
  static void decimate(std::uint64_t m, PerM& s, const double* h, std::uint64_t base,
                       std::size_t from, std::size_t to) {
    if (s.acf[0].n >= kNoiseIdPoints) return;
    for (std::uint64_t k = (base + from + m - 1) / m * m; k < base + to; k += m) {
      add_decimated(s, h[k - base]);
    }
  }

  // Octave factors m = 2^l share one pyramid: level l holds, for every k ≥ 2m − 1,
  //   V^m_k = Σ_{j=k−m+1}^{k} (x_j − x_{j−m})   (the MDEV window of phase differences),
  // in a ring buffer of the last 2m + kSubBlock points. Every kind follows from V alone:
  //   d2_k(m) = V_k − V_{k−1},   MDEV's Σ_{j=k−m+1}^{k} d2_j = e_k = V_k − V_{k−m},
  //   d3_k(m) = d2_k − d2_{k−m} = e_k − e_{k−1},
  // and the next level from this one: V^{2m}_k = V_k + 2V_{k−m} + V_{k−2m} (V^1 is the first
  // difference of the phase). A level reads its own ring at lags 1, m and 2m and writes the
  // next one: a few vector operations per point, no running sums, no lag of 3m.
  struct Level {
    detail::AlignedDoubles v;  // V^m at ring position k mod ring
    std::size_t ring = 0;
    int factor = -1;           // index into factors, −1 for a level only passed through
  };

  // Points k = base + [from, to) (h[j] = x_{base+j}) through every level.
  void pyramid(const double* h, std::uint64_t base, std::size_t from, std::size_t to) {
    Level& first = levels_[0];
    if (base + from == 0) {
      first.v[0] = 0.0;  // x_{−1} does not exist
      if (to - from >= 2) step_ = (h[to - 1] - h[from]) / static_cast<double>(to - from - 1);
    }
    for (std::size_t j = base + from == 0 ? from + 1 : from; j < to;) {
      const auto at = static_cast<std::size_t>((base + j) % first.ring);
      const std::size_t n = std::min(to - j, first.ring - at);
      double* out = first.v.data() + at;
      for (std::size_t t = 0; t < n; ++t) out[t] = (h[j + t] - h[j + t - 1]) - step_;
      j += n;
    }
    for (std::size_t l = 0; l < levels_.size(); ++l) run_level(l, base + from, base + to);
  }

  // Level l at points [k0, k1): sums into its factor's PerM, the next level's V written.
  void run_level(std::size_t l, std::uint64_t k0, std::uint64_t k1) {
    const std::uint64_t m = std::uint64_t{1} << l;
    Level& L = levels_[l];
    Level* next = l + 1 < levels_.size() ? &levels_[l + 1] : nullptr;
    PerM scratch;
    PerM& s = L.factor >= 0 ? per_m_[static_cast<std::size_t>(L.factor)] : scratch;
    const double* V = L.v.data();
    const std::size_t R = L.ring;
    auto at = [R](std::uint64_t k) { return static_cast<std::size_t>(k % R); };
    const std::uint64_t steady = 4 * m;  // from here every term of every kind is defined
    // Startup (k < 4m < 2R) point by point, each term from where it is defined.
    auto at_early = [R](std::uint64_t k) { return static_cast<std::size_t>(k >= R ? k - R : k); };
    for (std::uint64_t k = k0; k < std::min(k1, steady); ++k) {
      const bool decimated = k % m == 0;
      if (k >= 2 * m) {
        const double d2 = V[at_early(k)] - V[at_early(k - 1)];
        s.oadev += static_cast<long double>(d2) * d2;
        if (decimated) {
          s.adev += static_cast<long double>(d2) * d2;
          ++s.adev_terms;
        }
      }
      if (k + 1 >= 3 * m) {
        const double e = V[at_early(k)] - V[at_early(k - m)];
        s.mdev += static_cast<long double>(e) * e;
        if (k >= 3 * m) {
          const double d3 = e - (V[at_early(k - 1)] - V[at_early(k - m - 1)]);
          s.ohdev += static_cast<long double>(d3) * d3;
          if (decimated) {
            s.hdev += static_cast<long double>(d3) * d3;
            ++s.hdev_terms;
          }
        }
      }
      if (next) {  // k < 4m: no wrap in the next ring (4m + kSubBlock)
        next->v[k] =
            k + 1 >= 4 * m ? (V[at_early(k)] + V[at_early(k - 2 * m)]) + 2.0 * V[at_early(k - m)] : 0.0;
      }
    }
    // Steady state in vector kernels, split where a ring wraps.
    double sums[5] = {0, 0, 0, 0, 0};
    const bool masked = m > 1 && m <= 8;  // non-overlapped terms inside the kernel
    std::uint64_t masked_terms = 0;
    const std::uint64_t k_steady = std::max(k0, steady);
    for (std::uint64_t k = k_steady; k < k1;) {
      const std::size_t i0 = at(k), i1 = at(k - 1), iq = at(k - m), iq1 = at(k - m - 1),
                        ir = at(k - 2 * m);
      std::size_t n = static_cast<std::size_t>(k1 - k);
      n = std::min({n, R - i0, R - i1, R - iq, R - iq1, R - ir});
      double* vn = nullptr;
      if (next) {
        const std::size_t io = static_cast<std::size_t>(k % next->ring);
        n = std::min(n, next->ring - io);
        vn = next->v.data() + io;
      }
      std::array<double, 8> mask{};
      if (masked) {
        for (std::size_t u = 0; u < 8; ++u) mask[u] = (k + u) % m == 0 ? 1.0 : 0.0;
        masked_terms += (k + n - 1) / m - (k - 1) / m;
      }
      const double *v = V + i0, *v1 = V + i1, *q = V + iq, *q1 = V + iq1, *r = V + ir;
      if (masked && next) {
        detail::level_sums<true, true>(v, v1, q, q1, r, vn, n, mask.data(), sums);
      } else if (masked) {
        detail::level_sums<true, false>(v, v1, q, q1, r, vn, n, mask.data(), sums);
      } else if (next) {
        detail::level_sums<false, true>(v, v1, q, q1, r, vn, n, mask.data(), sums);
      } else {
        detail::level_sums<false, false>(v, v1, q, q1, r, vn, n, mask.data(), sums);
      }
      k += n;
    }
    s.oadev += sums[0];
    s.ohdev += sums[1];
    s.mdev += sums[2];
    if (k1 > k_steady) {
      if (m == 1) {  // every difference is a non-overlapped one as well
        sums[3] = sums[0];
        sums[4] = sums[1];
        masked_terms = k1 - k_steady;
      } else if (!masked) {
        nonoverlapped(V, R, m, k_steady, k1, sums + 3, &masked_terms);
      }
      s.adev += sums[3];
      s.hdev += sums[4];
      s.adev_terms += masked_terms;
      s.hdev_terms += masked_terms;
    }
  }

  // Σ d2², Σ d3² over k ≡ 0 mod m in [k0, k1) (k0 ≥ 3m) from level m's ring V of size R;
  // counts them.
  static void nonoverlapped(const double* V, std::size_t R, std::uint64_t m, std::uint64_t k0,
                            std::uint64_t k1, double* sums, std::uint64_t* terms) {
    const std::uint64_t first = (k0 + m - 1) / m * m;
    if (first >= k1) return;
    const auto M = static_cast<std::size_t>(m);
    auto wrap = [R](std::size_t i) { return i >= R ? i - R : i; };
    std::size_t i0 = first % R, i1 = (first - 1) % R, iq = (first - m) % R,
                iq1 = (first - m - 1) % R;
    double a2 = 0, h2 = 0;
    std::uint64_t n = 0;
    for (std::uint64_t k = first; k < k1; k += m) {
      const double d2 = V[i0] - V[i1];
      const double d3 = d2 - (V[iq] - V[iq1]);
      a2 += d2 * d2;
      h2 += d3 * d3;
      ++n;
      i0 = wrap(i0 + M);
      i1 = wrap(i1 + M);
      iq = wrap(iq + M);
      iq1 = wrap(iq1 + M);
    }
    sums[0] += a2;
    sums[1] += h2;
    *terms += n;
  }

  static constexpr std::size_t kSubBlock = 4096;
  // Decimated points used for noise identification per factor: the lag-1 autocorrelation of
  // 2^16 points has a standard error ≈ 1/256, far below the 0.25 steps that decide the type.
  static constexpr std::uint64_t kNoiseIdPoints = 1u << 16;

  static void add_decimated(PerM& s, double z) {
    double v = z;
    for (std::size_t d = 0; d < 4; ++d) {
      const std::uint64_t n = s.acf[d].n;
      s.acf[d].add(v);
      if (d == 3) break;
      const double prev = s.prev[d];
      s.prev[d] = v;
      if (n == 0) break;  // the next difference needs two values
      v = v - prev;
    }
  }

  // Noise type at factor index i for `kind` (Hadamard kinds may difference once more).
  int alpha(std::size_t i, DeviationKind kind) const {
    const PerM& s = per_m_[i];
    const int dmax = (kind == DeviationKind::kHdev || kind == DeviationKind::kOhdev) ? 3 : 2;
    if (s.acf[0].n >= opt_.acf_min_points) {
      std::array<double, 4> r1{};
      for (std::size_t d = 0; d < 4; ++d) r1[d] = s.acf[d].r1();
      return noise_id::from_acf(r1, dmax);
    }
    // B1: sample variance of the m-averages (first differences of the decimated phase / τ)
    // over their non-overlapped Allan variance; R(n) from MVAR/AVAR of the same record.
    const double n = static_cast<double>(s.acf[1].n);
    const double m = static_cast<double>(opt_.factors[i]);
    if (s.acf[1].n < opt_.b1_min_averages || s.adev_terms == 0) {
      return i > 0 ? alpha(i - 1, kind) : 0;  // too few averages: the type found at the shorter τ
    }
    const double avar = static_cast<double>(s.adev / (2.0L * s.adev_terms));
    const double b1 = s.acf[1].variance() / avar;
    const std::uint64_t N = count_;
    double rn = 1.0;
    if (N + 1 >= 3 * opt_.factors[i] + 1 && N >= 2 * opt_.factors[i] + 1) {
      const long double mvar = s.mdev / (m * m * static_cast<long double>(N + 1 - 3 * opt_.factors[i]));
      const long double oavar = s.oadev / static_cast<long double>(N - 2 * opt_.factors[i]);
      rn = static_cast<double>(mvar / oavar);
    }
    return noise_id::from_b1(b1, rn, n, m);
  }

  // TOTDEV: squared centred differences at the centres c ∈ [1, N−2] within m of either end
  // (those not in the OADEV sum), on the reflected record.
  long double total_ends(std::uint64_t m) const {
    const auto N = static_cast<std::int64_t>(count_);
    const auto mm = static_cast<std::int64_t>(m);
    auto x = [&](std::int64_t i) -> double {
      if (i < static_cast<std::int64_t>(head_.size())) return head_[static_cast<std::size_t>(i)];
      return tail_[static_cast<std::size_t>(i) % tail_.size()];
    };
    auto xs = [&](std::int64_t i) -> double {
      if (i < 0) return 2 * x(0) - x(-i);
      if (i > N - 1) return 2 * x(N - 1) - x(2 * (N - 1) - i);
      return x(i);
    };
    long double sum = 0;
    for (std::int64_t c = 1; c <= N - 2; ++c) {
      if (c >= mm && c + mm <= N - 1) {
        c = std::max(c, N - 1 - mm);  // jump over the centres of the OADEV sum
        continue;
      }
      const double d = xs(c - mm) - 2 * x(c) + xs(c + mm);
      sum += static_cast<long double>(d) * d;
    }
    return sum;
  }

  DeviationOptions opt_;
  std::size_t keep_ = 0, head_cap_ = 0, block_ = 0;
  std::vector<double> hist_;  // phase x_{count_ − done_ + j} at j < fill_
  std::size_t fill_ = 0, done_ = 0;
  std::uint64_t count_ = 0;   // phase points accumulated
  std::vector<double> head_;  // the first 2·max factor + 1 phase points
  std::vector<double> tail_;  // the last ones, x_k at k mod tail_.size()
  std::vector<PerM> per_m_;
  std::vector<Level> levels_;  // the octave pyramid, level l for m = 2^l
  // Mean phase step of the first sub-block, taken off every step entering the pyramid: a
  // linear phase cancels in every kind, and without it V^m grows as m² × the mean rate, whose
  // rounding the differences V_k − V_{k−1} would then carry.
  double step_ = 0.0;
  bool rate_started_ = false;
  double rate_offset_ = 0.0;
  long double phase_ = 0.0L;
};

DeviationStream::DeviationStream(DeviationOptions options) : state_(std::make_unique<State>(std::move(options))) {}
DeviationStream::~DeviationStream() = default;
DeviationStream::DeviationStream(DeviationStream&&) noexcept = default;
DeviationStream& DeviationStream::operator=(DeviationStream&&) noexcept = default;

void DeviationStream::add_phase(const double* x, std::size_t n) { state_->add_phase(x, n); }
void DeviationStream::add_rate(const double* y, std::size_t n) { state_->add_rate(y, n); }
std::uint64_t DeviationStream::phase_points() const { return state_->phase_points(); }
std::size_t DeviationStream::state_bytes() const { return state_->state_bytes(); }
const DeviationOptions& DeviationStream::options() const { return state_->options(); }
std::vector<DeviationPoint> DeviationStream::result(DeviationKind kind) { return state_->result(kind); }

}  // namespace stend::noise
