/* Stend plugin ABI — the C entry point every plugin shared library exports.
 *
 * A plugin is a shared library exporting one symbol, STEND_PLUGIN_ENTRY_SYMBOL, of type
 * stend_plugin_entry_fn. The host calls it, checks abi_version and struct_size against its own,
 * and refuses the file (naming it and both versions) when they differ. Only then does it read the
 * rest of the struct. Everything reachable from the returned pointer must live as long as the
 * library stays loaded (static storage).
 *
 * Bump STEND_PLUGIN_ABI_VERSION on any change to this file or to the C++ interfaces in sdk.hpp.
 */
#ifndef STEND_PLUGIN_ABI_H
#define STEND_PLUGIN_ABI_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* 2: Fixture::observe() and stend::FixtureLinkFault added to sdk.hpp */
#define STEND_PLUGIN_ABI_VERSION 4u
#define STEND_PLUGIN_ENTRY_SYMBOL "stend_plugin_entry"

typedef enum stend_plugin_kind {
  STEND_KIND_SENSOR = 1,    /* factory returns stend::Sensor*    */
  STEND_KIND_FIXTURE = 2,   /* factory returns stend::Fixture*   */
  STEND_KIND_ESTIMATOR = 3  /* factory returns stend::Estimator* */
} stend_plugin_kind;

/* One configuration key the plugin accepts. The host validates the experiment's `config:` block
 * against these (type, range, unknown keys with "did you mean") and reports file:line:column,
 * so plugins never see malformed input.
 *   type: "number" | "integer" | "bool" | "string" | "vec3" | "mat3" | "numbers" | "matrix3"
 *         ("numbers" = list of any length; "matrix3" = 3 rows of equal, any length)
 *   unit: SI unit of the value ("m/s^2", "deg", "degC", "Hz", "s", "1" for dimensionless, "" n/a)
 *   default_yaml: YAML text of the default, or NULL when the key is required
 *   min/max: inclusive bounds applied to every element; NaN means unbounded
 *   choices: for strings, '|'-separated allowed values, or NULL for any */
typedef struct stend_param_spec {
  const char* key;
  const char* type;
  const char* unit;
  const char* default_yaml;
  double min;
  double max;
  const char* choices;
  const char* doc;
} stend_param_spec;

/* Creates one object. `params` points to a const stend::Params (validated, defaults filled).
 * On failure returns NULL and writes a human-readable reason into error[0..error_size). */
typedef void* (*stend_create_fn)(const void* params, char* error, size_t error_size);
typedef void (*stend_destroy_fn)(void* object);

typedef struct stend_plugin_info {
  uint32_t abi_version;  /* = STEND_PLUGIN_ABI_VERSION the plugin was built with      */
  uint32_t struct_size;  /* = sizeof(stend_plugin_info) the plugin was built with      */
  stend_plugin_kind kind;
  const char* name;        /* referenced as `plugin: NAME` in experiments; [a-z0-9_]+   */
  const char* version;     /* the plugin's own semantic version                         */
  const char* description; /* one line                                                  */
  const stend_param_spec* params; /* configuration schema                               */
  size_t param_count;
  stend_create_fn create;
  stend_destroy_fn destroy;
} stend_plugin_info;

typedef const stend_plugin_info* (*stend_plugin_entry_fn)(void);

#ifdef __cplusplus
}
#endif

#endif /* STEND_PLUGIN_ABI_H */
