// Internal: the run report's overview of the recording itself — the raw accelerometer, gyroscope
// and temperature over the whole run, read a chunk at a time and reduced to time bins, with the
// segments shaded.
#pragma once

#include "stend/estimation/report_section.hpp"

#include <filesystem>

namespace stend::reporting::detail {

// The section of the run folder `dir`; a paragraph instead of plots when the samples cannot be
// read. `temperature_recorded` is set to whether the recording has a (finite) temperature.
estimation::ReportSection overview_section(const std::filesystem::path& dir, bool& temperature_recorded);

}  // namespace stend::reporting::detail
