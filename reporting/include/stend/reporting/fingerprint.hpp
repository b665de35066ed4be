// Procedure fingerprint: a hash of what was physically done to the unit, so that only results
// obtained the same way are compared.
//
// Normalized procedure = the resolved experiment's `procedure`, `bench.fixtures` and
// `bench.mounting`, canonicalized: mappings with sorted keys, YAML aliases expanded, numbers
// written in their shortest round-trip form (5, 5.0 and 5e0 are one number), and the purely
// descriptive keys `label` and `description` dropped. Sensor identity and configuration, the
// experiment name, seed, gravity site, outputs and estimation are not part of it.
// Fingerprint = lowercase hex SHA-256 of the canonical text.
#pragma once

#include <string>

namespace stend::reporting {

// Canonical text of the normalized procedure of an experiment YAML document. Throws InputError
// when the text is not YAML or has no `procedure`.
std::string canonical_procedure(const std::string& experiment_yaml);
// SHA-256 (FIPS 180-4) of bytes, lowercase hex.
std::string sha256_hex(const std::string& bytes);
// sha256_hex(canonical_procedure(experiment_yaml)).
std::string procedure_fingerprint(const std::string& experiment_yaml);

}  // namespace stend::reporting
