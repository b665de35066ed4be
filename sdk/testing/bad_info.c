/* One source, many broken plugins: compiled once per STEND_TEST_CASE_* definition (see
 * CMakeLists.txt). Each returns an info struct with exactly one thing wrong, except the
 * "valid" cases (duplicates, silent create failure), which the host must accept. */
#include <stend/plugin_abi.h>

#include <stddef.h>

#define EXPORT __attribute__((visibility("default")))

#if defined(STEND_TEST_CASE_UNRESOLVED)
/* Exists nowhere: dlopen(RTLD_NOW) must fail on it. */
extern void stend_symbol_that_does_not_exist(void);
#endif

__attribute__((unused)) static void* create_nothing(const void* params, char* error, size_t error_size) {
  (void)params;
#if defined(STEND_TEST_CASE_UNRESOLVED)
  stend_symbol_that_does_not_exist();
#endif
#if !defined(STEND_TEST_CASE_SILENT_CREATE)
  if (error != NULL && error_size > 0) {
    const char* text = "test plugin creates nothing";
    size_t i = 0;
    for (; text[i] != '\0' && i + 1 < error_size; ++i) error[i] = text[i];
    error[i] = '\0';
  }
#else
  (void)error;
  (void)error_size;
#endif
  return NULL;
}

__attribute__((unused)) static void destroy_nothing(void* object) { (void)object; }

static const stend_param_spec kParams[] = {
    {"gain", "number", "1", "1.0", 0.0, 10.0, NULL, "a gain"},
#if defined(STEND_TEST_CASE_BAD_PARAM_TYPE)
    {"offset", "complex", "m/s^2", "0", -1.0, 1.0, NULL, "a type the host doesn't know"},
#elif defined(STEND_TEST_CASE_NULL_PARAM_KEY)
    {NULL, "number", "m/s^2", "0", -1.0, 1.0, NULL, "no key"},
#else
    {"offset", "vec3", "m/s^2", "[0, 0, 0]", -1.0, 1.0, NULL, "an offset"},
#endif
};

#ifndef STEND_TEST_NAME
#define STEND_TEST_NAME "test_broken"
#endif

static const stend_plugin_info kInfo = {
#if defined(STEND_TEST_CASE_BAD_ABI)
    999u,
#else
    STEND_PLUGIN_ABI_VERSION,
#endif
#if defined(STEND_TEST_CASE_BAD_SIZE)
    (uint32_t)(sizeof(stend_plugin_info) + 16u),
#else
    (uint32_t)sizeof(stend_plugin_info),
#endif
#if defined(STEND_TEST_CASE_BAD_KIND)
    (stend_plugin_kind)7,
#else
    STEND_KIND_SENSOR,
#endif
#if defined(STEND_TEST_CASE_BAD_NAME)
    "Bad-Name",
#elif defined(STEND_TEST_CASE_EMPTY_NAME)
    "",
#elif defined(STEND_TEST_CASE_NULL_NAME)
    NULL,
#else
    STEND_TEST_NAME,
#endif
#if defined(STEND_TEST_CASE_NULL_VERSION)
    NULL,
#else
    "0.0.1",
#endif
    "deliberately broken test plugin",
#if defined(STEND_TEST_CASE_NULL_PARAMS)
    NULL,
#else
    kParams,
#endif
    sizeof kParams / sizeof kParams[0],
#if defined(STEND_TEST_CASE_NULL_CREATE)
    NULL,
#else
    create_nothing,
#endif
#if defined(STEND_TEST_CASE_NULL_DESTROY)
    NULL,
#else
    destroy_nothing,
#endif
};

EXPORT const stend_plugin_info* stend_plugin_entry(void) {
#if defined(STEND_TEST_CASE_NULL_ENTRY)
  (void)kInfo;
  return NULL;
#else
  return &kInfo;
#endif
}
