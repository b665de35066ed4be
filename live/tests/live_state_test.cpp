// The live view's state, server and run-folder feed: the JSON document the page draws (history
// kept bounded over a long run), the read-only server over real HTTP on the loopback interface,
// and a run folder read back (HDF5 and CSV) giving the same static means the run itself reported.
#include "stend/errors.hpp"
#include "stend/live/live_state.hpp"
#include "stend/live/run_folder_feed.hpp"
#include "stend/live/server.hpp"
#include "stend/testing/files.hpp"
#include "stend/testing/sim_bench.hpp"

#include <gtest/gtest.h>
#include <httplib.h>

#include <cmath>
#include <map>

namespace {

using nlohmann::json;

stend::RunProgress progress_at(double t) {
  stend::RunProgress p;
  p.step = 1;
  p.step_count = 2;
  p.phase = stend::RunPhase::kRecording;
  p.run_time_s = t;
  p.remaining_s = 100.0 - t;
  p.latest_t_s = t;
  p.latest = {0.1, 0.2, 9.8, 0.01, 0.02, 0.03};
  p.air_c = 20.0 + 0.01 * t;
  p.die_c = 21.0;
  p.setpoint_c = 25.0;
  p.truth_columns = {"air_c", "table.tilt.cmd_deg", "table.tilt.meas_deg"};
  p.truth = {20.0, 30.0, 29.5};
  return p;
}

// A short simulated run: a chamber step recorded while settling, then three orientations.
const char* kExperiment = R"(experiment: {name: live_feed, seed: 3}
bench:
  sensor: {plugin: sim_imu, config: {output_rate_hz: 100}}
  fixtures:
    - {id: table, plugin: sim_three_axis_table}
    - {id: chamber, plugin: sim_thermochamber, on: table, config: {initial_c: 24}}
  mounting: {on: chamber}
procedure:
  - set_temperature: {fixture: chamber, setpoint_c: 25, tolerance_c: 0.5, hold_s: 5}
  - orientations:
      fixture: table
      list: [{tilt_deg: 0, rotation_deg: 0}, {tilt_deg: 30, rotation_deg: 0}, {tilt_deg: 30, rotation_deg: 90}]
      dwell_s: 1
      record_s: 3
)";

}  // namespace

TEST(LiveState, DocumentCarriesTheSnapshotAndBoundedHistory) {
  stend::live::LiveLimits limits;
  limits.channel_points = 50;
  limits.temperature_points = 40;
  stend::live::LiveState state("r1", limits);
  for (int i = 0; i < 1000; ++i) {
    stend::RunProgress p = progress_at(0.1 * i);
    if (i >= 500) {
      p.closed_segment = i / 100;  // segments 5…9 closed along the way
      p.closed_mean = {1, 2, 3, 4, 5, 6};
    }
    state.update(p);
  }
  const json j = state.to_json();
  EXPECT_EQ(j["schema"], "stend.live/1");
  EXPECT_EQ(j["status"], "running");
  EXPECT_EQ(j["trace"]["t_s"].size(), 50u);  // a sliding window of the latest samples
  EXPECT_DOUBLE_EQ(j["trace"]["t_s"].back().get<double>(), 99.9);
  EXPECT_EQ(j["trace"]["az_mps2"].size(), 50u);
  // The whole run's temperatures, thinned: never more than the limit, first and recent points kept.
  const auto& tt = j["temperatures"]["t_s"];
  EXPECT_LT(tt.size(), 40u);
  EXPECT_GT(tt.size(), 10u);
  EXPECT_DOUBLE_EQ(tt.front().get<double>(), 0.0);
  EXPECT_GT(tt.back().get<double>(), 90.0);
  EXPECT_EQ(j["means"].size(), 5u);  // one per closed segment, not one per update
  EXPECT_EQ(j["table_deg"]["table.tilt"], 29.5);
  EXPECT_NEAR(j["fraction_done"].get<double>(), 0.999, 1e-9);
  EXPECT_TRUE(j["segment"]["mean"][0].is_null());  // NaN (no segment open) is null in JSON
  state.set_status(stend::RunStatus::kComplete);
  EXPECT_EQ(state.to_json()["status"], "complete");
  EXPECT_EQ(state.to_json()["remaining_s"], 0.0);
}

