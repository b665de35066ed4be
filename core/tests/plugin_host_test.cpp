// The plugin host: search path, every refusal case (each with its own broken plugin built under
// sdk/testing/), creating objects, `stend plugins` output, and the out-of-tree workflow a
// researcher follows (install Stend, build sdk/template_sensor against it, load it).
#include <stend/core/experiment.hpp>
#include <stend/core/plugin_host.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/program.hpp>

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>
#include <yaml-cpp/yaml.h>

namespace {

namespace fs = std::filesystem;
using stend::PluginHost;
using stend::PluginRecord;
using stend::testing::read_text;
using stend::testing::shell_quote;
using stend::testing::TempDir;
using stend::testing::write_text;

// Like EXPECT_THAT(text, HasSubstr(part)), without depending on gmock.
testing::AssertionResult Contains(const char* text_expr, const char* part_expr,
                                  const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return testing::AssertionSuccess();
  return testing::AssertionFailure() << text_expr << " does not contain " << part_expr
                                     << "\n  text: " << text << "\n  part: " << part;
}
#define EXPECT_CONTAINS(text, part) EXPECT_PRED_FORMAT2(Contains, text, part)

const std::string kBinaryDir = STEND_BINARY_DIR;
const std::string kSourceDir = STEND_SOURCE_DIR;
const std::string kTestPluginDir = kBinaryDir + "/lib/stend/test-plugins";

std::string test_plugin(const std::string& stem) {
  return kTestPluginDir + "/stend_" + stem + ".so";
}

// Sets (or unsets, with nullopt) an environment variable for one scope.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::optional<std::string>& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) {
      ::setenv(name, value->c_str(), 1);
    } else {
      ::unsetenv(name);
    }
  }
  ~ScopedEnv() {
    if (old_) {
      ::setenv(name_.c_str(), old_->c_str(), 1);
    } else {
      ::unsetenv(name_.c_str());
    }
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_;
  std::optional<std::string> old_;
};

class ConstantTruth : public stend::TruthSource {
 public:
  explicit ConstantTruth(Eigen::Vector3d f) : f_(std::move(f)) {}
  stend::BenchTruth at(double t_s) const override {
    stend::BenchTruth truth;
    truth.t_s = t_s;
    truth.specific_force_mps2 = f_;
    return truth;
  }

 private:
  Eigen::Vector3d f_;
};

const PluginRecord* record_for(const PluginHost& host, const std::string& file) {
  for (const auto& r : host.records()) {
    if (r.file == file) return &r;
  }
  return nullptr;
}

stend::Params good_params() {
  stend::Params p;
  p.set("rate_hz", 100.0);
  p.set("offset_mps2", std::vector<double>{0.5, -0.25, 0.125});
  p.set("device", std::string("sim"));
  return p;
}

bool on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  if (path == nullptr) return false;
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) continue;
    const fs::path candidate = fs::path(dir) / program;
    if (::access(candidate.c_str(), X_OK) == 0) return true;
  }
  return false;
}

// Runs a shell command with its output going to `log`; returns true on exit status 0.
bool run(const std::string& command, const fs::path& log) {
  const stend::testing::ProgramOutput o = stend::testing::run_command(command);
  write_text(log, o.text);
  return o.code == 0;
}

// ---------------------------------------------------------------------------------------------
// Search path

