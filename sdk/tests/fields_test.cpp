// Field tables (stend/fields.hpp): the generated schema as the host reads it, the reader, and the
// entry point STEND_DEFINE_PLUGIN builds from a table.
#include <gtest/gtest.h>

#include <stend/core/experiment.hpp>
#include <stend/fields.hpp>
#include <stend/sdk.hpp>
#include <stend/yaml/reader.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>
#include <yaml-cpp/yaml.h>

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Link {
  std::string port = "/dev/ttyUSB0";
  int baud = 115200;
};

// One member of every shape, a member of a member, an accessor, a converted property and a
// required key.
struct Config {
  double rate_hz = 100.0;
  double density = 0.005 * kPi / 180.0;  // needs all 17 digits to read back the same
  int bits = 16;
  std::int64_t seed = 0;
  bool enabled = true;
  std::string mode = "fifo";
  std::string who_am_i = "0x68";  // reads as an integer unless quoted
  std::string serial;             // empty
  Eigen::Vector3d bias_mps2{0.5, -1.25, 1e-6};
  Eigen::Matrix3d misalignment = Eigen::Matrix3d::Identity();
  std::vector<double> knots{1.0, 2.0, 4.0};
  std::vector<std::vector<double>> tc{{0.0}, {0.0}, {0.0}};
  Link link;
  struct {
    double gain = 2.0;
  } inner;
  double period_ms = 20.0;  // the parameter is the rate in Hz: 1000 / period_ms
  std::string device;       // required
};

using F = stend::fields::Field<Config>;

const stend::fields::Table<Config>& test_fields() {
  static const stend::fields::Table<Config> table(
      "fields_test", {
                         F("rate_hz", &Config::rate_hz, "Hz", "output data rate").range(1.0, 1000.0),
                         F("density", &Config::density, "rad/s/sqrt(Hz)", "white noise").range(0.0, 1.0),
                         F("bits", &Config::bits, "", "word length").range(2, 32),
                         F("seed", &Config::seed, "", "noise seed").at_least(0.0),
                         F("enabled", &Config::enabled, "", "switch"),
                         F("mode", &Config::mode, "", "how samples are read").choices("fifo|poll"),
                         F("who_am_i", &Config::who_am_i, "", "identity register"),
                         F("serial", &Config::serial, "", "serial number"),
                         F("bias_mps2", &Config::bias_mps2, "m/s^2", "bias").range(-10.0, 10.0),
                         F("misalignment", &Config::misalignment, "1", "mounting matrix"),
                         F("knots", &Config::knots, "degC", "temperatures"),
                         F("tc", &Config::tc, "1/degC^k", "coefficients per axis"),
                         F("port", &Config::link, &Link::port, "", "serial port"),
                         F("baud", &Config::link, &Link::baud, "1/s", "line rate").range(1200, 4000000),
                         F("gain", [](Config& c) -> double& { return c.inner.gain; }, "1", "gain"),
                         F::property<double>(
                             "sample_rate_hz", [](const Config& c) { return 1000.0 / c.period_ms; },
                             [](Config& c, double hz) { c.period_ms = 1000.0 / hz; }, "Hz", "sampling rate"),
                         F("device", &Config::device, "", "where the device is").required(),
                     });
  return table;
}

}  // namespace

// The entry point of a plugin whose schema is the table above (the object is never created here).
class Probe final : public stend::Sensor {
 public:
  explicit Probe(const stend::Params& p) : c_(test_fields().read(p)) {}
  stend::SensorIdentity identity() const override { return {"Stend", "Probe", c_.serial, c_.who_am_i}; }
  stend::SensorInfo info() const override {
    stend::SensorInfo i;
    i.output_rate_hz = c_.rate_hz;
    return i;
  }
  void start(double) override {}
  void acquire(double, const stend::TruthSource&, std::vector<stend::ImuSample>&) override {}

 private:
  Config c_;
};

STEND_DEFINE_PLUGIN(STEND_KIND_SENSOR, "fields_test", "0.0.1", "field table probe", test_fields(), Probe)

