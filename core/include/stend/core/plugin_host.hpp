// The plugin host: finds plugin shared libraries on the search path, checks their ABI, and
// creates sensors, fixtures and estimators from them.
#pragma once

#include <stend/core/experiment.hpp>
#include <stend/sdk.hpp>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace stend {

struct SearchDir {
  std::string path;
  std::string origin;  // "experiment", "STEND_PLUGIN_PATH", "build tree", "install prefix",
                       // "next to the program"
};

// One file the host looked at.
struct PluginRecord {
  std::string file;
  std::string origin;                        // SearchDir::origin it was found through
  const stend_plugin_info* info = nullptr;   // null when refused
  std::string refusal;                       // why it was refused (empty when loaded)
  std::string shadowed_by;                   // set when an earlier file had the same name
};

class PluginHost : public PluginCatalogue {
 public:
  // Search order: `extra` (e.g. the experiment's plugin_paths), then STEND_PLUGIN_PATH (':'-
  // separated), then `../lib/stend/plugins` next to the running program (its own tree: the install
  // prefix for an installed stend, relocated or not; the build tree for the build tree's), then
  // the configured install prefix's, then — only for a program with no plugin folder of its own
  // (a test or tool outside bin/) — the build tree's. The last three are listed only when they
  // exist; a directory reached twice is listed once. The first plugin of a name wins; later ones
  // are listed as shadowed.
  static std::vector<SearchDir> default_search_path(const std::vector<std::string>& extra = {});
  // One line per folder: its path, origin and number of plugin files (`stend --version`).
  static std::string describe_search_path(const std::vector<SearchDir>& dirs);

  PluginHost() = default;
  ~PluginHost() override;
  PluginHost(const PluginHost&) = delete;
  PluginHost& operator=(const PluginHost&) = delete;

  // Loads every `stend_*.so` found in `dirs` (non-recursive). Never throws for a bad file: it is
  // recorded as refused with the reason (no entry point, ABI version or struct size mismatch,
  // unresolved symbol / dlopen error, bad info fields, duplicate name).
  void scan(const std::vector<SearchDir>& dirs);
  // Loads one file explicitly (also used by tests). Returns its record.
  const PluginRecord& load(const std::string& file, const std::string& origin);
  // Lists the `stend_*.so` files in `dirs` without loading them (none of their code runs): each is
  // recorded as refused with `reason`, so `stend plugins`, create() and an experiment's "unknown
  // plugin" error name the file and why it was not loaded.
  void list_unloaded(const std::vector<SearchDir>& dirs, const std::string& reason);

  const std::vector<PluginRecord>& records() const { return records_; }
  const stend_plugin_info* find(const std::string& name) const override;
  std::vector<std::string> names() const override;
  // "FILE: REASON" for a refused file named after `name` (stend_<name>.so).
  std::string why_not_loaded(const std::string& name) const override;
  const PluginRecord* record_of(const std::string& name) const;
  // Every directory scan() was given, in order (for `stend plugins`).
  const std::vector<SearchDir>& search_path() const { return searched_; }

  // Create an object; throws InputError naming the plugin and its reason on failure,
  // or when the plugin is of another kind.
  PluginPtr<Sensor> create_sensor(const std::string& name, const Params& params) const;
  PluginPtr<Fixture> create_fixture(const std::string& name, const Params& params) const;
  PluginPtr<Estimator> create_estimator(const std::string& name, const Params& params) const;

  // Human-readable table for `stend plugins`.
  std::string describe() const;

 private:
  void* create(const std::string& name, stend_plugin_kind kind, const Params& params) const;
  std::vector<PluginRecord> records_;
  std::vector<SearchDir> searched_;
  std::vector<void*> handles_;  // dlopen handles, closed in the destructor
};

}  // namespace stend