TEST(PluginHostSearchPath, OrderOriginsAndDeduplication) {
  TempDir tmp("search");
  const std::string a = (tmp.path() / "a").string(), b = (tmp.path() / "b").string();
  fs::create_directories(a);
  fs::create_directories(b);
  const std::string missing = (tmp.path() / "missing").string();
  ScopedEnv env("STEND_PLUGIN_PATH", b + "::" + missing + ":" + a);

  const auto dirs = PluginHost::default_search_path({a, missing + "/../a"});
  // Experiment dirs first, then the environment's; a dir reached twice is listed once (first
  // origin wins); missing ones named explicitly are kept so `stend plugins` can say so.
  ASSERT_GE(dirs.size(), 3u);
  EXPECT_EQ(dirs[0].path, a);
  EXPECT_EQ(dirs[0].origin, "experiment");
  EXPECT_EQ(dirs[1].path, b);
  EXPECT_EQ(dirs[1].origin, "STEND_PLUGIN_PATH");
  EXPECT_EQ(dirs[2].path, missing);
  EXPECT_EQ(dirs[2].origin, "STEND_PLUGIN_PATH");
  for (std::size_t i = 3; i < dirs.size(); ++i) {
    EXPECT_NE(dirs[i].origin, "experiment");
    EXPECT_NE(dirs[i].origin, "STEND_PLUGIN_PATH");
    EXPECT_TRUE(fs::is_directory(dirs[i].path)) << dirs[i].path;
  }
  // The build tree's plugin dir, when it exists. (It is also ../lib/stend/plugins relative to
  // this test program, which must not make it appear twice.)
  const bool build_dir_exists = fs::is_directory(STEND_BUILD_PLUGIN_DIR);
  const auto build = std::find_if(dirs.begin(), dirs.end(),
                                  [](const auto& d) { return d.origin == "build tree"; });
  EXPECT_EQ(build != dirs.end(), build_dir_exists);
  if (build != dirs.end()) {
    EXPECT_EQ(build->path, STEND_BUILD_PLUGIN_DIR);
  }
  EXPECT_EQ(std::count_if(dirs.begin(), dirs.end(),
                          [](const auto& d) { return d.origin == "next to the program"; }),
            0)
      << "the dir next to a build-tree program is the build tree's";
}

TEST(PluginHostSearchPath, WithoutEnvironment) {
  ScopedEnv env("STEND_PLUGIN_PATH", std::nullopt);
  for (const auto& d : PluginHost::default_search_path()) {
    EXPECT_NE(d.origin, "STEND_PLUGIN_PATH");
    EXPECT_NE(d.origin, "experiment");
  }
}

// ---------------------------------------------------------------------------------------------
// Refusals: every broken plugin in lib/stend/test-plugins, scanned together.

class PluginHostTestPlugins : public testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::is_directory(kTestPluginDir))
        << kTestPluginDir << " is missing: build the target stend_test_plugins";
    ASSERT_TRUE(fs::exists(test_plugin("good_sensor"))) << "build the target stend_test_plugins";
    host_.scan({{kTestPluginDir, "test"}});
  }
  PluginHost host_;
};

struct RefusalCase {
  const char* stem;
  std::vector<std::string> reason;  // substrings the refusal must contain
};

TEST_F(PluginHostTestPlugins, EachBrokenPluginIsRefusedNamingFileAndReason) {
  const std::vector<RefusalCase> cases = {
      {"bad_abi", {"plugin ABI 999, host ABI " + std::to_string(STEND_PLUGIN_ABI_VERSION) + ": rebuild the plugin against this Stend's SDK"}},
      {"bad_size",
       {"plugin info struct is " + std::to_string(sizeof(stend_plugin_info) + 16) + " bytes",
        "host expects " + std::to_string(sizeof(stend_plugin_info)), "struct_size"}},
      {"no_entry", {"no entry point 'stend_plugin_entry' (not a Stend plugin?)"}},
      {"null_entry", {"entry point 'stend_plugin_entry' returned null"}},
      {"entry_throws", {"entry point 'stend_plugin_entry' threw", "entry point exploded"}},
      {"unresolved", {"cannot load", "undefined symbol", "stend_symbol_that_does_not_exist"}},
      {"bad_kind", {"field 'kind' is 7"}},
      {"bad_name", {"field 'name' is 'Bad-Name'", "lower-case letters, digits and '_'"}},
      {"empty_name", {"field 'name' is empty"}},
      {"null_name", {"field 'name' is null"}},
      {"null_version", {"field 'version' is null"}},
      {"null_create", {"field 'create' is null"}},
      {"null_destroy", {"field 'destroy' is null"}},
      {"null_params", {"field 'params' is null but 'param_count' is 2"}},
      {"null_param_key", {"field 'params[1].key' is null"}},
      {"bad_param_type", {"field 'params[1].type' of 'offset' is 'complex'", "expected one of"}},
      {"junk", {"cannot load"}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.stem);
    const std::string file = test_plugin(c.stem);
    const PluginRecord* r = record_for(host_, file);
    ASSERT_NE(r, nullptr) << file << " was not looked at";
    EXPECT_EQ(r->info, nullptr);
    EXPECT_EQ(r->origin, "test");
    EXPECT_CONTAINS(r->refusal, file);
    for (const auto& part : c.reason) EXPECT_CONTAINS(r->refusal, part);
  }
}