namespace {

// The host's own validation of a `config:` block against the generated schema.
stend::Params host_reads(const std::string& yaml) {
  return stend::params_from_yaml(YAML::Load(yaml), *stend_plugin_entry(), "test.yaml", "config");
}

const stend_param_spec& spec_of(const std::string& key) {
  const auto& t = test_fields();
  for (std::size_t i = 0; i < t.size(); ++i)
    if (key == t.specs()[i].key) return t.specs()[i];
  throw std::out_of_range(key);
}

void expect_same(const Config& a, const Config& b) {
  EXPECT_EQ(a.rate_hz, b.rate_hz);
  EXPECT_EQ(a.density, b.density);
  EXPECT_EQ(a.bits, b.bits);
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_EQ(a.enabled, b.enabled);
  EXPECT_EQ(a.mode, b.mode);
  EXPECT_EQ(a.who_am_i, b.who_am_i);
  EXPECT_EQ(a.serial, b.serial);
  EXPECT_EQ(a.bias_mps2, b.bias_mps2);
  EXPECT_EQ(a.misalignment, b.misalignment);
  EXPECT_EQ(a.knots, b.knots);
  EXPECT_EQ(a.tc, b.tc);
  EXPECT_EQ(a.link.port, b.link.port);
  EXPECT_EQ(a.link.baud, b.link.baud);
  EXPECT_EQ(a.inner.gain, b.inner.gain);
  EXPECT_DOUBLE_EQ(a.period_ms, b.period_ms);
  EXPECT_EQ(a.device, b.device);
}

std::string message_of(const stend::Params& p) {
  try {
    (void)test_fields().read(p);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no error)";
}

stend::Params with_device(stend::Params p) {
  p.set("device", std::string("/dev/x"));
  return p;
}

}  // namespace

TEST(Fields, SchemaHasOneEntryPerFieldWithTheTypeOfItsMember) {
  const stend_plugin_info& info = *stend_plugin_entry();
  ASSERT_EQ(info.param_count, test_fields().size());
  EXPECT_EQ(info.params, test_fields().specs());
  const std::vector<std::pair<const char*, const char*>> types = {
      {"rate_hz", "number"}, {"bits", "integer"},        {"seed", "integer"},  {"enabled", "bool"},
      {"mode", "string"},    {"bias_mps2", "vec3"},      {"misalignment", "mat3"}, {"knots", "numbers"},
      {"tc", "matrix3"},     {"port", "string"},         {"baud", "integer"},  {"gain", "number"},
      {"sample_rate_hz", "number"}};
  for (const auto& [key, type] : types) EXPECT_STREQ(spec_of(key).type, type) << key;
  const stend_param_spec& rate = spec_of("rate_hz");
  EXPECT_STREQ(rate.unit, "Hz");
  EXPECT_STREQ(rate.doc, "output data rate");
  EXPECT_EQ(rate.min, 1.0);
  EXPECT_EQ(rate.max, 1000.0);
  EXPECT_EQ(rate.choices, nullptr);
  EXPECT_EQ(spec_of("seed").min, 0.0);
  EXPECT_TRUE(std::isnan(spec_of("seed").max));
  EXPECT_TRUE(std::isnan(spec_of("enabled").min));
  EXPECT_STREQ(spec_of("mode").choices, "fifo|poll");
}

TEST(Fields, DefaultsAreWrittenFromTheDefaultConfig) {
  auto def = [](const char* key) { return std::string(spec_of(key).default_yaml); };
  EXPECT_EQ(def("rate_hz"), "100");
  EXPECT_EQ(def("density"), "8.726646259971648e-05");  // shortest text that reads back the same
  EXPECT_EQ(def("bits"), "16");
  EXPECT_EQ(def("enabled"), "true");
  EXPECT_EQ(def("mode"), "\"fifo\"");
  EXPECT_EQ(def("who_am_i"), "\"0x68\"");
  EXPECT_EQ(def("serial"), "\"\"");
  EXPECT_EQ(def("bias_mps2"), "[0.5, -1.25, 1e-06]");
  EXPECT_EQ(def("misalignment"), "[[1, 0, 0], [0, 1, 0], [0, 0, 1]]");
  EXPECT_EQ(def("knots"), "[1, 2, 4]");
  EXPECT_EQ(def("tc"), "[[0], [0], [0]]");
  EXPECT_EQ(def("port"), "\"/dev/ttyUSB0\"");
  EXPECT_EQ(def("gain"), "2");
  EXPECT_EQ(def("sample_rate_hz"), "50");
  EXPECT_EQ(spec_of("device").default_yaml, nullptr);  // required
}

TEST(Fields, DefaultsRoundTripThroughTheHostToTheDefaultConfig) {
  const stend::Params p = host_reads("{device: /dev/ttyACM0}");
  EXPECT_EQ(p.values().size(), test_fields().size());  // the host filled in every default
  Config expected;
  expected.device = "/dev/ttyACM0";
  expect_same(test_fields().read(p), expected);
}

