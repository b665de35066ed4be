// The deviations a model file asks for, per channel of a recording: the `deviations` and `tau`
// keys of the `allan:` mapping, one DeviationStream pass per channel, a "deviations" JSON member
// and a compact text table.
//
//   allan:
//     deviations: [oadev, mdev, hdev, ohdev, totdev, tdev]   # any of adev oadev mdev tdev hdev ohdev totdev
//     tau: octave                                            # octave | log (10 per decade) | all
//
// Each kind is reported at every factor m ≤ min(max_m, N/2) up to N / its Stable32 stop ratio,
// τ = m / rate, with the identified noise type α, EDF and the interval at the `confidence` of the
// allan options. Values are in the channel's signal unit (TDEV: signal unit × s).
#pragma once

#include <stend/allan/allan.hpp>
#include <stend/noise/deviations.hpp>

#include <nlohmann/json_fwd.hpp>

#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

namespace YAML {
class Node;
}

namespace stend::allan {

// The deviations of one signal (stend/noise/deviations.hpp), under allan's names.
using noise::all_factors;
using noise::deviation_edf;
using noise::DeviationKind;
using noise::DeviationOptions;
using noise::DeviationPoint;
using noise::DeviationStream;
using noise::kAllDeviationKinds;
using noise::log_factors;
using noise::stop_ratio;
using noise::to_string;  // its DeviationKind overload

enum class TauSpacing { kOctave, kLog, kAll };
const char* to_string(TauSpacing t);
inline constexpr int kLogFactorsPerDecade = 10;

struct DeviationRequest {
  std::vector<DeviationKind> kinds;  // empty: no deviations are computed
  TauSpacing tau = TauSpacing::kOctave;

  bool empty() const { return kinds.empty(); }
  bool IsValid(std::string* why = nullptr) const;  // no kind twice
};

// True for the keys of the allan mapping that deviations_from_yaml reads.
bool is_deviation_key(const std::string& key);
// The request from the allan mapping (null: empty). Throws InputError naming file:line:column for an unknown kind, a kind given twice, a non-list or an unknown spacing.
DeviationRequest deviations_from_yaml(const YAML::Node& allan, const std::string& file = {});

// The averaging factors of `spacing` for `samples` rate samples and the cap max_m.
std::vector<std::uint64_t> deviation_factors(TauSpacing spacing, std::uint64_t samples, std::uint64_t max_m);

struct ChannelDeviations {
  ChannelInfo channel;  // name and signal unit
  double rate_hz = 0.0;
  std::uint64_t samples = 0;
  double confidence = stats::kOneSigma;
  std::vector<std::pair<DeviationKind, std::vector<DeviationPoint>>> kinds;
};

// One channel's rate samples y[0 … n) at rate_hz.
ChannelDeviations channel_deviations(const double* y, std::size_t n, double rate_hz, const ChannelInfo& channel,
                                     const DeviationRequest& request, const AllanOptions& options = {});
// One channel's phase (time-error) points x[0 … n) taken 1/rate_hz apart — the n − 1 rate samples
// between them (Stable32's phase data), without differencing and integrating again.
ChannelDeviations phase_deviations(const double* x, std::size_t n, double rate_hz, const ChannelInfo& channel,
                                   const DeviationRequest& request, const AllanOptions& options = {});
// Every channel of `report` (its rate, time window and channel names) read again from the
// recording's sample source.
std::vector<ChannelDeviations> recording_deviations(const Recording& recording, const AllanReport& report,
                                                    const DeviationRequest& request,
                                                    const AllanOptions& options = {});

// doc["deviations"] = [{channel, unit, rate_hz, samples, confidence, tau_spacing,
//   kinds: {oadev: [{tau_s, m, terms, value, edf, lo, hi, alpha}, …], …}}, …] (NaN → null).
void add_deviations_json(nlohmann::json& doc, const std::vector<ChannelDeviations>& channels,
                         TauSpacing spacing);
// One block per channel: a row per τ, a column per kind (value, and α/EDF of the first kind).
void write_deviation_table(std::ostream& os, const std::vector<ChannelDeviations>& channels);

}  // namespace stend::allan
