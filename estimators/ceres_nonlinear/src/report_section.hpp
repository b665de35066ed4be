// ceres_nonlinear's section of the run report (set as its registry entry's `report`).
#pragma once

#include <stend/estimation/report_section.hpp>
#include <stend/estimation/result.hpp>

namespace stend::ceres_nonlinear {

estimation::ReportSection report_section(const estimation::FitResult& result);

}  // namespace stend::ceres_nonlinear
