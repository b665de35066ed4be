// run.json: the run's header as JSON, both ways (the writer's text, the reader's checked fields).
// Internal to stend_recording.
#pragma once

#include "stend/recording/recording.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <filesystem>
#include <string>

namespace stend::detail {

// The header as run.json states it (format_version, status, names, site, sensor, plugins, truth
// columns), in that order.
nlohmann::ordered_json header_json(const RecordingHeader& h);
// The text of a run.json document: indented, invalid UTF-8 (e.g. raw bytes read from a device
// into a serial number) replaced rather than thrown, ending in a line feed.
std::string dump_json(const nlohmann::ordered_json& j);

// The header from run.json's text (`file` names where the text came from in errors). Returns the
// parsed JSON, for the counts the writer recorded at finish. Throws InputError naming the file
// (and line, for a syntax error) and the key that is wrong.
nlohmann::json read_run_json(const std::filesystem::path& file, const std::string& text, RecordingHeader& h);

}  // namespace stend::detail
