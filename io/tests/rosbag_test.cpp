// ROS bag importers: ROS 1 on the shared real bags and on bags written here with librosbag's own
// writer (rosbag::Bag); rosbag2 (MCAP and SQLite3) on bags written by the formats' own writers
// (io/tests/rosbag2_writer: @mcap/core + @foxglove/rosmsg2-serialization, then python3 sqlite3 in
// rosbag2's schema); bad files of every kind give an ImportError naming file and place.
#include <stend/io/rosbag.hpp>
#include <stend/testing/files.hpp>
#include <stend/testing/paths.hpp>
#include <stend/testing/program.hpp>

#include <gtest/gtest.h>

#include <ros/serialization.h>
#include <rosbag/bag.h>
#include <topic_tools/shape_shifter.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using stend::Recording;
using stend::io::ImportError;
using stend::io::RosbagOptions;

namespace {

std::string import_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const ImportError& e) {
    return e.what();
  }
  return "(no ImportError)";
}

const stend::Event& info_event(const Recording& r) {
  for (const stend::Event& e : r.events) {
    if (e.source == "import") return e;
  }
  throw std::runtime_error("no import event");
}

double mean_norm_accel(const Recording& r) {
  double s = 0.0;
  for (const auto& x : r.samples) s += x.accel_mps2.norm();
  return s / static_cast<double>(r.samples.size());
}

std::size_t gap_count(const Recording& r) {
  std::size_t n = 0;
  for (const auto& s : r.samples) n += (s.flags & stend::kGapBefore) ? 1 : 0;
  return n;
}

void truncate_copy(const fs::path& from, const fs::path& to, std::uintmax_t size) {
  fs::copy_file(from, to, fs::copy_options::overwrite_existing);
  fs::resize_file(to, size);
}

// Every truncation of `file` (at `steps` offsets) throws ImportError naming the copy: none crashes,
// none imports silently.
template <class Import>
void expect_truncations_refused(const fs::path& file, const fs::path& dir, int steps, Import import) {
  const auto size = fs::file_size(file);
  for (int k = 0; k < steps; ++k) {
    const auto cut = size * static_cast<std::uintmax_t>(k) / static_cast<std::uintmax_t>(steps) + 3;
    const fs::path copy = dir / ("cut_" + std::to_string(cut) + file.extension().string());
    truncate_copy(file, copy, cut);
    const std::string msg = import_error([&] { import(copy); });
    EXPECT_NE(msg.find(copy.string()), std::string::npos) << "cut at byte " << cut << ": " << msg;
  }
}

// ---------------------------------------------------------------------------------------------
// ROS 1

TEST(Rosbag1, SparkfunRazorRealBag) {
  const fs::path bag = stend::testing::shared_data("logs/rosbag1/sparkfun_razor.bag");
  STEND_SKIP_IF_ABSENT(bag);
  ASSERT_TRUE(stend::io::looks_like_rosbag1(bag));
  EXPECT_FALSE(stend::io::looks_like_rosbag2(bag));
  const Recording r = stend::io::import_rosbag1(bag);
  ASSERT_EQ(r.samples.size(), 2144u);  // the only Imu topic (/imu/mag is MagneticField)
  EXPECT_EQ(r.header.identity.model, "/imu/data_raw");
  EXPECT_EQ(r.header.identity.serial, "/imu");  // header.frame_id
  EXPECT_EQ(r.samples.front().t_s, 0.0);
  EXPECT_NEAR(r.samples.back().t_s, 31.0, 1.0);
  EXPECT_NEAR(mean_norm_accel(r), 9.81, 0.5);  // m/s², a board at rest most of the time
  EXPECT_GT(r.header.info.output_rate_hz, 50.0);
  EXPECT_FALSE(r.header.info.has_temperature);
  EXPECT_NE(info_event(r).message.find("header.stamp"), std::string::npos);
}

TEST(Rosbag1, RobotLocalizationRealBag) {
  const fs::path bag = stend::testing::shared_data("logs/rosbag1/robot_localization_test2.bag");
  STEND_SKIP_IF_ABSENT(bag);
  const Recording r = stend::io::import_rosbag1(bag);
  ASSERT_EQ(r.samples.size(), 3061u);  // /imu/data; the odometry topic is not Imu
  EXPECT_EQ(r.header.identity.model, "/imu/data");
  EXPECT_EQ(r.header.identity.serial, "base_link");
  EXPECT_NEAR(r.samples.back().t_s, 61.0, 1.0);
  EXPECT_NEAR(r.header.info.output_rate_hz, 50.0, 1.0);  // stamps 47.58, 47.60, … s
  EXPECT_NEAR(mean_norm_accel(r), 9.81, 0.5);
  RosbagOptions odom;
  odom.topic = "/jackal_velocity_controller/odom";
  const std::string msg = import_error([&] { stend::io::import_rosbag1(bag, odom); });
  EXPECT_NE(msg.find("nav_msgs/Odometry, expected sensor_msgs/Imu"), std::string::npos) << msg;
}