TEST(LiveServer, ServesThePageAndStateReadOnlyOnLoopback) {
  stend::live::LiveState state("served");
  state.update(progress_at(12.0));
  stend::live::LiveServerOptions o;
  o.port = 0;
  const stend::live::LiveServer server(state, o);
  ASSERT_GT(server.port(), 0);
  EXPECT_EQ(server.url(), "http://127.0.0.1:" + std::to_string(server.port()) + "/");
  httplib::Client c("127.0.0.1", server.port());
  const auto page = c.Get("/");
  ASSERT_TRUE(page) << "no answer from the live view";
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("/live.js"), std::string::npos);
  EXPECT_EQ(page->body.find("http"), std::string::npos) << "the page must load nothing from elsewhere";
  const auto st = c.Get("/api/state");
  ASSERT_TRUE(st);
  EXPECT_EQ(json::parse(st->body)["run"], "served");
  EXPECT_EQ(json::parse(st->body)["run_time_s"], 12.0);
  const auto js = c.Get("/uPlot.iife.min.js");
  ASSERT_TRUE(js);
  if (stend::live::charts_built_in()) {
    EXPECT_EQ(js->status, 200);
  }
  const auto post = c.Post("/api/state", "{}", "application/json");
  ASSERT_TRUE(post);
  EXPECT_EQ(post->status, 405);
  EXPECT_EQ(c.Get("/nothing-here")->status, 404);
  // Only a literal address is accepted, and a port that is taken is an I/O error naming it.
  stend::live::LiveServerOptions bad;
  bad.address = "localhost";
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("'localhost' is not an IP address"), std::string::npos) << why;
  EXPECT_THROW(stend::live::LiveServer(state, bad), stend::InputError);
  bad.address = "127.0.0.1";
  bad.port = 70000;
  EXPECT_FALSE(bad.IsValid());
  stend::live::LiveServerOptions taken;
  taken.port = server.port();
  EXPECT_THROW(stend::live::LiveServer(state, taken), stend::IoError);
}

class Feed : public ::testing::TestWithParam<stend::RecordingFormat> {};

TEST_P(Feed, RunFolderGivesTheMeansTheRunReported) {
  const stend::testing::TempDir dir("live-feed");
  const stend::Experiment exp =
      stend::parse_experiment(kExperiment, (dir / "x.yaml").string(), stend::testing::build_tree_plugins());
  std::map<int, std::array<double, 6>> reported;
  stend::RunOptions opt;
  opt.store.format = GetParam();
  opt.progress_period_s = 0.0;
  opt.on_progress = [&](const stend::RunProgress& p) {
    if (p.closed_segment >= 0) reported[p.closed_segment] = p.closed_mean;
  };
  const stend::RunResult r = stend::testing::run_in_process(exp, dir.path(), opt);
  ASSERT_EQ(r.status, stend::RunStatus::kComplete) << r.message;
  ASSERT_EQ(r.segments, 4);

  stend::live::LiveState state("feed");
  stend::live::RunFolderFeed feed(r.dir, exp.procedure);
  EXPECT_EQ(feed.refresh(state), stend::RunStatus::kComplete);
  const json j = state.to_json();
  EXPECT_EQ(j["status"], "complete");
  EXPECT_EQ(j["fraction_done"], 1.0);
  EXPECT_EQ(j["remaining_s"], 0.0);
  EXPECT_EQ(j["step"], 2);
  EXPECT_EQ(j["step_count"], 2);
  EXPECT_NEAR(j["setpoint_c"].get<double>(), 25.0, 1e-9);
  EXPECT_NEAR(j["air_c"].get<double>(), 25.0, 0.5);
  EXPECT_EQ(j["table_deg"].size(), 3u);  // the three-axis table's angles
  EXPECT_GT(j["trace"]["t_s"].size(), 100u);
  EXPECT_GT(j["temperatures"]["t_s"].size(), 10u);
  ASSERT_EQ(j["means"].size(), 4u);
  ASSERT_EQ(reported.size(), 4u);
  for (const auto& m : j["means"]) {
    const auto& want = reported.at(m["segment"].get<int>());
    for (std::size_t c = 0; c < 3; ++c)  // the same samples: specific force within 1 mg
      EXPECT_NEAR(m["mean"][c].get<double>(), want[c], 0.01) << "segment " << m["segment"] << " channel " << c;
  }
  // Tilted 30° about x: gravity leaves z for y (the run's own mean, read back from the folder).
  EXPECT_NEAR(j["means"][2]["mean"][2].get<double>(), 9.81 * std::cos(30 * M_PI / 180), 0.2);
}

INSTANTIATE_TEST_SUITE_P(Stores, Feed, ::testing::Values(stend::RecordingFormat::kHdf5, stend::RecordingFormat::kCsv),
                         [](const auto& p) { return std::string(stend::to_string(p.param)); });
