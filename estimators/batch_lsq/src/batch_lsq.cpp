// The paper's batch least-squares procedure on a recording. See stend/batch_lsq/batch_lsq.hpp.
#include "stend/batch_lsq/batch_lsq.hpp"

#include "stend/estimation/summary.hpp"

#include <exception>
#include <utility>

namespace stend::batch_lsq {

Eigen::VectorXd FitResult::theta_full() const {
  Eigen::VectorXd t = Eigen::VectorXd::Constant(spec.model.size(), kNaN);
  if (!ok()) return t;
  for (std::size_t j = 0; j < param_index.size(); ++j)
    t[param_index[j]] = lsq.estimate[static_cast<Eigen::Index>(j)];
  return t;
}

FitResult fit_points(const std::vector<processing::StaticPoint>& points, const ModelSpec& spec) {
  FitResult fr;
  static_cast<estimation::StaticFit&>(fr) = estimation::fit_static_points(points, spec);
  fr.spec = spec;
  fr.points = points;
  return fr;
}

FitResult fit_recording(const Recording& rec, const ModelSpec& spec) {
  processing::Extraction ex;
  FitResult fr;
  try {
    ex = estimation::extract_static_points(rec, spec);
  } catch (const std::exception& e) {
    fr.spec = spec;
    fr.message = e.what();
  }
  if (fr.message.empty()) {
    ModelSpec used = spec;
    used.processing = ex.options;
    fr = fit_points(ex.points, used);
    if (!fr.ok() && ex.points.empty())
      fr.message = "no usable static segment in the recording (" + ex.tally() + "); " + fr.message;
    fr.notes.insert(fr.notes.begin(), ex.notes.begin(), ex.notes.end());
  }
  fr.extracted = true;
  fr.recording_dir = rec.dir.string();
  fr.experiment_name = rec.header.experiment_name;
  fr.recording_status = to_string(rec.header.status);
  if (!rec.complete())
    fr.notes.push_back("the recording's status is '" + fr.recording_status +
                       "', not 'complete': it may be truncated");
  const processing::StaticExtractionSettings& x = fr.spec.processing.extraction;
  if (x.filter == processing::Filter::kButterworth && x.settle_s < 1.0 / x.cutoff_hz)
    fr.notes.push_back("settle_s = " + estimation::number_text(x.settle_s) +
                       " s is shorter than 1/cutoff_hz = " + estimation::number_text(1.0 / x.cutoff_hz) +
                       " s: the filter's edge transients may reach the averaged window");
  return fr;
}

}  // namespace stend::batch_lsq