// A bag written by librosbag: Imu messages on `topics` (stamp i·10 ms from 100 s, or 0;
// accel (0.1 i, 0, 9.8), gyro (0, 0.01 i, 0); record time 200 s + i·10 ms) and Temperature at
// 1 Hz (20 + k °C) on /temp; written in the order `order` gives the i (empty: 0 … n−1), in chunks
// of about `chunk_bytes`; frame_id "imu_frame", or "f<i as 8 digits>" with frame_per_message.
void write_ros1_bag(const fs::path& file, const std::vector<std::string>& topics, int n, bool zero_stamps,
                    rosbag::compression::CompressionType compression, std::vector<int> order = {},
                    std::uint32_t chunk_bytes = 2048, bool frame_per_message = false) {
  rosbag::Bag bag(file.string(), rosbag::bagmode::Write);
  bag.setCompression(compression);
  bag.setChunkThreshold(chunk_bytes);
  auto message = [](const char* md5, const char* type, std::vector<std::uint8_t> bytes) {
    topic_tools::ShapeShifter s;
    s.morph(md5, type, "(definition not needed by the reader)", "");
    ros::serialization::IStream in(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
    s.read(in);
    return s;
  };
  auto header = [&](ros::serialization::OStream& o, std::uint32_t sec, std::uint32_t nsec, int i) {
    o.next(std::uint32_t{0});
    o.next(sec);
    o.next(nsec);
    char frame[16];
    std::snprintf(frame, sizeof frame, "f%08d", i);
    o.next(std::string(frame_per_message ? frame : "imu_frame"));  // 9 characters either way
  };
  if (order.empty()) {
    for (int i = 0; i < n; ++i) order.push_back(i);
  }
  for (const int i : order) {
    const ros::Time stamp = zero_stamps ? ros::Time(0, 0) : ros::Time(100.0 + 0.01 * i);
    std::vector<std::uint8_t> b(4 * 3 + 4 + 9 + 8 * (4 + 9 + 3 + 9 + 3 + 9));
    ros::serialization::OStream o(b.data(), static_cast<std::uint32_t>(b.size()));
    header(o, stamp.sec, stamp.nsec, i);
    const double values[] = {0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (double v : values) o.next(v);
    for (double v : {0.0, 0.01 * i, 0.0}) o.next(v);
    for (int k = 0; k < 9; ++k) o.next(0.0);
    for (double v : {0.1 * i, 0.0, 9.8}) o.next(v);
    for (int k = 0; k < 9; ++k) o.next(0.0);
    const ros::Time record(200.0 + 0.01 * i);
    for (const std::string& t : topics) bag.write(t, record, message("6a62c6daae103f4ff57a132d6f95cec2", "sensor_msgs/Imu", b));
    if (i % 100 == 0) {
      std::vector<std::uint8_t> tb(4 * 3 + 4 + 9 + 16);
      ros::serialization::OStream ot(tb.data(), static_cast<std::uint32_t>(tb.size()));
      header(ot, stamp.sec, stamp.nsec, i);
      ot.next(20.0 + i / 100);
      ot.next(0.0);
      bag.write("/temp", record, message("ff71b307acdbe7c871a5a6d7ed359100", "sensor_msgs/Temperature", tb));
    }
  }
  bag.close();
}

// Messages come in record-time order, as rosbag's View gives them, whatever order the file holds
// them in: chunks out of order (each read in turn by start time), and chunks overlapping in time
// (the messages gathered and sorted first, which the info event says).
TEST(Rosbag1, MessagesComeInTimeOrderWhateverTheFileOrder) {
  stend::testing::TempDir dir("rosbag1");
  std::vector<int> reversed, interleaved;
  for (int i = 299; i >= 0; --i) reversed.push_back(i);
  for (int i = 0; i < 300; i += 2) interleaved.push_back(i);
  for (int i = 1; i < 300; i += 2) interleaved.push_back(i);
  for (const auto& [name, order] : {std::pair{"reversed", reversed}, std::pair{"interleaved", interleaved}}) {
    SCOPED_TRACE(name);
    const fs::path file = dir / (std::string(name) + ".bag");
    write_ros1_bag(file, {"/imu"}, 300, false, rosbag::compression::LZ4, order);
    const Recording r = stend::io::import_rosbag1(file);
    ASSERT_EQ(r.samples.size(), 300u);
    for (std::size_t k = 0; k < r.samples.size(); ++k) {
      EXPECT_NEAR(r.samples[k].accel_mps2.x(), 0.1 * static_cast<double>(k), 1e-12) << k;
      EXPECT_NEAR(r.samples[k].t_s, 0.01 * static_cast<double>(k), 1e-6) << k;
    }
    const bool overlap = info_event(r).message.find("chunks overlap in time") != std::string::npos;
    EXPECT_EQ(overlap, std::string(name) == "interleaved") << info_event(r).message;
  }
}

// Crafted: three chunks of 10 000 messages each, every third message in each (all three span the
// whole bag): the messages are decoded once in storage order and then sorted. Taken in time order
// from the chunks, each message switched chunk and decompressed one again (2 of 3 held): quadratic
// in the bag's size: 66 s here (the bound is 5 s), 9 s for 12 000 messages.
TEST(Rosbag1, InterleavedChunksAreReadOnce) {
  stend::testing::TempDir dir("rosbag1");
  constexpr int kMessages = 30000;
  std::vector<int> order;
  for (int r = 0; r < 3; ++r)
    for (int i = r; i < kMessages; i += 3) order.push_back(i);
  const fs::path file = dir / "interleaved3.bag";
  write_ros1_bag(file, {"/imu"}, kMessages, false, rosbag::compression::LZ4, order, 10000 * 390);
  const auto start = std::chrono::steady_clock::now();
  const Recording r = stend::io::import_rosbag1(file);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
  ASSERT_EQ(r.samples.size(), static_cast<std::size_t>(kMessages));
  for (std::size_t k = 0; k < r.samples.size(); k += 997) EXPECT_NEAR(r.samples[k].accel_mps2.x(), 0.1 * static_cast<double>(k), 1e-9) << k;
  EXPECT_NE(info_event(r).message.find("chunks overlap in time"), std::string::npos) << info_event(r).message;
}

// Crafted: a frame_id per message, 100 000 of them. The first pass keeps the distinct ones in a set
// beside their list (they were searched for in the list: quadratic, 14 s for these, 3 s for half).
TEST(Rosbag1, AFrameIdPerMessageIsLinearInTime) {
  stend::testing::TempDir dir("rosbag1");
  constexpr int kMessages = 100000;
  const fs::path file = dir / "frames.bag";
  write_ros1_bag(file, {"/imu"}, kMessages, false, rosbag::compression::Uncompressed, {}, 1 << 20, true);
  const auto start = std::chrono::steady_clock::now();
  const Recording r = stend::io::import_rosbag1(file);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
  ASSERT_EQ(r.samples.size(), static_cast<std::size_t>(kMessages));
  EXPECT_EQ(r.header.identity.serial, "f00000000");
  EXPECT_NE(info_event(r).message.find("(100000 different frame_ids)"), std::string::npos) << info_event(r).message;
}

TEST(Rosbag1, WrittenBagKnownValuesAndTemperature) {
  stend::testing::TempDir dir("rosbag1");
  for (auto compression : {rosbag::compression::Uncompressed, rosbag::compression::BZ2, rosbag::compression::LZ4}) {
    const fs::path file = dir / ("imu" + std::to_string(static_cast<int>(compression)) + ".bag");
    write_ros1_bag(file, {"/imu"}, 500, false, compression);
    RosbagOptions opt;
    opt.temperature_topic = "/temp";
    const Recording r = stend::io::import_rosbag1(file, opt);
    ASSERT_EQ(r.samples.size(), 500u);
    EXPECT_NEAR(r.samples[250].t_s, 2.5, 1e-6);
    EXPECT_DOUBLE_EQ(r.samples[250].accel_mps2.x(), 25.0);
    EXPECT_DOUBLE_EQ(r.samples[250].accel_mps2.z(), 9.8);
    EXPECT_DOUBLE_EQ(r.samples[250].gyro_radps.y(), 2.5);
    EXPECT_TRUE(r.header.info.has_temperature);
    EXPECT_DOUBLE_EQ(r.samples[250].temperature_c, 22.0);  // the 1 Hz message at 2.0 s, held
    EXPECT_NEAR(r.header.info.output_rate_hz, 100.0, 1e-6);
    EXPECT_EQ(gap_count(r), 0u);
  }
}

TEST(Rosbag1, TopicChoiceZeroStampsAndBadFiles) {
  stend::testing::TempDir dir("rosbag1");
  const fs::path two = dir / "two.bag";
  write_ros1_bag(two, {"/imu_a", "/imu_b"}, 50, false, rosbag::compression::Uncompressed);
  std::string msg = import_error([&] { stend::io::import_rosbag1(two); });
  EXPECT_NE(msg.find("2 sensor_msgs/Imu topics: /imu_a /imu_b"), std::string::npos) << msg;
  RosbagOptions b;
  b.topic = "/imu_b";
  EXPECT_EQ(stend::io::import_rosbag1(two, b).samples.size(), 50u);
  b.topic = "/absent";
  msg = import_error([&] { stend::io::import_rosbag1(two, b); });
  EXPECT_NE(msg.find("topic /absent: no such topic"), std::string::npos) << msg;
  b.topic = "/temp";
  msg = import_error([&] { stend::io::import_rosbag1(two, b); });
  EXPECT_NE(msg.find("type sensor_msgs/Temperature, expected sensor_msgs/Imu"), std::string::npos) << msg;

  const fs::path zero = dir / "zero.bag";
  write_ros1_bag(zero, {"/imu"}, 50, true, rosbag::compression::Uncompressed);
  const Recording z = stend::io::import_rosbag1(zero);
  ASSERT_EQ(z.samples.size(), 50u);
  EXPECT_NEAR(z.samples[10].t_s, 0.1, 1e-6);  // record time 200 s + i·10 ms
  EXPECT_NE(info_event(z).message.find("record time"), std::string::npos) << info_event(z).message;

  const fs::path text = dir / "not_a_bag.bag";
  stend::testing::write_text(text, "#ROSBAG V1.2\nnot this version\n");
  EXPECT_FALSE(stend::io::looks_like_rosbag1(text));
  msg = import_error([&] { stend::io::import_rosbag1(text); });
  EXPECT_NE(msg.find(text.string() + ": byte 0: not a ROS 1 bag"), std::string::npos) << msg;

  const fs::path whole = dir / "whole.bag";
  write_ros1_bag(whole, {"/imu"}, 300, false, rosbag::compression::BZ2);
  expect_truncations_refused(whole, dir.path(), 40, [](const fs::path& f) { stend::io::import_rosbag1(f); });
  const fs::path cut = dir / "cut.bag";
  truncate_copy(whole, cut, fs::file_size(whole) / 2);
  msg = import_error([&] { stend::io::import_rosbag1(cut); });
  EXPECT_NE(msg.find("the bag header puts the index there, but the file ends at byte " +
                     std::to_string(fs::file_size(whole) / 2)),
            std::string::npos)
      << msg;
}

// ---------------------------------------------------------------------------------------------
// rosbag2

// The bags write_bags.cjs and write_db3.py write, once for the suite; empty with `skip` set
// when node or the npm packages are absent.
class Rosbag2 : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = std::make_unique<stend::testing::TempDir>("rosbag2");
    const char* cache = std::getenv("STEND_NODE_CACHE");
    const char* xdg = std::getenv("XDG_CACHE_HOME");
    const char* home = std::getenv("HOME");
    const fs::path base = cache ? fs::path(cache)
                                : (xdg ? fs::path(xdg) : fs::path(home ? home : "/nonexistent") / ".cache") / "stend/node";
    const fs::path modules = base / "rosbag2_writer/node_modules";
    if (stend::testing::run_command("command -v node").code != 0) {
      skip_ = "node is not installed";
      return;
    }
    if (!fs::exists(modules / "@mcap/core")) {
      skip_ = "npm packages absent in " + modules.string() + " (run scripts/install-node-test-deps.sh)";
      return;
    }
    const fs::path src = stend::testing::source_path("io/tests/rosbag2_writer");
    const auto node = stend::testing::run_command(
        "node " + stend::testing::shell_quote((src / "write_bags.cjs").string()) + " " + dir_->str(),
        {{"NODE_PATH", modules.string()}});
    ASSERT_EQ(node.code, 0) << node.text;
    const auto py = stend::testing::run_command("python3 " + stend::testing::shell_quote((src / "write_db3.py").string()) +
                                                " " + dir_->str());
    ASSERT_EQ(py.code, 0) << py.text;
  }
  static void TearDownTestSuite() { dir_.reset(); }
  void SetUp() override {
    if (!skip_.empty()) GTEST_SKIP() << "ROS 2 bag tests skipped: " << skip_;
  }
  static fs::path bag(const std::string& name) { return dir_->path() / name; }

  static std::unique_ptr<stend::testing::TempDir> dir_;
  static std::string skip_;
};
std::unique_ptr<stend::testing::TempDir> Rosbag2::dir_;
std::string Rosbag2::skip_;

