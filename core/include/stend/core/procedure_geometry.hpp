// The table steps of a procedure (orientations and rates on a declared table) as what they do to
// the sensor — for a recording made elsewhere, which Stend aligns to observed steps
// (stend/alignment/align.hpp): each orientation becomes the sensor direction it turns up (a face),
// each rates step the axis it turns about in the sensor frame (rate legs). The geometry is the
// fixtures' own: a bench of the declared fixtures with no sensor is commanded step by step and
// its truth read (Bench::at), so axis order, zero positions, stacking and the mounting are those
// of a bench run. Only simulated fixtures (sim_*) may describe a table elsewhere: a real plugin
// would talk to its device.
#pragma once

#include <stend/core/bench.hpp>
#include <stend/core/experiment.hpp>
#include <stend/core/plugin_host.hpp>

namespace stend {

// `exp` with its orientations and rates steps replaced by faces and rate legs, and a record step
// by the one face the table holds then (labels and record times kept; every other step as it is). The resolved YAML stays the original's (the
// procedure fingerprint is the file's). Throws ExperimentError at a step or fixture that cannot be
// turned into what the sensor saw.
Experiment as_observed_procedure(const Experiment& exp, const PluginHost& host);

// An experiment file read as the procedure of a log made elsewhere (no sensor needed): loaded with
// the plugins of the default search path (the fixtures it may declare; its own plugin_paths are not
// loaded) and turned into observed steps (as_observed_procedure) — what `stend import --experiment`
// aligns a log to.
Experiment load_observed_procedure(const std::string& file);

}  // namespace stend
