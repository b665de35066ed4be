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

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <thread>
#include <vector>

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
  EXPECT_EQ(j["message"], "");
  if (GetParam() == stend::RecordingFormat::kCsv) {  // cut mid-way: rows missing against run.json
    const std::string imu = stend::testing::read_text(r.dir / "imu.csv");
    stend::testing::write_text(r.dir / "imu.csv", imu.substr(0, imu.size() / 2));
    feed.refresh(state);
    const std::string message = state.to_json()["message"].get<std::string>();
    EXPECT_NE(message.find("damaged: "), std::string::npos) << message;
  }
}

INSTANTIATE_TEST_SUITE_P(Stores, Feed, ::testing::Values(stend::RecordingFormat::kHdf5, stend::RecordingFormat::kCsv),
                         [](const auto& p) { return std::string(stend::to_string(p.param)); });

// ---- the server's limits (docs/live-view.md, "Limits") -------------------------------------------

namespace {

// A raw TCP connection to the live view on 127.0.0.1, for clients no library would be: idle, slow,
// sending a body it never finishes or a Host of another name.
class RawClient {
 public:
  explicit RawClient(int port) : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  ~RawClient() { ::close(fd_); }
  RawClient(const RawClient&) = delete;
  RawClient& operator=(const RawClient&) = delete;
  bool connected() const { return connected_; }
  bool send(const std::string& text) { return ::send(fd_, text.data(), text.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(text.size()); }
  // What the server says within `wait` (until it closes the connection, or the time is up).
  std::string answer(std::chrono::milliseconds wait) {
    std::string got;
    const auto until = std::chrono::steady_clock::now() + wait;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - std::chrono::steady_clock::now());
      if (left.count() <= 0) return got;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) return got;
      char buf[4096];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) return got;
      got.append(buf, static_cast<std::size_t>(n));
    }
  }

 private:
  int fd_;
  bool connected_ = false;
};

std::string get_request(const std::string& path, const std::string& host) {
  return "GET " + path + " HTTP/1.1\r\nHost: " + host + "\r\nConnection: close\r\n\r\n";
}

struct Served {
  stend::live::LiveState state{"limits"};
  std::unique_ptr<stend::live::LiveServer> server;
  Served() {
    state.update(progress_at(3.0));
    stend::live::LiveServerOptions o;
    o.port = 0;
    server = std::make_unique<stend::live::LiveServer>(state, o);
  }
  int port() const { return server->port(); }
  std::string host() const { return "127.0.0.1:" + std::to_string(port()); }
};

bool starts_with(const std::string& s, const std::string& head) { return s.rfind(head, 0) == 0; }

}  // namespace

TEST(LiveServerLimits, AHugePostIsRefusedBeforeItsBodyIsRead) {
  Served s;
  RawClient c(s.port());
  ASSERT_TRUE(c.connected());
  // A gigabyte announced, a few kilobytes sent: the answer comes at once, the body is never read.
  ASSERT_TRUE(c.send("POST /api/state HTTP/1.1\r\nHost: " + s.host() + "\r\nContent-Length: 1000000000\r\n\r\n" +
                     std::string(4096, 'x')));
  const std::string a = c.answer(std::chrono::milliseconds(1500));
  EXPECT_TRUE(starts_with(a, "HTTP/1.1 405")) << a;
  // A GET with a body too.
  RawClient g(s.port());
  ASSERT_TRUE(g.send("GET /api/state HTTP/1.1\r\nHost: " + s.host() + "\r\nContent-Length: 400000000\r\n\r\n"));
  const std::string b = g.answer(std::chrono::milliseconds(1500));
  EXPECT_TRUE(starts_with(b, "HTTP/1.1 413")) << b;
  // Headers beyond the request budget end the connection without an answer of 200.
  RawClient h(s.port());
  h.send("GET / HTTP/1.1\r\nHost: " + s.host() + "\r\n");
  for (int i = 0; i < 100 && h.send("X-Filler: " + std::string(1000, 'y') + "\r\n"); ++i) {}
  EXPECT_FALSE(starts_with(h.answer(std::chrono::milliseconds(1500)), "HTTP/1.1 200"));
}

TEST(LiveServerLimits, AHostOfAnotherNameIsRefused) {
  Served s;
  for (const std::string& host : std::vector<std::string>{"evil.example:" + std::to_string(s.port()), "evil.example", ""}) {
    RawClient c(s.port());
    ASSERT_TRUE(c.send(get_request("/api/state", host)));
    const std::string a = c.answer(std::chrono::milliseconds(1500));
    EXPECT_TRUE(starts_with(a, "HTTP/1.1 403")) << host << ": " << a;
    EXPECT_EQ(a.find("\"run\""), std::string::npos) << "the state leaked to " << host;
  }
  for (const std::string& host : std::vector<std::string>{s.host(), "localhost:" + std::to_string(s.port()), "[::1]:80"}) {
    RawClient c(s.port());
    ASSERT_TRUE(c.send(get_request("/api/state", host)));
    EXPECT_TRUE(starts_with(c.answer(std::chrono::milliseconds(1500)), "HTTP/1.1 200")) << host;
  }
}

TEST(LiveServerLimits, IdleClientsDoNotDelayANewOne) {
  Served s;
  std::vector<std::unique_ptr<RawClient>> idle;
  for (int i = 0; i < 48; ++i) {  // more than the server serves at once
    idle.push_back(std::make_unique<RawClient>(s.port()));
    if (i % 2 == 1) idle.back()->send("GET / HTTP/1.1\r\n");  // half of them slow: a request begun
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const auto start = std::chrono::steady_clock::now();
  RawClient c(s.port());
  ASSERT_TRUE(c.send(get_request("/api/state", s.host())));
  const std::string a = c.answer(std::chrono::milliseconds(3000));
  const auto took = std::chrono::steady_clock::now() - start;
  EXPECT_TRUE(starts_with(a, "HTTP/1.1 200")) << a;
  EXPECT_LT(took, std::chrono::milliseconds(1000));
  const auto stopping = std::chrono::steady_clock::now();
  s.server.reset();
  EXPECT_LT(std::chrono::steady_clock::now() - stopping, std::chrono::milliseconds(500));
}

TEST(LiveServerLimits, StopsAtOnceWithIdleAndSlowClientsConnected) {
  auto s = std::make_unique<Served>();
  std::vector<std::unique_ptr<RawClient>> idle;
  for (int i = 0; i < 12; ++i) {
    idle.push_back(std::make_unique<RawClient>(s->port()));
    if (i % 3 == 0) idle.back()->send("GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n");  // never finished
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const auto start = std::chrono::steady_clock::now();
  s.reset();
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(500));
}