// write_bags.cjs's messages: index i = 0…599 without 300…302; message 100 repeats 99's stamp.
std::vector<int> written_indices() {
  std::vector<int> v;
  for (int i = 0; i < 600; ++i) {
    if (i < 300 || i > 302) v.push_back(i);
  }
  return v;
}

void expect_written_content(const Recording& r, bool temperature) {
  const std::vector<int> idx = written_indices();
  ASSERT_EQ(r.samples.size(), idx.size());
  for (std::size_t k : {std::size_t{0}, std::size_t{57}, std::size_t{299}, std::size_t{300}, std::size_t{596}}) {
    const int i = idx[k];
    SCOPED_TRACE("message " + std::to_string(i));
    EXPECT_NEAR(r.samples[k].t_s, 0.005 * i, 1e-9);
    EXPECT_DOUBLE_EQ(r.samples[k].accel_mps2.x(), 0.01 * i);
    EXPECT_DOUBLE_EQ(r.samples[k].accel_mps2.y(), -0.02 * i);
    EXPECT_DOUBLE_EQ(r.samples[k].accel_mps2.z(), 9.81);
    EXPECT_DOUBLE_EQ(r.samples[k].gyro_radps.x(), 0.001 * i);
    EXPECT_DOUBLE_EQ(r.samples[k].gyro_radps.y(), 0.002);
    EXPECT_DOUBLE_EQ(r.samples[k].gyro_radps.z(), -0.003 * i);
    if (temperature) {
      EXPECT_NEAR(r.samples[k].temperature_c, 25.0 + 0.1 * (i / 20), 1e-9);
    }
  }
  EXPECT_DOUBLE_EQ(r.samples[100].t_s, r.samples[99].t_s);  // the repeated stamp, kept
  // Gaps: 299 → 303, and 100 → 101 (10 ms after the repeated stamp): the stamps as recorded.
  EXPECT_TRUE(r.samples[300].flags & stend::kGapBefore);
  EXPECT_TRUE(r.samples[101].flags & stend::kGapBefore);
  EXPECT_EQ(gap_count(r), 2u);
  EXPECT_NEAR(r.header.info.output_rate_hz, 200.0, 1e-6);
  EXPECT_EQ(r.header.identity.model, "/imu/data");
  EXPECT_EQ(r.header.identity.serial, "imu_link");
  const std::string& m = info_event(r).message;
  EXPECT_NE(m.find("1 timestamps do not increase"), std::string::npos) << m;
  EXPECT_NE(m.find("2 gap(s)"), std::string::npos) << m;
}