TEST_F(PluginHostTestPlugins, OnlyStendSoFilesAreScannedInNameOrder) {
  std::vector<std::string> seen;
  for (const auto& r : host_.records()) seen.push_back(fs::path(r.file).filename().string());
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  for (const auto& name : seen) {
    EXPECT_EQ(name.rfind("stend_", 0), 0u) << name;
    EXPECT_EQ(name.substr(name.size() - 3), ".so") << name;
  }
  EXPECT_EQ(record_for(host_, kTestPluginDir + "/libstend_ignored.so"), nullptr);
  EXPECT_EQ(record_for(host_, kTestPluginDir + "/stend_ignored.txt"), nullptr);
}

TEST_F(PluginHostTestPlugins, GoodPluginLoadsBesideBrokenOnes) {
  const PluginRecord* r = host_.record_of("test_good");
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->file, test_plugin("good_sensor"));
  EXPECT_TRUE(r->refusal.empty());
  EXPECT_TRUE(r->shadowed_by.empty());
  ASSERT_NE(host_.find("test_good"), nullptr);
  EXPECT_STREQ(host_.find("test_good")->version, "1.2.3");
  EXPECT_EQ(host_.find("Bad-Name"), nullptr);
  EXPECT_EQ(host_.names(),
            (std::vector<std::string>{"test_create_fails", "test_dup", "test_good", "test_silent"}));

  auto sensor = host_.create_sensor("test_good", good_params());
  ASSERT_NE(sensor, nullptr);
  EXPECT_EQ(sensor->identity().model, "TestSensor");
  ConstantTruth truth({1.0, 2.0, 3.0});
  std::vector<stend::ImuSample> out;
  sensor->start(0.0);
  sensor->acquire(0.05, truth, out);
  ASSERT_EQ(out.size(), 5u);
  EXPECT_DOUBLE_EQ(out.back().t_s, 0.05);
  EXPECT_DOUBLE_EQ(out.back().accel_mps2.x(), 1.5);
  EXPECT_DOUBLE_EQ(out.back().accel_mps2.y(), 1.75);
  EXPECT_DOUBLE_EQ(out.back().accel_mps2.z(), 3.125);
}

TEST_F(PluginHostTestPlugins, DuplicateNameIsShadowedFirstWins) {
  const PluginRecord* a = record_for(host_, test_plugin("dup_a"));
  const PluginRecord* b = record_for(host_, test_plugin("dup_b"));
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  EXPECT_TRUE(a->shadowed_by.empty());
  EXPECT_EQ(b->shadowed_by, a->file);
  EXPECT_TRUE(b->refusal.empty());
  ASSERT_NE(host_.record_of("test_dup"), nullptr);
  EXPECT_EQ(host_.record_of("test_dup")->file, a->file);
}

TEST_F(PluginHostTestPlugins, CreateFailureReportsPluginFileAndReason) {
  try {
    (void)host_.create_sensor("test_create_fails", good_params());
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "plugin 'test_create_fails' (" + test_plugin("create_fails") +
                                    ") could not create a sensor: no device at "
                                    "/dev/stend-test-does-not-exist (device 'sim')");
  }
  try {
    (void)host_.create_sensor("test_silent", good_params());
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "plugin 'test_silent' (" + test_plugin("silent_create") +
                                    ") could not create a sensor: no reason given");
  }
}

TEST_F(PluginHostTestPlugins, WrongKindAndUnknownNameAreExplained) {
  try {
    (void)host_.create_fixture("test_good", good_params());
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "plugin 'test_good' (" + test_plugin("good_sensor") +
                                    ") is a sensor plugin, not a fixture");
  }
  try {
    (void)host_.create_estimator("test_good", good_params());
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "is a sensor plugin, not an estimator");
  }
  try {
    (void)host_.create_sensor("no_such_plugin", good_params());
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "no plugin named 'no_such_plugin'");
    EXPECT_CONTAINS(e.what(), "loaded plugins: test_create_fails, test_dup, test_good, test_silent");
  }
  // A refused file that would have provided the name is mentioned.
  try {
    (void)host_.create_sensor("bad_abi", good_params());
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), test_plugin("bad_abi") + ": plugin ABI 999");
  }
}

