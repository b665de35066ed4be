// The correlation of overlapping Allan variance estimates at two averaging factors. See
// stend/noise/edf.hpp (avar_correlation).
#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>
#include <vector>

#include "stend/noise/edf.hpp"

namespace stend::noise {

namespace {

double generalized_autocovariance(NoiseType type, long l) {
  const double a = std::abs(static_cast<double>(l));
  switch (type) {
    case NoiseType::kQuantization:
    case NoiseType::kFlickerPhase: return l == 0 ? 2.0 : (a == 1.0 ? -1.0 : 0.0);
    case NoiseType::kWhite: return l == 0 ? 1.0 : 0.0;
    case NoiseType::kRandomWalk: return -0.5 * a;
    case NoiseType::kFlicker: {
      if (a > 8.0) return -std::log(a) + 1.0 / (12.0 * a * a);  // the integral's expansion
      static const std::array<double, 9> near = [] {
        std::array<double, 9> g{};
        constexpr int kNodes = 2000;  // midpoint rule over u ∈ [−1, 1]
        for (int lag = 0; lag <= 8; ++lag) {
          double s = 0.0;
          for (int q = 0; q < kNodes; ++q) {
            const double u = -1.0 + (q + 0.5) * 2.0 / kNodes;
            s += (1.0 - std::abs(u)) * std::log(std::abs(lag + u));
          }
          g[static_cast<std::size_t>(lag)] = -s * 2.0 / kNodes;
        }
        return g;
      }();
      return near[static_cast<std::size_t>(a)];
    }
  }
  return 0.0;
}

// Σ_s w(s)·C12(s)² for d_m1 and d_m2 (m1 ≤ m2) of one noise type, w(s) the share of the pairs of
// second differences at lag s in a record of n samples (M_i = n + 1 − 2·m_i of them each:
// w(s) = #{i < M1 : 0 ≤ i + s < M2} / (M1·M2)); n = 0: a long record, w = 1. Each kernel is ±1/m
// on two boxes of m samples, so C12(s) is four box-box sums Σ_{t<n1} Σ_{u<n2} G(x + u − t), each
// four values of the second cumulative sum of G: O(1) per lag.
double avar_cross_moment(NoiseType type, long m1, long m2, long n = 0) {
  const long reach = (type == NoiseType::kFlicker ? 8 : 1) * 2 * (m1 + m2) + 2;  // C12 ≈ 0 beyond
  const long y0 = -(reach + 3 * m1 + 2 * m2 + 2), y1 = reach + 3 * m2 + 2;
  std::vector<long double> q(static_cast<std::size_t>(y1 - y0 + 2));
  long double p = 0.0L;  // q[y − y0] = Σ_{z<y} P(z), P(z) = Σ_{y0≤v<z} G(v)
  for (long y = y0; y <= y1; ++y) {
    q[static_cast<std::size_t>(y - y0 + 1)] = q[static_cast<std::size_t>(y - y0)] + p;
    p += generalized_autocovariance(type, y);
  }
  auto Q = [&](long y) { return q[static_cast<std::size_t>(y - y0)]; };
  auto box = [&](long x) { return Q(x + m2 + 1) - Q(x + m2 - m1 + 1) - Q(x + 1) + Q(x - m1 + 1); };
  const long M1 = n + 1 - 2 * m1, M2 = n + 1 - 2 * m2;
  auto weight = [&](long s) -> long double {
    if (n == 0) return 1.0L;
    const long pairs = std::min(M1, M2 - s) - std::max(0L, -s);
    return pairs > 0 ? static_cast<long double>(pairs) / (static_cast<long double>(M1) * M2) : 0.0L;
  };
  long double sum = 0.0L;
  for (long s = -reach; s <= reach; ++s) {
    const long double c = box(s) - box(s + m2) - box(s - m1) + box(s + m2 - m1);
    sum += weight(s) * c * c;
  }
  return static_cast<double>(sum / (static_cast<long double>(m1 * m1) * static_cast<long double>(m2 * m2)));
}

// The correlation in a record of n samples, computed directly (see avar_correlation).
double avar_correlation_finite(NoiseType type, long m1, long m2, long n) {
  // A fit asks for every pair of its points: each point's own moment is computed once (per thread).
  thread_local std::map<std::tuple<NoiseType, long, long>, double> own;
  auto self = [&](long m) {
    const auto key = std::make_tuple(type, m, n);
    auto it = own.find(key);
    if (it == own.end()) it = own.emplace(key, avar_cross_moment(type, m, m, n)).first;
    return it->second;
  };
  return avar_cross_moment(type, m1, m2, n) / std::sqrt(self(m1) * self(m2));
}

// compute_avar_correlation_table()'s output, kept so that no process pays its ≈ 0.15 s
// (noise_edf_test recomputes it).
constexpr AvarCorrelationTable kAvarCorrelation = {{
    {{  // random-walk FM: b = 0 … 3, k = 0 … 10
        {1, 0.71713716560063612, 0.48913049448252938, 0.34184226467778478,
         0.24097335021568247, 0.17026062025391145, 0.12036881620464548, 0.085109427374796112,
         0.060180714399358966, 0.04255406063319217, 0.030090241750778946},
        {1, 0.85833250775998859, 0.63923712243562658, 0.45819744198917312,
         0.32512944836444341, 0.23010541083599806, 0.16274549898936619, 0.11508490826244037,
         0.081378463827401756, 0.057543466197188892, 0.040689410991505734},
        {1, 0.88131956077162332, 0.66763728262811994, 0.48115848312786885,
         0.34193943396725462, 0.24209912931742167, 0.17124581247014198, 0.12109902540188346,
         0.085631707415702835, 0.06055107363830841, 0.042816130095250725},
        {1, 0.88614957451641962, 0.67398436028466846, 0.48637224678318408,
         0.34577337100662431, 0.24483787441056357, 0.17318745496252586, 0.12247288159512933,
         0.086603332099449828, 0.061238144724313485, 0.043301967799323646},
    }},
    {{  // flicker FM: b = 0 … 3, k = 0 … 10
        {1, 0.62709824921060753, 0.27455495333054336, 0.10616092478207638,
         0.039128338558412766, 0.014115382865266554, 0.0050402854153616082, 0.0017908063672161868,
         0.00063470133185199217, 0.00022467594202662299, 7.9483601472431713e-05},
        {1, 0.68269266637981774, 0.30554197157121171, 0.11935271764199243,
         0.044198732686013098, 0.015980358193906793, 0.0057124526287437791, 0.0020307152345217516,
         0.00071992150273455927, 0.0002548764039310284, 9.0173544400550565e-05},
        {1, 0.68871882207353607, 0.30896654176801364, 0.12080850389810641,
         0.044757955180706036, 0.016185981657252657, 0.0057865466660298043, 0.0020571570761030839,
         0.00072931333086110434, 0.00025820452153942319, 9.1351549558028682e-05},
        {1, 0.68935210467469887, 0.30933218927380662, 0.12096386540394009,
         0.044817568507844685, 0.016207877867244577, 0.005794430239828556, 0.0020599688899531035,
         0.00073031169233398092, 0.00025855822556385106, 9.1476728524041064e-05},
    }},
    {{  // white FM: b = 0 … 3, k = 0 … 10
        {1, 0.46291004988627571, 0.18057877962865379, 0.065653216429861272,
         0.023380488239570611, 0.0082813545958943663, 0.002929240567456325, 0.0010357614385940422,
         0.00036620744509030441, 0.0001294748099338323, 4.5776339902683341e-05},
        {1, 0.50155039131781753, 0.18234920215644923, 0.064938377864070682,
         0.0230011336146684, 0.0081358493832606599, 0.002876786275259093, 0.0010171266400528704,
         0.00035961114435291831, 0.00012714196672777356, 4.4951493518165608e-05},
        {1, 0.52164541887041027, 0.18576888147064513, 0.065799223890344927,
         0.023274182224040374, 0.0082296076089801631, 0.0029096889151147146, 0.0010287377395021471,
         0.00036371436620169224, 0.00012859250486336554, 4.5464321180357541e-05},
        {1, 0.52804146359215431, 0.18703196257213767, 0.066156038342916876,
         0.023392368044815377, 0.0082706876478546628, 0.0029241505752675601, 0.0010338451991432308,
         0.00036551963890552112, 0.00012923072210613125, 4.5689961246002537e-05},
    }},
    {{  // white PM (and flicker PM): b = 0 … 3, k = 0 … 10
        {1, 0.40000000000000002, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423},
        {1, 0.40000000000000002, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423},
        {1, 0.40000000000000002, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423},
        {1, 0.40000000000000002, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423, 0.51428571428571423,
         0.51428571428571423, 0.51428571428571423, 0.51428571428571423},
    }},
}};

}  // namespace

std::size_t avar_correlation_row(NoiseType type) {
  return static_cast<std::size_t>(std::min(alpha_of(type) + 2, 3));
}

AvarCorrelationTable compute_avar_correlation_table() {
  AvarCorrelationTable t{};
  for (const NoiseType type : {NoiseType::kRandomWalk, NoiseType::kFlicker, NoiseType::kWhite, NoiseType::kQuantization}) {
    std::array<double, kAvarCorrelationBase + kAvarCorrelationOctaves + 1> self{};
    for (std::size_t j = 0; j < self.size(); ++j) self[j] = avar_cross_moment(type, 1L << j, 1L << j);
    for (int b = 0; b <= kAvarCorrelationBase; ++b) {
      for (int k = 0; k <= kAvarCorrelationOctaves; ++k) {
        t[avar_correlation_row(type)][b][k] = avar_cross_moment(type, 1L << b, 1L << (b + k)) /
            std::sqrt(self[static_cast<std::size_t>(b)] * self[static_cast<std::size_t>(b + k)]);
      }
    }
  }
  return t;
}

const AvarCorrelationTable& avar_correlation_table() { return kAvarCorrelation; }

double avar_correlation(NoiseType type, double m1, double m2, double n_samples) {
  const AvarCorrelationTable& tables = kAvarCorrelation;
  if (m1 > m2) std::swap(m1, m2);
  const int k = static_cast<int>(std::lround(std::log2(m2 / m1)));
  if (k > kAvarCorrelationOctaves) return 0.0;
  if (n_samples > 0.0 && m2 * kAvarCorrelationFiniteRecord > n_samples && k <= kAvarCorrelationFiniteOctaves) {
    // Near the record's length: direct, scaled so that m1 is at most 2^kAvarCorrelationBase.
    const double scale = std::min(1.0, std::ldexp(1.0, kAvarCorrelationBase) / m1);
    const long a = std::lround(m1 * scale), b = std::lround(m2 * scale), n = std::lround(n_samples * scale);
    if (n + 1 > 2 * b) return avar_correlation_finite(type, a, b, n);
  }
  const int b = std::clamp(static_cast<int>(std::lround(std::log2(m1))), 0, kAvarCorrelationBase);
  return tables[avar_correlation_row(type)][static_cast<std::size_t>(b)][static_cast<std::size_t>(k)];
}

}  // namespace stend::noise