TEST_F(Rosbag2, McapEveryStorageLayout) {
  RosbagOptions opt;
  opt.temperature_topic = "/imu/temperature";
  for (const char* name : {"plain.mcap", "zstd.mcap", "lz4.mcap", "nosummary.mcap", "big_endian.mcap"}) {
    SCOPED_TRACE(name);
    if (!fs::exists(bag(name))) {
      ASSERT_STREQ(name, "lz4.mcap") << "not written";
      continue;  // the lz4 command was absent
    }
    EXPECT_TRUE(stend::io::looks_like_rosbag2(bag(name)));
    EXPECT_FALSE(stend::io::looks_like_rosbag1(bag(name)));
    const Recording r = stend::io::import_rosbag2(bag(name), opt);
    expect_written_content(r, true);
    const std::string& m = info_event(r).message;
    const std::string expected = std::string(name) == "zstd.mcap"  ? " zstd"
                                 : std::string(name) == "lz4.mcap"  ? " lz4"
                                 : std::string(name) == "plain.mcap" ? "outside chunks"
                                                                     : "MCAP";
    EXPECT_NE(m.find(expected), std::string::npos) << m;
  }
}

TEST_F(Rosbag2, SqliteBagFolderAndFile) {
  RosbagOptions opt;
  opt.temperature_topic = "/imu/temperature";
  const fs::path folder = bag("sqlite_bag");
  EXPECT_TRUE(stend::io::looks_like_rosbag2(folder));
  expect_written_content(stend::io::import_rosbag2(folder, opt), true);
  const fs::path db = folder / "sqlite_bag_0.db3";
  EXPECT_TRUE(stend::io::looks_like_rosbag2(db));
  expect_written_content(stend::io::import_rosbag2(db), false);
  // An SQLite database that is not a bag is not taken for one.
  const fs::path other = bag("other.db3");
  ASSERT_EQ(stend::testing::run_command("python3 -c \"import sqlite3; sqlite3.connect('" + other.string() +
                                        "').execute('CREATE TABLE t(x)')\"").code, 0);
  EXPECT_FALSE(stend::io::looks_like_rosbag2(other));
  RosbagOptions odom;
  odom.topic = "/odom";
  std::string msg = import_error([&] { stend::io::import_rosbag2(folder, odom); });
  EXPECT_NE(msg.find("type nav_msgs/msg/Odometry, expected sensor_msgs/msg/Imu"), std::string::npos) << msg;
  // A message cut short inside its CDR payload: the row and the bytes missing.
  const fs::path short_db = bag("short.db3");
  fs::copy_file(db, short_db, fs::copy_options::overwrite_existing);
  ASSERT_EQ(stend::testing::run_command("python3 -c \"import sqlite3; c = sqlite3.connect('" + short_db.string() +
                                        "'); c.execute('UPDATE messages SET data = substr(data, 1, 40) WHERE id = 5'); "
                                        "c.commit()\"").code, 0);
  msg = import_error([&] { stend::io::import_rosbag2(short_db); });
  EXPECT_NE(msg.find(short_db.string() + ": messages row id 5: topic /imu/data: ends at byte 40 of the payload"),
            std::string::npos)
      << msg;
}

