// Internal to the exports (exports.hpp): one function per format, each in its own file
// (export_<format>.cpp), writing from the run's typed results (export_sources.hpp).
#pragma once

#include "export_sources.hpp"

#include <filesystem>

namespace stend::reporting::detail {

ExportResult export_kalibr(const RunData& run, const std::filesystem::path& out, const ExportOptions& o);
ExportResult export_imutk(const RunData& run, const std::filesystem::path& prefix, const ExportOptions& o);
ExportResult export_px4(const RunData& run, const std::filesystem::path& out, const ExportOptions& o);
ExportResult export_matlab(const RunData& run, const std::filesystem::path& out, const ExportOptions& o);

}  // namespace stend::reporting::detail
