// The typed result of an estimator (see stend/estimation/result.hpp).
#include "stend/estimation/result.hpp"

#include <ostream>
#include <sstream>

namespace stend::estimation {

namespace {

template <class T>
bool same_optional(const std::optional<T>& a, const std::optional<T>& b, double rel_tol, double abs_tol) {
  if (a.has_value() != b.has_value()) return false;
  return !a || a->equals(*b, rel_tol, abs_tol);
}

}  // namespace

const InstrumentModel* FitResult::instrument(model::Instrument i) const {
  const auto& m = i == model::Instrument::kAccelerometer ? accelerometer : gyroscope;
  return m ? &*m : nullptr;
}

std::string FitResult::written_document() const { return document_text.empty() ? document.dump(2) : document_text; }

std::string FitResult::FullReport() const {
  std::ostringstream os;
  print(os);
  return os.str();
}

void FitResult::print(std::ostream& os) const {
  summary.print(os);
  for (const auto* m : {&accelerometer, &gyroscope})
    if (*m) os << **m;
  if (noise) os << *noise;
}

std::ostream& operator<<(std::ostream& os, const FitResult& r) {
  r.print(os);
  return os;
}

bool FitResult::equals(const FitResult& o, double rel_tol, double abs_tol) const {
  return summary.equals(o.summary, rel_tol, abs_tol) && same_optional(accelerometer, o.accelerometer, rel_tol, abs_tol) &&
         same_optional(gyroscope, o.gyroscope, rel_tol, abs_tol) && same_optional(noise, o.noise, rel_tol, abs_tol);
}

}  // namespace stend::estimation