TEST(Fields, EveryShapeRoundTripsThroughTheHostsYaml) {
  Config c;
  c.rate_hz = 100.0 / 3.0;
  c.density = 0.1 + 0.2;
  c.bits = 24;
  c.seed = 123456789012345;
  c.enabled = false;
  c.mode = "poll";
  c.who_am_i = "true";
  c.serial = "S/N \"7\" \\ tab\there\nline";
  c.bias_mps2 = {-9.80665, 1e-300, 3.0};
  c.misalignment << 1.0, 1e-3, -2e-3, 0.0, 1.0, 0.5, 0.25, 0.125, 1.0;
  c.knots = {};
  c.tc = {{1.0, 2.0}, {3.0, 4.0}, {5.0, 6.0}};
  c.link.port = "null";
  c.link.baud = 921600;
  c.inner.gain = -0.0;
  c.period_ms = 8.0;
  c.device = "~";
  YAML::Emitter out;
  stend::yaml::emit_params(out, test_fields().params(c), stend_plugin_entry());
  expect_same(test_fields().read(host_reads(out.c_str())), c);
}

TEST(Fields, AbsentKeysKeepTheirDefaultsAndPresentOnesAreAssigned) {
  stend::Params p;
  p.set("device", std::string("/dev/x"));
  p.set("gain", 0.5);
  p.set("port", std::string("/dev/ttyS1"));
  const Config c = test_fields().read(p);
  EXPECT_EQ(c.inner.gain, 0.5);
  EXPECT_EQ(c.link.port, "/dev/ttyS1");
  EXPECT_EQ(c.link.baud, 115200);
  EXPECT_EQ(c.rate_hz, 100.0);
}

TEST(Fields, UnknownKeyIsRefusedNamingThePluginAndTheKey) {
  stend::Params p = with_device({});
  p.set("rate_hx", 10.0);
  EXPECT_EQ(message_of(p), "fields_test: unknown parameter 'rate_hx'");
}

TEST(Fields, RequiredKeyMustBeGiven) {
  EXPECT_EQ(message_of(stend::Params{}), "fields_test: missing required parameter 'device' (where the device is)");
  EXPECT_THROW(host_reads("{}"), stend::ExperimentError);
}

TEST(Fields, WrongShapesAreRefused) {
  auto refused = [](const std::string& key, stend::Params::Value v) {
    stend::Params p = with_device({});
    p.set(key, std::move(v));
    return message_of(p);
  };
  using M = stend::Params::Matrix;
  EXPECT_EQ(refused("bias_mps2", std::vector<double>{1.0, 2.0}),
            "fields_test: parameter 'bias_mps2' must be a list of 3 numbers, got a list of 2 numbers");
  EXPECT_EQ(refused("misalignment", M{{1, 0, 0}, {0, 1, 0}}),
            "fields_test: parameter 'misalignment' must be a 3x3 matrix, got a matrix of 2 rows (3, 3 numbers)");
  EXPECT_EQ(refused("tc", M{{1.0}, {2.0, 3.0}, {4.0}}),
            "fields_test: parameter 'tc' must be 3 rows of numbers of equal length, got a matrix of 3 rows (1, 2, 1 "
            "numbers)");
  EXPECT_EQ(refused("tc", M{{}, {}, {}}),
            "fields_test: parameter 'tc' must be 3 rows of numbers of equal length, got a matrix of 3 rows (0, 0, 0 "
            "numbers)");
  EXPECT_EQ(refused("bits", 2.5), "fields_test: parameter 'bits' must be an integer, got a number");
  EXPECT_EQ(refused("rate_hz", std::string("fast")), "fields_test: parameter 'rate_hz' must be a number, got text");
  EXPECT_EQ(refused("enabled", std::int64_t{1}), "fields_test: parameter 'enabled' must be true or false, got an integer");
  EXPECT_EQ(refused("knots", 1.0), "fields_test: parameter 'knots' must be a list of numbers, got a number");
  EXPECT_EQ(refused("baud", std::int64_t{1} << 40),
            "fields_test: parameter 'baud' = 1099511627776 is above the maximum 4000000");
  EXPECT_EQ(refused("bits", std::int64_t{1} << 40), "fields_test: parameter 'bits' = 1099511627776 is above the maximum 32");
  EXPECT_EQ(refused("seed", std::int64_t{-1}), "fields_test: parameter 'seed' = -1 is below the minimum 0");
  EXPECT_EQ(refused("bias_mps2", std::vector<double>{0.0, 11.0, 0.0}),
            "fields_test: parameter 'bias_mps2' = 11 is above the maximum 10");
  EXPECT_EQ(refused("mode", std::string("burst")), "fields_test: parameter 'mode' = 'burst' is not one of fifo|poll");
}