TEST_F(PluginHostTestPlugins, DescribeListsLoadedRefusedShadowedAndSearchPath) {
  const std::string text = host_.describe();
  EXPECT_CONTAINS(text, "Plugins (4 loaded):");
  EXPECT_CONTAINS(text, "KIND");
  EXPECT_CONTAINS(text, "DESCRIPTION");
  EXPECT_CONTAINS(text, "test sensor: truth plus an offset");
  EXPECT_CONTAINS(text, "1.2.3");
  EXPECT_CONTAINS(text, "Refused (");
  EXPECT_CONTAINS(text, test_plugin("bad_abi") + ": plugin ABI 999, host ABI " + std::to_string(STEND_PLUGIN_ABI_VERSION));
  EXPECT_CONTAINS(text, "Shadowed (1):");
  EXPECT_CONTAINS(text, test_plugin("dup_b"));
  EXPECT_CONTAINS(text, "shadowed by " + test_plugin("dup_a"));
  EXPECT_CONTAINS(text, "Search path");
  EXPECT_CONTAINS(text, "1. " + kTestPluginDir);

  PluginHost empty;
  empty.scan({{"/nonexistent/stend-plugin-dir", "STEND_PLUGIN_PATH"}});
  const std::string none = empty.describe();
  EXPECT_CONTAINS(none, "Plugins (0 loaded):");
  EXPECT_CONTAINS(none, "/nonexistent/stend-plugin-dir  STEND_PLUGIN_PATH  (does not exist)");
}

TEST(PluginHost, JunkEmptyAndDirectoriesBesideAGoodPlugin) {
  TempDir dir("junk");
  // Random bytes (never the ELF magic), an empty file, a directory and a dangling symlink that
  // all look like plugins by name, next to a working plugin.
  std::mt19937 rng(12345);
  {
    std::ofstream junk(dir.path() / "stend_random.so", std::ios::binary);
    junk << "JUNK";
    for (int i = 0; i < 8192; ++i) junk.put(static_cast<char>(rng() & 0xff));
  }
  { std::ofstream empty(dir.path() / "stend_empty.so"); }
  fs::create_directories(dir.path() / "stend_directory.so");
  fs::create_symlink(dir.path() / "nowhere.so", dir.path() / "stend_dangling.so");
  fs::copy_file(test_plugin("good_sensor"), dir.path() / "stend_good_copy.so");

  PluginHost host;
  host.scan({{dir.str(), "experiment"}});
  ASSERT_EQ(host.records().size(), 3u) << host.describe();  // the directory and symlink skipped
  for (const char* stem : {"random", "empty"}) {
    const std::string file = (dir.path() / ("stend_" + std::string(stem) + ".so")).string();
    const PluginRecord* r = record_for(host, file);
    ASSERT_NE(r, nullptr) << file;
    EXPECT_EQ(r->info, nullptr);
    EXPECT_CONTAINS(r->refusal, file + ": cannot load: ");
  }
  ASSERT_NE(host.find("test_good"), nullptr);
  EXPECT_EQ(host.record_of("test_good")->origin, "experiment");
  EXPECT_NE(host.create_sensor("test_good", good_params()), nullptr);
}

TEST(PluginHost, LoadingTheSameFileTwiceIsOnePlugin) {
  PluginHost host;
  const PluginRecord& first = host.load(test_plugin("good_sensor"), "test");
  ASSERT_NE(first.info, nullptr);
  host.load(kTestPluginDir + "/../test-plugins/stend_good_sensor.so", "again");
  host.scan({{kTestPluginDir, "scan"}});
  EXPECT_EQ(std::count_if(host.records().begin(), host.records().end(),
                          [](const auto& r) { return r.info && std::string(r.info->name) == "test_good"; }),
            1);
  EXPECT_EQ(host.record_of("test_good")->origin, "test");
}

