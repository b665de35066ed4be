// The plugin host: search path, loading and checking plugin libraries, creating objects.
//
// Nothing a plugin file contains may take the host down: every problem becomes a refusal naming
// the file. (A plugin whose entry point or static initialisers crash can still crash the process;
// that is outside what an in-process host can guard against.)
#include <stend/core/plugin_host.hpp>

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <set>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <type_traits>
#include <utility>

namespace stend {
namespace {

namespace fs = std::filesystem;

#ifndef STEND_BUILD_PLUGIN_DIR
#define STEND_BUILD_PLUGIN_DIR ""
#endif
#ifndef STEND_PLUGIN_DIR_FROM_BIN
#define STEND_PLUGIN_DIR_FROM_BIN "../lib/stend/plugins"
#endif
#ifndef STEND_INSTALL_PLUGIN_DIR
#define STEND_INSTALL_PLUGIN_DIR ""
#endif

constexpr const char* kFilePrefix = "stend_";
constexpr const char* kFileSuffix = ".so";
constexpr std::size_t kMaxNameLength = 128;
constexpr const char* kParamTypes[] = {"number", "integer", "bool",    "string",
                                       "vec3",   "mat3",    "numbers", "matrix3"};

const char* kind_word(long kind) {
  switch (kind) {
    case STEND_KIND_SENSOR: return "sensor";
    case STEND_KIND_FIXTURE: return "fixture";
    case STEND_KIND_ESTIMATOR: return "estimator";
    default: return "unknown";
  }
}

std::string with_article(const char* word) {
  return std::string(std::strchr("aeiou", word[0]) ? "an " : "a ") + word;
}

// The kind field read without trusting it to hold a valid enumerator.
long raw_kind(const stend_plugin_info& info) {
  std::underlying_type_t<stend_plugin_kind> raw{};
  static_assert(sizeof raw == sizeof info.kind);
  std::memcpy(&raw, &info.kind, sizeof raw);
  return static_cast<long>(raw);
}

bool is_dir(const std::string& path) {
  std::error_code ec;
  return !path.empty() && fs::is_directory(path, ec);
}

// Identity of a file or directory for de-duplication: canonical when possible.
std::string identity_of(const std::string& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::path(path), ec);
  if (ec) p = fs::absolute(fs::path(path), ec).lexically_normal();
  return p.string();
}

bool matches_plugin_file_name(const std::string& name) {
  const std::size_t np = std::strlen(kFilePrefix), ns = std::strlen(kFileSuffix);
  return name.size() > np + ns && name.compare(0, np, kFilePrefix) == 0 &&
         name.compare(name.size() - ns, ns, kFileSuffix) == 0;
}

std::string program_plugin_dir() {
  std::error_code ec;
  fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec || exe.empty()) return {};
  return (exe.parent_path() / STEND_PLUGIN_DIR_FROM_BIN).lexically_normal().string();
}