// Crafted: 100 000 topics besides the bag's own, none with a message. Every topic is listed once,
// looked up in a set, in the first pass only (each pass listed them all, each searched for in the
// list: 84 s for these, 18 s for half).
TEST_F(Rosbag2, ManyTopicsAreListedInLinearTime) {
  const auto start = std::chrono::steady_clock::now();
  expect_written_content(stend::io::import_rosbag2(bag("many_topics.db3")), false);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
  RosbagOptions missing;
  missing.topic = "/none";
  const std::string msg = import_error([&] { stend::io::import_rosbag2(bag("many_topics.db3"), missing); });
  EXPECT_NE(msg.find("/crafted/topic_99999 (std_msgs/msg/String)"), std::string::npos) << msg.substr(0, 300);
}

// The Imu and Temperature cursors of a pass share one read of the storage while neither runs
// more than 16 384 messages ahead; past that the one behind reads a pass of its own, skipping what
// it took. Temperature 17 000 Imu messages apart, in time order (the Imu side leaves the shared
// pass after its first message) and reversed (the Temperature topic read whole first): the same
// samples and temperatures either way.
TEST_F(Rosbag2, SparseTemperatureBesideALongImuTopic) {
  RosbagOptions opt;
  opt.temperature_topic = "/imu/temperature";
  for (const char* name : {"long_temperature_sorted.db3", "long_temperature_reversed.db3"}) {
    SCOPED_TRACE(name);
    const Recording r = stend::io::import_rosbag2(bag(name), opt);
    ASSERT_EQ(r.samples.size(), 51000u);
    for (std::size_t i = 0; i < r.samples.size(); i += 1999) {
      EXPECT_NEAR(r.samples[i].t_s, 0.001 * static_cast<double>(i), 1e-9) << i;
      EXPECT_NEAR(r.samples[i].accel_mps2.x(), 0.1 * static_cast<double>(i), 1e-9) << i;
      EXPECT_DOUBLE_EQ(r.samples[i].temperature_c, 20.0 + static_cast<double>(i / 17000)) << i;
    }
    const bool whole = info_event(r).message.find("out of time order") != std::string::npos;
    EXPECT_EQ(whole, std::string(name) == "long_temperature_reversed.db3") << info_event(r).message;
  }
}

