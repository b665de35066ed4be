// Steps every importer shares (defined in importers.cpp): the recording skeleton, the import
// event, the sample-interval statistics and gap flags, number formatting for messages.
#pragma once

#include <stend/recording.hpp>

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace stend::io::detail {

// Median of the intervals between consecutive samples [s]; 0 with fewer than two samples.
double median_interval(const std::vector<ImuSample>& s);
// Flags samples that follow an interval longer than 1.5 periods; returns how many.
std::size_t flag_time_gaps(std::vector<ImuSample>& s, double rate_hz);
// "%.6g".
std::string fmt_g(double v);
// Header of an imported recording: status complete, experiment "import:<format>", clock "wall".
Recording new_recording(const std::filesystem::path& file, const std::string& format);
// The "info" event (source "import") at the first sample's time.
void add_import_event(Recording& rec, const std::string& message);

}  // namespace stend::io::detail