// Checks everything after abi_version and struct_size. Returns the reason, or "" when fine.
std::string check_fields(const stend_plugin_info& info) {
  std::ostringstream why;
  const long kind = raw_kind(info);
  if (kind < STEND_KIND_SENSOR || kind > STEND_KIND_ESTIMATOR) {
    why << "field 'kind' is " << kind << "; expected 1 (sensor), 2 (fixture) or 3 (estimator)";
    return why.str();
  }
  if (info.name == nullptr) return "field 'name' is null";
  const std::size_t name_length = ::strnlen(info.name, kMaxNameLength + 1);
  if (name_length == 0) return "field 'name' is empty";
  if (name_length > kMaxNameLength) {
    why << "field 'name' is longer than " << kMaxNameLength << " characters";
    return why.str();
  }
  const std::string name(info.name, name_length);
  for (char c : name) {
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) {
      why << "field 'name' is '" << name
          << "': a plugin name may contain only lower-case letters, digits and '_'";
      return why.str();
    }
  }
  if (info.version == nullptr) return "field 'version' is null";
  if (info.create == nullptr) return "field 'create' is null";
  if (info.destroy == nullptr) return "field 'destroy' is null";
  if (info.params == nullptr && info.param_count > 0) {
    why << "field 'params' is null but 'param_count' is " << info.param_count;
    return why.str();
  }
  std::set<std::string> keys;
  for (std::size_t i = 0; i < info.param_count; ++i) {
    const stend_param_spec& spec = info.params[i];
    if (spec.key == nullptr || spec.key[0] == '\0') {
      why << "field 'params[" << i << "].key' is " << (spec.key ? "empty" : "null");
      return why.str();
    }
    if (!keys.insert(spec.key).second) {
      why << "field 'params[" << i << "].key': '" << spec.key << "' is declared twice";
      return why.str();
    }
    if (spec.type == nullptr) {
      why << "field 'params[" << i << "].type' of '" << spec.key << "' is null";
      return why.str();
    }
    const bool known = std::any_of(std::begin(kParamTypes), std::end(kParamTypes),
                                   [&](const char* t) { return std::strcmp(t, spec.type) == 0; });
    if (!known) {
      why << "field 'params[" << i << "].type' of '" << spec.key << "' is '" << spec.type
          << "'; expected one of";
      const char* sep = " ";
      for (const char* t : kParamTypes) {
        why << sep << t;
        sep = ", ";
      }
      return why.str();
    }
  }
  return {};
}

std::string pad(const std::string& s, std::size_t width) {
  return s.size() >= width ? s : s + std::string(width - s.size(), ' ');
}

}  // namespace

// ---------------------------------------------------------------------------------------------

namespace {
std::vector<std::string> plugin_files_in(const std::string& dir);
}  // namespace

std::vector<SearchDir> PluginHost::default_search_path(const std::vector<std::string>& extra) {
  std::vector<SearchDir> dirs;
  std::set<std::string> seen;
  auto add = [&](const std::string& path, const char* origin, bool only_if_exists) {
    if (path.empty()) return;
    if (only_if_exists && !is_dir(path)) return;
    if (!seen.insert(identity_of(path)).second) return;
    dirs.push_back({path, origin});
  };
  for (const auto& dir : extra) add(dir, "experiment", false);
  if (const char* env = std::getenv("STEND_PLUGIN_PATH")) {
    std::string list(env);
    std::size_t begin = 0;
    while (begin <= list.size()) {
      std::size_t end = list.find(':', begin);
      if (end == std::string::npos) end = list.size();
      add(list.substr(begin, end - begin), "STEND_PLUGIN_PATH", false);
      begin = end + 1;
    }
  }
  // The running program's own tree first: an installed stend loads the installed plugins, the
  // build tree's stend the build tree's. The build tree is searched by a program of no Stend tree
  // only (a test or tool outside bin/), never by an installed one.
  const std::string own = program_plugin_dir();
  const bool own_is_build = is_dir(own) && is_dir(STEND_BUILD_PLUGIN_DIR) && identity_of(own) == identity_of(STEND_BUILD_PLUGIN_DIR);
  if (own_is_build) add(STEND_BUILD_PLUGIN_DIR, "build tree", true);
  else add(own, "next to the program", true);
  add(STEND_INSTALL_PLUGIN_DIR, "install prefix", true);
  if (!is_dir(own)) add(STEND_BUILD_PLUGIN_DIR, "build tree", true);
  return dirs;
}

std::string PluginHost::describe_search_path(const std::vector<SearchDir>& dirs) {
  std::ostringstream out;
  for (const auto& d : dirs)
    out << d.path << " (" << d.origin << ", " << plugin_files_in(d.path).size() << " plugin file(s))\n";
  return out.str();
}

PluginHost::~PluginHost() {
  for (auto it = handles_.rbegin(); it != handles_.rend(); ++it) ::dlclose(*it);
}

