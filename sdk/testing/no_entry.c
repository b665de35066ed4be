/* A perfectly good shared library that is not a Stend plugin: no stend_plugin_entry. */
__attribute__((visibility("default"))) int stend_not_a_plugin(void);
int stend_not_a_plugin(void) { return 42; }