TEST(PluginHost, MissingFileIsRefusedNotThrown) {
  PluginHost host;
  const std::string file = kTestPluginDir + "/stend_does_not_exist.so";
  const PluginRecord& r = host.load(file, "test");
  EXPECT_EQ(r.info, nullptr);
  EXPECT_CONTAINS(r.refusal, file + ": cannot load: ");
}

TEST(PluginHost, ObjectsMayOutliveTheHost) {
  stend::PluginPtr<stend::Sensor> sensor;
  {
    PluginHost host;
    host.load(test_plugin("good_sensor"), "test");
    sensor = host.create_sensor("test_good", good_params());
  }
  // The library stays loaded while the object exists.
  ConstantTruth truth({0.0, 0.0, 9.8});
  std::vector<stend::ImuSample> out;
  sensor->start(0.0);
  sensor->acquire(0.02, truth, out);
  EXPECT_EQ(out.size(), 2u);
  EXPECT_EQ(sensor->identity().serial, "T-1");
  sensor.reset();
}

// ---------------------------------------------------------------------------------------------
// Out of tree: install this build, build sdk/template_sensor against the installed package
// exactly as a researcher would, then load and use what it produced.

TEST(PluginHostOutOfTree, TemplateSensorBuildsAgainstInstalledSdkAndWorks) {
  if (!on_path("cmake")) GTEST_SKIP() << "cmake is not on PATH";

  TempDir tmp("oot");
  const fs::path prefix = tmp.path() / "prefix";
  const fs::path build = tmp.path() / "template-build";
  const fs::path log = tmp.path() / "log.txt";

  // 1. Install the whole build tree into a private prefix.
  ASSERT_TRUE(run("cmake --install " + shell_quote(kBinaryDir) + " --prefix " +
                      shell_quote(prefix.string()),
                  log))
      << "cmake --install failed (is the whole project built? `ninja` first):\n"
      << read_text(log);
  const fs::path config_dir = prefix / "lib" / "cmake" / "Stend";
  EXPECT_TRUE(fs::exists(config_dir / "StendConfig.cmake"));
  EXPECT_TRUE(fs::exists(config_dir / "StendConfigVersion.cmake"));
  EXPECT_TRUE(fs::exists(prefix / "include" / "stend" / "plugin_abi.h"));
  EXPECT_TRUE(fs::exists(prefix / "include" / "stend" / "sdk.hpp"));
  EXPECT_TRUE(fs::exists(prefix / "include" / "stend" / "errors.hpp"));
  EXPECT_TRUE(fs::exists(prefix / "include" / "stend" / "core" / "plugin_host.hpp"));
  EXPECT_TRUE(fs::exists(prefix / "include" / "stend" / "recording" / "recording.hpp"));
  EXPECT_FALSE(fs::exists(prefix / "lib" / "stend" / "test-plugins"))
      << "test plugins must never be installed";

  // 2. Configure and build the template on its own: a fresh CMake project that knows nothing of
  // this build's flags (-Werror, sanitizers), with the environment's compiler flags cleared.
  const std::string clean_env = "env -u CFLAGS -u CXXFLAGS -u CPPFLAGS -u LDFLAGS ";
  ASSERT_TRUE(run(clean_env + "cmake -S " + shell_quote(kSourceDir + "/sdk/template_sensor") +
                      " -B " + shell_quote(build.string()) + " -DCMAKE_PREFIX_PATH=" +
                      shell_quote(prefix.string()) + " -DCMAKE_BUILD_TYPE=Release",
                  log))
      << "configuring sdk/template_sensor failed:\n"
      << read_text(log);
  const std::string cache = read_text(build / "CMakeCache.txt");
  EXPECT_CONTAINS(cache, "Stend_DIR:PATH=" + config_dir.string())
      << "found a Stend other than the one just installed";
  EXPECT_EQ(cache.find("-Werror"), std::string::npos) << "parent build flags leaked";
  ASSERT_TRUE(run(clean_env + "cmake --build " + shell_quote(build.string()), log))
      << "building sdk/template_sensor failed:\n"
      << read_text(log);
  const fs::path plugin = build / "stend_template_sensor.so";
  ASSERT_TRUE(fs::exists(plugin)) << read_text(log);

  // 3. Its install goes to the installed Stend's plugin directory (STEND_PLUGIN_DIR). Checked
  // before installing, so a broken package can't make the test write outside its temp dir.
  const fs::path plugin_dir = prefix / "lib" / "stend" / "plugins";
  ASSERT_TRUE(cache.find("STEND_PLUGIN_INSTALL_DIR:PATH=" + plugin_dir.string() + "\n") !=
              std::string::npos)
      << "STEND_PLUGIN_DIR of the installed package is not " << plugin_dir;
  ASSERT_TRUE(run("cmake --install " + shell_quote(build.string()), log)) << read_text(log);
  EXPECT_TRUE(fs::exists(plugin_dir / "stend_template_sensor.so"))
      << read_text(log);

  // 4. Found through STEND_PLUGIN_PATH (pointing at the build dir), loaded, used.
  ScopedEnv env("STEND_PLUGIN_PATH", build.string());
  PluginHost host;
  host.scan(PluginHost::default_search_path());
  const PluginRecord* r = host.record_of("template_sensor");
  ASSERT_NE(r, nullptr) << host.describe();
  EXPECT_EQ(fs::path(r->file), plugin);
  EXPECT_EQ(r->origin, "STEND_PLUGIN_PATH");
  EXPECT_EQ(r->info->kind, STEND_KIND_SENSOR);
  EXPECT_STREQ(r->info->version, "0.1.0");
  EXPECT_CONTAINS(host.describe(), "template_sensor");

  // Every default in its schema is valid for its own schema.
  const stend_plugin_info& info = *r->info;
  const stend::Params defaults =
      stend::params_from_yaml(YAML::Node(), info, "template.yaml", "sensor.config");
  ASSERT_EQ(defaults.values().size(), info.param_count);
  const double lsb = defaults.number("lsb_mps2");

  const Eigen::Vector3d force(0.3, -0.2, 9.80665);
  const Eigen::Vector3d bias(0.05, -0.02, 0.1);
  const stend::Params params = stend::params_from_yaml(
      YAML::Load("bias_mps2: [0.05, -0.02, 0.1]\nserial: OOT-42\n"), info, "template.yaml",
      "sensor.config");
  auto sensor = host.create_sensor("template_sensor", params);
  ASSERT_NE(sensor, nullptr);
  EXPECT_EQ(sensor->identity().serial, "OOT-42");
  EXPECT_DOUBLE_EQ(sensor->info().output_rate_hz, 100.0);
  EXPECT_FALSE(sensor->info().has_gyro);

  ConstantTruth truth(force);
  std::vector<stend::ImuSample> out;
  sensor->start(1.0);
  sensor->acquire(1.1, truth, out);
  ASSERT_EQ(out.size(), 10u);
  for (std::size_t i = 0; i < out.size(); ++i) {
    const auto& s = out[i];
    EXPECT_NEAR(s.t_s, 1.0 + 0.01 * static_cast<double>(i + 1), 1e-12);
    EXPECT_EQ(s.flags, 0u);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(s.accel_mps2[k], force[k] + bias[k], lsb / 2 + 1e-12) << "axis " << k;
      EXPECT_DOUBLE_EQ(s.accel_mps2[k], s.accel_counts[k] * lsb);
    }
  }
  out.clear();
  sensor->acquire(1.1, truth, out);  // nothing new in (1.1, 1.1]
  EXPECT_TRUE(out.empty());

  // Beyond full scale the reading clips and is flagged.
  auto small = host.create_sensor(
      "template_sensor",
      stend::params_from_yaml(YAML::Load("range_mps2: 5"), info, "template.yaml", "sensor.config"));
  small->start(0.0);
  small->acquire(0.01, truth, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(out[0].flags & stend::kAccelSaturated);
  EXPECT_NEAR(out[0].accel_mps2.z(), 5.0, lsb);

  // A schema violation never reaches the plugin: the host's validation reports it.
  EXPECT_THROW(stend::params_from_yaml(YAML::Load("rate_hz: 0"), info, "template.yaml",
                                       "sensor.config"),
               stend::ExperimentError);
}

}  // namespace