namespace {
// The plugin files of one directory (non-recursive), sorted; none when it is not a directory.
std::vector<std::string> plugin_files_in(const std::string& dir) {
  std::vector<std::string> files;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return files;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::error_code type_ec;
    if (matches_plugin_file_name(name) && it->is_regular_file(type_ec)) files.push_back(it->path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}
}  // namespace

void PluginHost::scan(const std::vector<SearchDir>& dirs) {
  for (const auto& dir : dirs) {
    searched_.push_back(dir);
    for (const auto& file : plugin_files_in(dir.path)) load(file, dir.origin);
  }
}

void PluginHost::list_unloaded(const std::vector<SearchDir>& dirs, const std::string& reason) {
  for (const auto& dir : dirs) {
    searched_.push_back(dir);
    for (const auto& file : plugin_files_in(dir.path)) {
      const std::string identity = identity_of(file);
      if (std::any_of(records_.begin(), records_.end(), [&](const PluginRecord& r) { return identity_of(r.file) == identity; }))
        continue;
      PluginRecord record;
      record.file = file;
      record.origin = dir.origin;
      record.refusal = reason;
      records_.push_back(std::move(record));
    }
  }
}

std::string PluginHost::why_not_loaded(const std::string& name) const {
  const std::string expected_file = kFilePrefix + name + kFileSuffix;
  for (const auto& r : records_)
    if (r.info == nullptr && fs::path(r.file).filename() == expected_file) return r.file + ": " + r.refusal;
  return {};
}

const PluginRecord& PluginHost::load(const std::string& file, const std::string& origin) {
  // The same file reached twice (two search entries, a symlink) is one plugin.
  const std::string identity = identity_of(file);
  for (const auto& r : records_) {
    if (identity_of(r.file) == identity) return r;
  }

  PluginRecord record;
  record.file = file;
  record.origin = origin;
  auto refuse = [&](const std::string& reason) -> const PluginRecord& {
    record.info = nullptr;
    record.refusal = file + ": " + reason;
    records_.push_back(std::move(record));
    return records_.back();
  };

  // A bare name would make dlopen search the library path instead of opening this file.
  const std::string open_path = file.find('/') == std::string::npos ? "./" + file : file;
  ::dlerror();
  void* handle = ::dlopen(open_path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* err = ::dlerror();
    std::string text = err ? err : "dlopen failed";
    for (const std::string& prefix : {open_path + ": ", file + ": "}) {
      if (text.compare(0, prefix.size(), prefix) == 0) {
        text.erase(0, prefix.size());
        break;
      }
    }
    return refuse("cannot load: " + text);
  }
  auto close_and_refuse = [&](const std::string& reason) -> const PluginRecord& {
    ::dlclose(handle);
    return refuse(reason);
  };

  ::dlerror();
  void* symbol = ::dlsym(handle, STEND_PLUGIN_ENTRY_SYMBOL);
  if (symbol == nullptr) {
    return close_and_refuse(std::string("no entry point '") + STEND_PLUGIN_ENTRY_SYMBOL +
                            "' (not a Stend plugin?)");
  }
  stend_plugin_entry_fn entry = nullptr;
  static_assert(sizeof entry == sizeof symbol);
  std::memcpy(&entry, &symbol, sizeof entry);

  const stend_plugin_info* info = nullptr;
  try {
    info = entry();
  } catch (const std::exception& e) {
    return close_and_refuse(std::string("entry point '") + STEND_PLUGIN_ENTRY_SYMBOL +
                            "' threw: " + e.what());
  } catch (...) {
    return close_and_refuse(std::string("entry point '") + STEND_PLUGIN_ENTRY_SYMBOL +
                            "' threw an unknown exception");
  }
  if (info == nullptr) {
    return close_and_refuse(std::string("entry point '") + STEND_PLUGIN_ENTRY_SYMBOL +
                            "' returned null");
  }
  if (info->abi_version != STEND_PLUGIN_ABI_VERSION) {
    std::ostringstream why;
    why << "plugin ABI " << info->abi_version << ", host ABI " << STEND_PLUGIN_ABI_VERSION
        << ": rebuild the plugin against this Stend's SDK";
    return close_and_refuse(why.str());
  }
  if (info->struct_size != sizeof(stend_plugin_info)) {
    std::ostringstream why;
    why << "plugin info struct is " << info->struct_size << " bytes, host expects "
        << sizeof(stend_plugin_info)
        << " (field 'struct_size'): rebuild the plugin against this Stend's SDK";
    return close_and_refuse(why.str());
  }
  if (std::string why = check_fields(*info); !why.empty()) return close_and_refuse(why);

  handles_.push_back(handle);
  record.info = info;
  for (const auto& r : records_) {
    if (r.info != nullptr && r.shadowed_by.empty() && std::strcmp(r.info->name, info->name) == 0) {
      record.shadowed_by = r.file;
      break;
    }
  }
  records_.push_back(std::move(record));
  return records_.back();
}

const PluginRecord* PluginHost::record_of(const std::string& name) const {
  for (const auto& r : records_) {
    if (r.info != nullptr && r.shadowed_by.empty() && name == r.info->name) return &r;
  }
  return nullptr;
}

const stend_plugin_info* PluginHost::find(const std::string& name) const {
  const PluginRecord* r = record_of(name);
  return r ? r->info : nullptr;
}

std::vector<std::string> PluginHost::names() const {
  std::vector<std::string> out;
  for (const auto& r : records_) {
    if (r.info != nullptr && r.shadowed_by.empty()) out.emplace_back(r.info->name);
  }
  std::sort(out.begin(), out.end());
  return out;
}

void* PluginHost::create(const std::string& name, stend_plugin_kind kind,
                         const Params& params) const {
  const PluginRecord* r = record_of(name);
  if (r == nullptr) {
    std::ostringstream msg;
    msg << "no plugin named '" << name << "'";
    // A refused file that was probably meant to provide it says more than "not found".
    if (const std::string why = why_not_loaded(name); !why.empty()) msg << " (" << why << ")";
    const auto loaded = names();
    msg << "; loaded plugins: ";
    if (loaded.empty()) msg << "none";
    for (std::size_t i = 0; i < loaded.size(); ++i) msg << (i ? ", " : "") << loaded[i];
    msg << " (run `stend plugins` to see the search path and refused files)";
    throw InputError(msg.str());
  }
  const stend_plugin_info& info = *r->info;
  const long actual = raw_kind(info);
  if (actual != kind) {
    throw InputError("plugin '" + name + "' (" + r->file + ") is " +
                     with_article(kind_word(actual)) + " plugin, not " +
                     with_article(kind_word(kind)));
  }
  char error[1024] = {};
  void* object = nullptr;
  std::string reason;
  try {
    object = info.create(&params, error, sizeof error);
    error[sizeof error - 1] = '\0';
    reason = error;
  } catch (const std::exception& e) {
    reason = e.what();
  } catch (...) {
    reason = "unknown exception";
  }
  if (object == nullptr) {
    if (reason.empty()) reason = "no reason given";
    throw InputError("plugin '" + name + "' (" + r->file + ") could not create " +
                     with_article(kind_word(kind)) + ": " + reason);
  }
  return object;
}

namespace {
// The deleter keeps the plugin library loaded until the object is gone, so an object may outlive
// the host that created it.
template <class T>
PluginPtr<T> own(void* object, const PluginRecord& record) {
  stend_destroy_fn destroy = record.info->destroy;
  void* pin = ::dlopen(record.file.find('/') == std::string::npos ? ("./" + record.file).c_str()
                                                                   : record.file.c_str(),
                       RTLD_NOW | RTLD_LOCAL | RTLD_NOLOAD);
  return PluginPtr<T>(static_cast<T*>(object), [destroy, pin](T* p) {
    if (p != nullptr) destroy(static_cast<void*>(p));
    if (pin != nullptr) ::dlclose(pin);
  });
}
}  // namespace

PluginPtr<Sensor> PluginHost::create_sensor(const std::string& name, const Params& params) const {
  void* object = create(name, STEND_KIND_SENSOR, params);
  return own<Sensor>(object, *record_of(name));
}

PluginPtr<Fixture> PluginHost::create_fixture(const std::string& name,
                                              const Params& params) const {
  void* object = create(name, STEND_KIND_FIXTURE, params);
  return own<Fixture>(object, *record_of(name));
}

PluginPtr<Estimator> PluginHost::create_estimator(const std::string& name,
                                                  const Params& params) const {
  void* object = create(name, STEND_KIND_ESTIMATOR, params);
  return own<Estimator>(object, *record_of(name));
}

// ---------------------------------------------------------------------------------------------

std::string PluginHost::describe() const {
  std::ostringstream out;

  std::vector<const PluginRecord*> loaded, refused, shadowed;
  for (const auto& r : records_) {
    if (r.info == nullptr) {
      refused.push_back(&r);
    } else if (!r.shadowed_by.empty()) {
      shadowed.push_back(&r);
    } else {
      loaded.push_back(&r);
    }
  }
  std::stable_sort(loaded.begin(), loaded.end(), [](const PluginRecord* a, const PluginRecord* b) {
    const long ka = raw_kind(*a->info), kb = raw_kind(*b->info);
    return ka != kb ? ka < kb : std::strcmp(a->info->name, b->info->name) < 0;
  });

  out << "Plugins (" << loaded.size() << " loaded):\n";
  if (loaded.empty()) {
    out << "  none\n";
  } else {
    const std::vector<std::string> head = {"KIND", "NAME", "VERSION", "FILE", "ORIGIN",
                                           "DESCRIPTION"};
    std::vector<std::vector<std::string>> rows;
    for (const auto* r : loaded) {
      rows.push_back({kind_word(raw_kind(*r->info)), r->info->name, r->info->version, r->file,
                      r->origin, r->info->description ? r->info->description : ""});
    }
    std::vector<std::size_t> width(head.size());
    for (std::size_t c = 0; c < head.size(); ++c) {
      width[c] = head[c].size();
      for (const auto& row : rows) width[c] = std::max(width[c], row[c].size());
    }
    auto line = [&](const std::vector<std::string>& cells) {
      std::string text = " ";
      for (std::size_t c = 0; c < cells.size(); ++c) {
        text += ' ';
        text += c + 1 < cells.size() ? pad(cells[c], width[c] + 1) : cells[c];
      }
      while (!text.empty() && text.back() == ' ') text.pop_back();
      out << text << '\n';
    };
    line(head);
    for (const auto& row : rows) line(row);
  }

  out << "\nRefused (" << refused.size() << "):\n";
  if (refused.empty()) out << "  none\n";
  for (const auto* r : refused) out << "  " << r->refusal << "  [" << r->origin << "]\n";

  out << "\nShadowed (" << shadowed.size() << "):\n";
  if (shadowed.empty()) out << "  none\n";
  for (const auto* r : shadowed) {
    out << "  " << r->info->name << " " << r->info->version << "  " << r->file << "  ["
        << r->origin << "]  shadowed by " << r->shadowed_by << "\n";
  }

  out << "\nSearch path (first match of a name wins):\n";
  if (searched_.empty()) out << "  none\n";
  std::size_t path_width = 0;
  for (const auto& d : searched_) path_width = std::max(path_width, d.path.size());
  for (std::size_t i = 0; i < searched_.size(); ++i) {
    const auto& d = searched_[i];
    out << "  " << (i + 1) << ". " << pad(d.path, path_width) << "  " << d.origin
        << (is_dir(d.path) ? "" : "  (does not exist)") << "\n";
  }
  return out.str();
}

}  // namespace stend