TEST_F(Rosbag2, TopicChoiceAndZeroStamps) {
  std::string msg = import_error([&] { stend::io::import_rosbag2(bag("two_imu.mcap")); });
  EXPECT_NE(msg.find("2 sensor_msgs/msg/Imu topics: /imu/data /imu2/data"), std::string::npos) << msg;
  RosbagOptions second;
  second.topic = "/imu2/data";
  EXPECT_EQ(stend::io::import_rosbag2(bag("two_imu.mcap"), second).samples.size(), 597u);
  second.topic = "/nope";
  msg = import_error([&] { stend::io::import_rosbag2(bag("two_imu.mcap"), second); });
  EXPECT_NE(msg.find("/nope: no such topic"), std::string::npos) << msg;

  // Zero header stamps: the log time (stamp + 1 ms) gives the same relative times.
  const Recording z = stend::io::import_rosbag2(bag("zero_stamps.mcap"));
  expect_written_content(z, false);
  EXPECT_NE(info_event(z).message.find("record time"), std::string::npos);
}

TEST_F(Rosbag2, BadFilesNameFileAndPlace) {
  stend::testing::TempDir dir("rosbag2_bad");
  for (const char* name : {"plain.mcap", "zstd.mcap", "nosummary.mcap"}) {
    expect_truncations_refused(bag(name), dir.path(), 60, [](const fs::path& f) { stend::io::import_rosbag2(f); });
  }
  // A truncation inside the first message's record names its byte offset.
  const fs::path cut = dir / "cut.mcap";
  truncate_copy(bag("plain.mcap"), cut, 3000);
  std::string msg = import_error([&] { stend::io::import_rosbag2(cut); });
  EXPECT_NE(msg.find(cut.string() + ": byte "), std::string::npos) << msg;
  EXPECT_NE(msg.find("truncated"), std::string::npos) << msg;

  // Wrong magic: not detected, and refused at byte 0.
  const fs::path wrong = dir / "wrong.mcap";
  fs::copy_file(bag("plain.mcap"), wrong);
  { std::fstream f(wrong, std::ios::in | std::ios::out | std::ios::binary); f.seekp(1); f.put('X'); }
  EXPECT_FALSE(stend::io::looks_like_rosbag2(wrong));
  msg = import_error([&] { stend::io::import_rosbag2(wrong); });
  EXPECT_NE(msg.find(wrong.string() + ": byte 0"), std::string::npos) << msg;

  // A corrupt byte inside a zstd chunk.
  const fs::path corrupt = dir / "corrupt.mcap";
  fs::copy_file(bag("zstd.mcap"), corrupt);
  { std::fstream f(corrupt, std::ios::in | std::ios::out | std::ios::binary); f.seekp(2000); f.put('\x55'); f.put('\xAA'); }
  msg = import_error([&] { stend::io::import_rosbag2(corrupt); });
  EXPECT_NE(msg.find(corrupt.string()), std::string::npos) << msg;

  // A truncated SQLite3 file.
  const fs::path db = dir / "cut.db3";
  truncate_copy(bag("sqlite_bag") / "sqlite_bag_0.db3", db, 20000);
  msg = import_error([&] { stend::io::import_rosbag2(db); });
  EXPECT_NE(msg.find(db.string()), std::string::npos) << msg;
}

}  // namespace

