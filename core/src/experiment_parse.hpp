// The pieces of the experiment reader (experiment.hpp), one file each: the document (the file's
// text, its single YAML document, plugin_paths), the bench section, the procedure read and
// expanded, the resolved YAML written back. Stage 2 (the procedure against the fixtures' declared
// limits) is experiment_validate.cpp. Internal to stend_core.
#pragma once

#include <stend/core/experiment.hpp>
#include <stend/yaml/reader.hpp>

#include <cstddef>
#include <string>
#include <vector>

namespace stend::detail {

// Bounds on what one procedure expands into.
inline constexpr std::size_t kMaxOrientationsPerStep = 100000;
inline constexpr std::size_t kMaxSteps = 100000;

// Throws ExperimentError at `where` (key path `path`).
[[noreturn]] void fail(const SourceLocation& where, const std::string& path, const std::string& message,
                       const std::string& hint = {});

// --- the document (experiment_document.cpp) ---------------------------------------------------

// The whole text of experiment file `path`; ExperimentError when it is missing, a folder or
// unreadable.
std::string read_text_file(const std::string& path);
// The experiment's root mapping: the text's single YAML document (ExperimentError at the second
// one, at a syntax error, or for an empty file or one that is not a mapping).
YAML::Node load_root(const std::string& text, const std::string& file);
// `plugin_paths` (at key path `path`): each an existing folder, relative paths taken from the
// experiment file's folder, made absolute.
std::vector<std::string> resolve_plugin_paths(const YAML::Node& node, const std::string& file,
                                              const std::string& path);

// --- bench: (experiment_bench.cpp) ------------------------------------------------------------

// The bench section of `top` into exp: gravity, base heading, the sensor and fixtures (their
// plugins and configs checked against `catalogue`'s schemas), the mounting.
void read_bench(const yaml::MapReader& top, const PluginCatalogue& catalogue, Experiment& exp);
// The ids of exp.fixtures, in declaration order.
std::vector<std::string> fixture_ids(const Experiment& exp);

// --- procedure: (experiment_expand.cpp) -------------------------------------------------------

// The procedure section of `top`: every step read with its defaults and units, repeats expanded
// (each pass numbered in repeat_index), sweeps and grids expanded into orientations. Durations
// are bounded by exp.limits; step fixtures must be among exp.fixtures.
std::vector<Step> read_procedure(const yaml::MapReader& top, const Experiment& exp);

// The settings of the observed steps (experiment_observed_steps.cpp), read from their body.
void faces_settings(const yaml::MapReader& m, Step& s);
void turns_settings(const yaml::MapReader& m, Step& s);
void rate_legs_settings(const yaml::MapReader& m, Step& s);
void still_settings(const yaml::MapReader& m, Step& s);

// --- the resolved experiment (experiment_emit.cpp) --------------------------------------------

// The whole experiment as YAML, defaults filled in, repeats and sweeps expanded: what a run
// folder's experiment.yaml holds, and what reads back as the same experiment.
std::string emit_resolved(const Experiment& e, const PluginCatalogue& catalogue);

}  // namespace stend::detail
