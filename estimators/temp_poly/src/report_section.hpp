// temp_poly's section of the run report (set as its registry entry's `report`).
#pragma once

#include <stend/estimation/report_section.hpp>
#include <stend/estimation/result.hpp>

namespace stend::temp_poly {

estimation::ReportSection report_section(const estimation::FitResult& result);

}  // namespace stend::temp_poly
