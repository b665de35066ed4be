// End-to-end: `stend run --live` on a wall-clock run, loaded in headless Chromium while the run
// goes on (the page updates, no console messages, a screenshot shows the three accelerometer
// traces), and `stend watch` on the finished run folder serving the same page.
#include "stend/testing/browser.hpp"
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <thread>

namespace {

using nlohmann::json;
using stend::testing::shell_quote;

// About 20 s of wall time: the chamber held at 25 °C, then three table positions.
const char* kExperiment = R"(experiment: {name: live_wall, seed: 5, clock: wall}
bench:
  sensor: {plugin: sim_imu, config: {output_rate_hz: 100}}
  fixtures:
    - {id: table, plugin: sim_three_axis_table}
    - {id: chamber, plugin: sim_thermochamber, on: table, config: {initial_c: 25}}
  mounting: {on: chamber}
procedure:
  - set_temperature: {fixture: chamber, setpoint_c: 25, tolerance_c: 0.5, hold_s: 4}
  - orientations:
      fixture: table
      list: [{tilt_deg: 0, rotation_deg: 0}, {tilt_deg: 20, rotation_deg: 0}, {tilt_deg: 20, rotation_deg: 40}]
      dwell_s: 0.5
      record_s: 3
outputs: {report: false}
)";

json state_of(int port) {
  httplib::Client c("127.0.0.1", port);
  const auto r = c.Get("/api/state");
  return r && r->status == 200 ? json::parse(r->body) : json();
}

int port_of(const std::string& url) {
  std::smatch m;
  return std::regex_search(url, m, std::regex(":(\\d+)/")) ? std::stoi(m[1]) : 0;
}

// The number the page shows in an element: <span id="updates">12</span>.
int shown_count(const std::string& dom, const std::string& id) {
  std::smatch m;
  return std::regex_search(dom, m, std::regex("id=\"" + id + "\"[^>]*>(\\d+)<")) ? std::stoi(m[1]) : -1;
}

std::string shown_text(const std::string& dom, const std::string& id) {
  std::smatch m;
  return std::regex_search(dom, m, std::regex("id=\"" + id + "\"[^>]*>([^<]*)<")) ? std::string(m[1]) : "";
}

// The page's three accelerometer traces (x red, y green, z blue) and the chamber's air temperature.
void expect_traces(const std::filesystem::path& png, const std::string& what) {
  stend::testing::Image img;
  ASSERT_TRUE(stend::testing::read_png(png, img)) << "cannot decode " << png;
  EXPECT_GT(stend::testing::count_colour(img, 0xd62728), 150u) << what << ": no x trace (red)";
  EXPECT_GT(stend::testing::count_colour(img, 0x2ca02c), 150u) << what << ": no y trace (green)";
  EXPECT_GT(stend::testing::count_colour(img, 0x1f77b4), 150u) << what << ": no z trace (blue)";
}

}  // namespace

TEST(LiveView, PageUpdatesDuringAWallClockRunAndWatchServesTheFolder) {
  const std::string chromium = stend::testing::find_chromium();
  if (chromium.empty()) GTEST_SKIP() << "chromium is not installed (Debian package 'chromium'): browser check skipped";
  const stend::testing::TempDir dir("live-view");
  stend::testing::write_text(dir / "live.yaml", kExperiment);
  auto run = stend::testing::start_stend("run " + shell_quote((dir / "live.yaml").string()) + " -o " +
                                         shell_quote(dir.str()) + " --name live --live --port 0");
  const std::string url = run.wait_for("live view: (http://127\\.0\\.0\\.1:[0-9]+/)");
  ASSERT_FALSE(url.empty()) << run.finish().text;
  const int port = port_of(url);

  // The state advances with the run.
  const json s1 = state_of(port);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const json s2 = state_of(port);
  ASSERT_FALSE(s1.is_null());
  EXPECT_EQ(s2["status"], "running");
  EXPECT_GT(s2["run_time_s"].get<double>(), s1["run_time_s"].get<double>());
  EXPECT_GT(s2["remaining_s"].get<double>(), 0.0);

  // The page, loaded twice while the run goes on: it draws the state, and the state it draws moves.
  const auto b1 = stend::testing::headless_chromium(url, 2500);
  ASSERT_EQ(b1.code, 0) << b1.log;
  EXPECT_TRUE(b1.console.empty()) << "console messages:\n" << b1.console;
  EXPECT_GE(shown_count(b1.dom, "updates"), 1) << b1.dom;
  EXPECT_NE(shown_text(b1.dom, "status").find("running"), std::string::npos) << b1.dom;
  const std::string progress1 = shown_text(b1.dom, "progress-text");
  EXPECT_NE(progress1.find("left"), std::string::npos) << progress1;
  for (int i = 0; i < 100 && state_of(port).value("run_time_s", 0.0) < 9.0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const std::filesystem::path shot = dir / "live.png";
  const auto b2 = stend::testing::headless_chromium(url, 2500, shot);
  ASSERT_EQ(b2.code, 0) << b2.log;
  EXPECT_TRUE(b2.console.empty()) << "console messages:\n" << b2.console;
  expect_traces(shot, "stend run --live");
  const auto b3 = stend::testing::headless_chromium(url, 2500);
  EXPECT_NE(shown_text(b3.dom, "progress-text"), progress1) << "the page did not change while the run went on";
  EXPECT_NE(shown_text(b3.dom, "step").find("orientations"), std::string::npos) << b3.dom;

  const auto done = run.finish();
  ASSERT_EQ(done.code, 0) << done.text;

  // stend watch on the finished folder: the same page, the run complete with its four segments.
  auto watch = stend::testing::start_stend("watch " + shell_quote((dir / "live").string()) + " --port 0");
  const std::string watch_url = watch.wait_for("live view: (http://127\\.0\\.0\\.1:[0-9]+/)");
  ASSERT_FALSE(watch_url.empty()) << watch.finish().text;
  const json w = state_of(port_of(watch_url));
  EXPECT_EQ(w["status"], "complete");
  EXPECT_EQ(w["fraction_done"], 1.0);
  EXPECT_EQ(w["step"], 2);
  EXPECT_EQ(w["means"].size(), 4u);
  const std::filesystem::path watch_shot = dir / "watch.png";
  const auto b4 = stend::testing::headless_chromium(watch_url, 2500, watch_shot);
  ASSERT_EQ(b4.code, 0) << b4.log;
  EXPECT_TRUE(b4.console.empty()) << "console messages:\n" << b4.console;
  expect_traces(watch_shot, "stend watch");
  watch.interrupt();  // Ctrl-C ends stend watch normally
  EXPECT_EQ(watch.finish().code, 0);
  if (const char* keep = std::getenv("STEND_LIVE_SCREENSHOTS")) {  // for looking at them
    std::filesystem::copy_file(shot, std::filesystem::path(keep) / "live.png", std::filesystem::copy_options::overwrite_existing);
    std::filesystem::copy_file(watch_shot, std::filesystem::path(keep) / "watch.png",
                               std::filesystem::copy_options::overwrite_existing);
  }
}
