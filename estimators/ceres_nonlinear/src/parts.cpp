// A model-file fit as its parts (see parts.hpp).
#include "parts.hpp"
#include "report.hpp"

#include <utility>
#include <vector>

namespace stend::ceres_nonlinear::detail {

CalibrationResult not_applicable_part(model::ErrorModel model, const std::string& why) {
  CalibrationResult r;
  r.status = estimation::FitStatus::kNotApplicable;
  r.message = why;
  r.model = std::move(model);
  return r;
}

namespace {

std::vector<const CalibrationResult*> parts_of(const ModelFileFit& f) {
  std::vector<const CalibrationResult*> parts;
  if (f.has_accel) parts.push_back(&f.accel);
  if (f.has_gyro) parts.push_back(&f.gyro);
  return parts;
}

}  // namespace

void conclude(ModelFileFit& f) {
  std::vector<estimation::FitStatus> statuses;
  f.notes.clear();
  for (const CalibrationResult* p : parts_of(f)) {
    statuses.push_back(p->status);
    if (p->status == estimation::FitStatus::kNotApplicable)
      f.notes.push_back(std::string(p->is_gyroscope() ? "gyroscope" : "accelerometer") + ": " +
                        estimation::status_text(p->status) + " — " + p->message);
  }
  if (f.has_accel && f.accel.ok())
    if (const std::string caveat = norm_check_caveat(f.accel); !caveat.empty())
      f.notes.push_back("accelerometer: the calibrated RMS of |a| - g over the intervals is " + caveat);
  f.status = estimation::combined_status(statuses);
  if (f.status == estimation::FitStatus::kNotApplicable && f.message.empty())
    for (const auto& n : f.notes) f.message += (f.message.empty() ? "" : "; ") + n;
}

std::string status_line(const ModelFileFit& f) {
  std::string s = std::string("ceres_nonlinear: ") + estimation::status_text(f.status);
  if (!f.ok()) s += " — " + f.message;
  s += "\n";
  if (f.ok())
    for (const auto& n : f.notes) s += "note: " + n + "\n";
  return s;
}

}  // namespace stend::ceres_nonlinear::detail