// Bags the fuzz target found (fuzz/regressions/, replayed by the fuzz ctests): a length beyond its
// bounds is refused with its offset before librosbag allocates 2 GB for an index record's header,
// or reads past a header (heap-buffer-overflow in ros::Header::parse).
TEST(Rosbag1, IndexRecordLengthBeyondTheEndIsRefusedBeforeOpening) {
  const fs::path bag = stend::testing::source_path("fuzz/regressions/import_rosbag1/index_header_2GB.bag");
  const std::string msg = import_error([&] { stend::io::import_rosbag1(bag); });
  // Its records are walked from the start now, and a chunk before the index is damaged too.
  EXPECT_NE(msg.find("byte 4117: a record's header declares 538976288 bytes, past the end of the file at byte 33316"),
            std::string::npos) << msg;
}

TEST(Rosbag1, HeaderFieldBeyondItsHeaderIsRefusedBeforeOpening) {
  const fs::path bag = stend::testing::source_path("fuzz/regressions/import_rosbag1/header_field_beyond_record.bag");
  const std::string msg = import_error([&] { stend::io::import_rosbag1(bag); });
  EXPECT_NE(msg.find("a header field declares"), std::string::npos) << msg;
  EXPECT_NE(msg.find("past the end of the record header at byte"), std::string::npos) << msg;

  // A field length of 2^32 - 4: "4 + length" in 32 bits wrapped to 0, and the walk stood still
  // (an endless loop in the index walk, found by the fuzz target). Lengths are 64-bit sums now.
  const fs::path wraps = stend::testing::source_path("fuzz/regressions/import_rosbag1/rosbag1_header_field_length_wraps.bag");
  const std::string wrap = import_error([&] { stend::io::import_rosbag1(wraps); });
  EXPECT_NE(wrap.find("byte 37: a header field declares 4294967292 bytes, past the end of the record header at byte 86"),
            std::string::npos) << wrap;
}

// The records librosbag reads at open time through the index are checked too: a chunk whose own
// header declares 3.3 GB (the fuzz target found it: librosbag allocated 4 GB to read it), a chunk
// info pointing into the middle of a record, a connection record whose data (the connection's
// header, which librosbag parses) holds a field longer than itself (ASan: ros::Header::parse read
// past its buffer), a chunk declaring more uncompressed bytes than its compressed ones can hold
// (librosbag allocates that size to decompress).
TEST(Rosbag1, EveryRecordTheIndexReachesIsCheckedBeforeOpening) {
  const auto refusal = [](const char* name) {
    const fs::path bag = stend::testing::source_path(std::string("fuzz/regressions/import_rosbag1/") + name);
    return import_error([&] { stend::io::import_rosbag1(bag); });
  };
  const std::string header = refusal("chunk_header_4GB.bag");
  EXPECT_NE(header.find("byte 4117: a record's header declares 3286536728 bytes, past the end of the file at byte 34621"),
            std::string::npos) << header;
  const std::string pos = refusal("chunk_pos_inside_a_record.bag");
  EXPECT_NE(pos.find("a chunk info points at byte 4125, where no record starts"), std::string::npos) << pos;
  const std::string conn = refusal("connection_header_field_beyond.bag");
  EXPECT_NE(conn.find("byte 28418: a header field declares 43576 bytes, past the end of the connection header at byte 28502"),
            std::string::npos) << conn;
  const std::string size = refusal("chunk_size_4GB.bag");
  EXPECT_NE(size.find("byte 4117: a chunk (bz2) declares 4026531840 uncompressed bytes, which its 496 stored bytes"),
            std::string::npos) << size;
}

// What is inside a chunk is checked too (librosbag read a message at an offset the index gave,
// past its chunk: ASan SEGV in Bag::readHeaderFromBuffer, found by the fuzz target): a chunk that
// does not decompress to its declared size, and a record inside a chunk longer than the chunk.
namespace {

// A little-endian uint32 at `at` of a bag's bytes.
std::uint32_t le32(const std::string& bytes, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = v << 8 | static_cast<std::uint8_t>(bytes[at + static_cast<std::size_t>(i)]);
  return v;
}

// Where a bag's first chunk record starts: after the 13-byte magic line and the bag header record
// (header length, header, data length, data).
std::size_t first_chunk(const std::string& bytes) {
  const std::size_t data_len_at = 13 + 4 + le32(bytes, 13);
  return data_len_at + 4 + le32(bytes, data_len_at);
}

}  // namespace

