// The estimators' model files: each input is read by every model-file parser (batch_lsq's linear
// model spec, ceres_nonlinear's options, temp_poly's options), as `stend fit --model` would for
// the estimator that claims it. A parser either returns or throws a std::exception with the reason.
#include <stend/ceres_nonlinear/model_file.hpp>
#include <stend/estimation/model_spec.hpp>
#include <stend/temp_poly/temp_poly.hpp>

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <exception>
#include <string>

#include "fuzz_support.hpp"

namespace {

template <class F>
void refused_or_read(F&& parse) {
  try {
    parse();
  } catch (const std::exception&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > stend::fuzz::kMaxInputBytes) return 0;
  const std::string text(reinterpret_cast<const char*>(data), size);
  refused_or_read([&] {
    const auto spec = stend::estimation::parse_model_spec(text, "fuzz.yaml");
    (void)stend::estimation::parse_model_spec(stend::estimation::to_yaml(spec), "round-trip.yaml");
  });
  refused_or_read([&] {
    const auto o = stend::ceres_nonlinear::options_from_yaml(YAML::Load(text), "fuzz.yaml");
    (void)stend::ceres_nonlinear::describe_options(o);
  });
  refused_or_read([&] { (void)stend::temp_poly::parse_options(text, "fuzz.yaml"); });
  return 0;
}