TEST(Fields, WholeNumbersAreIntegersAndIntegersAreNumbers) {
  stend::Params p = with_device({});
  p.set("bits", 12.0);
  p.set("rate_hz", std::int64_t{200});
  const Config c = test_fields().read(p);
  EXPECT_EQ(c.bits, 12);
  EXPECT_EQ(c.rate_hz, 200.0);
}

TEST(Fields, IntegerThatDoesNotFitItsMemberIsRefused) {
  struct Small {
    std::uint8_t code = 1;
  };
  const stend::fields::Table<Small> t("small", {stend::fields::Field<Small>("code", &Small::code, "", "code")});
  stend::Params p;
  p.set("code", std::int64_t{300});
  EXPECT_THROW((void)t.read(p), std::invalid_argument);
  p.set("code", std::int64_t{255});
  EXPECT_EQ(t.read(p).code, 255);
}

TEST(Fields, TableThatIsABugIsRefusedWhenBuilt) {
  struct Two {
    double a = 5.0, b = 0.0;
  };
  using G = stend::fields::Field<Two>;
  EXPECT_THROW((stend::fields::Table<Two>("two", {G("a", &Two::a, "", ""), G("a", &Two::b, "", "")})),
               std::logic_error);
  EXPECT_THROW((stend::fields::Table<Two>("two", {G("", &Two::a, "", "")})), std::logic_error);
  EXPECT_THROW((stend::fields::Table<Two>("two", {G("a", &Two::a, "", "").range(0.0, 1.0)})), std::logic_error);
  // A required key's member initializer is no default, so it is not checked.
  EXPECT_NO_THROW((stend::fields::Table<Two>("two", {G("a", &Two::a, "", "").range(0.0, 1.0).required()})));
}

TEST(Fields, PluginDefaultsCanDifferFromTheConfigs) {
  Config chip;
  chip.rate_hz = 104.0;
  const stend::fields::Table<Config> t("chip", {F("rate_hz", &Config::rate_hz, "Hz", "rate")}, chip);
  EXPECT_STREQ(t.specs()[0].default_yaml, "104");
  EXPECT_EQ(t.read(stend::Params{}).rate_hz, 104.0);
}

TEST(Fields, NestedFieldsOfAPartAreFieldsOfTheWhole) {
  struct Whole {
    Link link;
    double extra = 1.0;
  };
  using L = stend::fields::Field<Link>;
  const std::vector<L> shared = {L("port", &Link::port, "", "port"), L("baud", &Link::baud, "1/s", "rate")};
  const stend::fields::Table<Whole> t(
      "whole", stend::fields::join(stend::fields::nested<Whole>(&Whole::link, shared),
                                   {stend::fields::Field<Whole>("extra", &Whole::extra, "", "extra")}));
  ASSERT_EQ(t.size(), 3u);
  EXPECT_STREQ(t.specs()[0].key, "port");
  EXPECT_STREQ(t.specs()[1].default_yaml, "115200");
  EXPECT_STREQ(t.specs()[2].key, "extra");
  stend::Params p;
  p.set("baud", std::int64_t{9600});
  const Whole w = t.read(p);
  EXPECT_EQ(w.link.baud, 9600);
  EXPECT_EQ(w.link.port, "/dev/ttyUSB0");
}

TEST(Fields, PluginCreatedThroughTheEntryReadsItsTable) {
  const stend_plugin_info& info = *stend_plugin_entry();
  const stend::Params p = host_reads("{device: /dev/x, who_am_i: '0x69', rate_hz: 250}");
  char err[256] = {};
  void* object = info.create(&p, err, sizeof err);
  ASSERT_NE(object, nullptr) << err;
  auto* sensor = static_cast<stend::Sensor*>(object);
  EXPECT_EQ(sensor->identity().who_am_i, "0x69");
  EXPECT_EQ(sensor->info().output_rate_hz, 250.0);
  info.destroy(object);
  stend::Params bad = p;
  bad.set("nope", 1.0);
  EXPECT_EQ(info.create(&bad, err, sizeof err), nullptr);
  EXPECT_STREQ(err, "fields_test: unknown parameter 'nope'");
}