TEST(Rosbag1, ChunkContentsAreCheckedAndTheirDamageNamed) {
  const fs::path found = stend::testing::source_path("fuzz/regressions/import_rosbag1/message_index_into_damaged_chunk.bag");
  std::string msg = import_error([&] { stend::io::import_rosbag1(found); });
  EXPECT_NE(msg.find("chunk at byte 22425: bz2 data does not decompress to the chunk's declared 2207 bytes"),
            std::string::npos) << msg;

  stend::testing::TempDir dir("rosbag1");
  const fs::path plain = dir / "plain.bag";
  write_ros1_bag(plain, {"/imu"}, 50, false, rosbag::compression::Uncompressed);
  std::string bytes = stend::testing::read_text(plain);
  const std::size_t chunk = first_chunk(bytes);
  const std::size_t inside = chunk + 4 + le32(bytes, chunk) + 4;  // the records inside, after its header
  bytes[inside + 3] = '\x7f';  // the first inner record's header length: ~2 GB
  const fs::path damaged = dir / "damaged.bag";
  stend::testing::write_text(damaged, bytes);
  msg = import_error([&] { stend::io::import_rosbag1(damaged); });
  EXPECT_NE(msg.find("chunk at byte " + std::to_string(chunk) + ", byte 0 inside it: a record's header declares"),
            std::string::npos) << msg;
  EXPECT_NE(msg.find("past the chunk's end (damaged chunk)"), std::string::npos) << msg;
}

// An lz4 chunk's content checksum (XXH32 of the records, after the frame's end mark; verified by
// Stend, not liblz4) is checked: one bit of it changed, the chunk is refused as damaged.
TEST(Rosbag1, Lz4ChunkContentChecksumIsVerified) {
  stend::testing::TempDir dir("rosbag1");
  const fs::path good = dir / "lz4.bag";
  write_ros1_bag(good, {"/imu"}, 50, false, rosbag::compression::LZ4);
  ASSERT_EQ(stend::io::import_rosbag1(good).samples.size(), 50u);
  std::string bytes = stend::testing::read_text(good);
  const std::size_t chunk = first_chunk(bytes);
  const std::size_t data_len_at = chunk + 4 + le32(bytes, chunk);
  const std::size_t frame_end = data_len_at + 4 + le32(bytes, data_len_at);
  bytes[frame_end - 1] = static_cast<char>(bytes[frame_end - 1] ^ 0x01);  // the checksum's last byte
  const fs::path damaged = dir / "damaged.bag";
  stend::testing::write_text(damaged, bytes);
  const std::string msg = import_error([&] { stend::io::import_rosbag1(damaged); });
  EXPECT_NE(msg.find("chunk at byte " + std::to_string(chunk) + ": lz4 chunk: its content checksum does not match"),
            std::string::npos) << msg;
}

// An MCAP file the fuzz target found: a chunk declaring an uncompressed size its stored bytes
// cannot hold is refused with its place before the size is allocated (was std::bad_alloc).
TEST(Rosbag2Mcap, ChunkDeclaringMoreThanItsBytesHoldIsRefused) {
  const fs::path mcap = stend::testing::source_path("fuzz/regressions/import_rosbag2_mcap/chunk_declares_huge_size.mcap");
  const std::string msg = import_error([&] { stend::io::import_rosbag2(mcap); });
  EXPECT_NE(msg.find("uncompressed bytes, more than its"), std::string::npos) << msg;
  EXPECT_NE(msg.find("(damaged header)"), std::string::npos) << msg;
}

// A zstd frame can state any content size and fill it with run-length blocks of a few bytes each
// (the fuzz target made 1 GB from 50 kB): a chunk is decompressed whole, so one declaring more than
// 256 MiB is refused by its size before anything is allocated, naming the limit.
TEST(Rosbag2Mcap, ChunkLargerThanTheChunkLimitIsRefusedBeforeItIsAllocated) {
  const stend::testing::TempDir dir("mcap-limit");
  auto put = [](std::string& to, std::uint64_t v, int bytes) {  // little-endian
    for (int i = 0; i < bytes; ++i) to.push_back(static_cast<char>(v >> (8 * i)));
  };
  constexpr std::uint64_t kDeclared = std::uint64_t{300} << 20;
  std::string frame("\x28\xB5\x2F\xFD\xE0", 5);  // zstd magic; one segment, an 8-byte content size
  put(frame, kDeclared, 8);
  frame += std::string("\x0B\x00\x00\x00", 4);  // the last block: run-length, 1 byte
  std::string chunk;  // start and end time, uncompressed size, crc 0, compression, records
  put(chunk, 0, 8), put(chunk, 0, 8), put(chunk, kDeclared, 8), put(chunk, 0, 4), put(chunk, 4, 4);
  chunk += "zstd";
  put(chunk, frame.size(), 8);
  chunk += frame;
  std::string file("\x89MCAP0\r\n\x06", 9);  // magic, then a Chunk record
  put(file, chunk.size(), 8);
  file += chunk;
  const fs::path mcap = dir.path() / "big_chunk.mcap";
  stend::testing::write_text(mcap, file);
  const std::string msg = import_error([&] { stend::io::import_rosbag2(mcap); });
  EXPECT_NE(msg.find("chunk declares 314572800 uncompressed bytes, more than the 256 MiB Stend reads in one chunk"),
            std::string::npos) << msg;
}
