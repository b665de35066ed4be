// Issue 37, the second hardening round, through the stend program: concurrent commands on one run
// take turns and leave whole results; a PostgreSQL server that stalls fails the command within its
// timeout; a run with no samples is reported; usage errors of batch exit 1; reading a store that
// is not there creates none; a cut-off results file is refused; validate refuses what the run's
// fit would refuse. docs/errors.md lists each.
#include <gtest/gtest.h>

#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"

#include <nlohmann/json.hpp>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using stend::testing::ProgramOutput;
using stend::testing::read_text;
using stend::testing::run_command;
using stend::testing::run_stend;
using stend::testing::shell_quote;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

const std::string src = STEND_SOURCE_DIR;
const std::string kBiasScale = src + "/diagnosis/examples/bias_scale.yaml";

bool has(const ProgramOutput& o, const std::string& s) { return o.text.find(s) != std::string::npos; }

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// One CSV run of the six-position test, fitted once.
class Hardening : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    tmp = std::make_unique<TempDir>("hardening");
    const ProgramOutput r = run_stend("run " + src + "/configs/six_position.yaml --quiet --store csv --output " +
                                      tmp->str() + " --name six");
    ASSERT_EQ(r.code, 0) << r.text;
    const ProgramOutput f = run_stend("fit " + run().string() + " -m " + kBiasScale + " --db " + db());
    ASSERT_EQ(f.code, 0) << f.text;
  }
  static void TearDownTestSuite() { tmp.reset(); }
  static fs::path run() { return *tmp / "six"; }
  static std::string db() { return (*tmp / "db.sqlite").string(); }
  static fs::path copy_of_run(const std::string& name) {
    const fs::path d = *tmp / name;
    fs::remove_all(d);
    fs::copy(run(), d, fs::copy_options::recursive);
    return d;
  }
  static std::unique_ptr<TempDir> tmp;
};
std::unique_ptr<TempDir> Hardening::tmp;

// A TCP port on 127.0.0.1 whose connections the kernel completes and nobody ever answers: a
// database server that accepts and stalls.
class StalledListener {
 public:
  StalledListener() : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd_, 16) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len) != 0)
      port_ = -1;
    else
      port_ = ntohs(a.sin_port);
  }
  ~StalledListener() { ::close(fd_); }
  StalledListener(const StalledListener&) = delete;
  StalledListener& operator=(const StalledListener&) = delete;
  int port() const { return port_; }

 private:
  int fd_;
  int port_ = -1;
};

}  // namespace

// ---- writers that cannot collide ----------------------------------------------------------------

TEST_F(Hardening, ConcurrentFitsAndReportsOnOneRunAllSucceedAndLeaveWholeResults) {
  const fs::path d = copy_of_run("concurrent");
  const std::string stend = shell_quote(stend::testing::stend_program().string());
  std::string script;
  for (int i = 0; i < 6; ++i)
    script += "(" + stend + " fit " + shell_quote(d.string()) + " -m " + shell_quote(kBiasScale) + " --db " +
              shell_quote(db()) + " > " + shell_quote((*tmp / ("fit" + std::to_string(i) + ".log")).string()) +
              " 2>&1; echo $? > " + shell_quote((*tmp / ("fit" + std::to_string(i) + ".rc")).string()) + ") & ";
  for (int i = 0; i < 4; ++i)
    script += "(" + stend + " report " + shell_quote(d.string()) + " --db " + shell_quote(db()) + " > " +
              shell_quote((*tmp / ("report" + std::to_string(i) + ".log")).string()) + " 2>&1; echo $? > " +
              shell_quote((*tmp / ("report" + std::to_string(i) + ".rc")).string()) + ") & ";
  script += "wait";
  ASSERT_EQ(run_command(script).code, 0);
  for (const std::string& what : std::vector<std::string>{"fit", "report"})
    for (int i = 0; i < (what == "fit" ? 6 : 4); ++i) {
      const std::string name = what + std::to_string(i);
      EXPECT_EQ(read_text(*tmp / (name + ".rc")), "0\n") << read_text(*tmp / (name + ".log"));
    }
  for (const auto& e : fs::directory_iterator(d)) {
    EXPECT_NE(e.path().extension(), ".tmp") << e.path();
    if (e.path().extension() == ".json") {
      EXPECT_FALSE(nlohmann::json::parse(read_text(e.path()), nullptr, false).is_discarded()) << e.path();
    }
  }
  EXPECT_NE(read_text(d / "report.html").find("</html>"), std::string::npos);
}

// ---- the live view: Ctrl-C ends `stend watch` at once, whatever its viewers do ---------------------

namespace {

// A viewer that connects to 127.0.0.1:`port` and then sends `text` (maybe nothing) and never more.
int idle_viewer(int port, const std::string& text) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 && !text.empty())
    (void)::send(fd, text.data(), text.size(), MSG_NOSIGNAL);
  return fd;
}

}  // namespace

TEST_F(Hardening, WatchEndsAtOnceOnCtrlCWithIdleAndSlowViewersConnected) {
  stend::testing::StartedCommand watch = stend::testing::start_stend("watch " + run().string() + " --port 0");
  const std::string port = watch.wait_for("live view: http://127\\.0\\.0\\.1:([0-9]+)/");
  ASSERT_FALSE(port.empty());
  std::vector<int> viewers;
  for (int i = 0; i < 16; ++i) viewers.push_back(idle_viewer(std::stoi(port), i % 2 ? "GET / HTTP/1.1\r\n" : ""));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const auto start = std::chrono::steady_clock::now();
  watch.interrupt();
  const ProgramOutput o = watch.finish();
  EXPECT_LT(seconds_since(start), 1.5) << o.text;  // the watch loop's tick (50 ms) and a prompt stop
  EXPECT_EQ(o.code, 0) << o.text;
  for (const int fd : viewers) ::close(fd);
}

// ---- PostgreSQL timeouts --------------------------------------------------------------------------

TEST(PostgresTimeouts, AServerThatAcceptsAndStallsFailsTheCommandWithinTheConnectTimeout) {
  const StalledListener server;
  ASSERT_GT(server.port(), 0);
  const std::string url = "postgresql://stend@127.0.0.1:" + std::to_string(server.port()) + "/stend";
  const std::string stend = shell_quote(stend::testing::stend_program().string());
  // The default (10 s): `timeout` ends a command that would hang, and the test then fails.
  auto start = std::chrono::steady_clock::now();
  const ProgramOutput d = run_command("exec timeout 60 " + stend + " db check --db " + shell_quote(url),
                                      {{"PGSSLMODE", "disable"}});
  EXPECT_LT(seconds_since(start), 25.0);
  EXPECT_EQ(d.code, 4) << d.text;
  EXPECT_TRUE(has(d, "cannot connect to the results store")) << d.text;
  EXPECT_TRUE(has(d, "connect_timeout 10 s by default")) << d.text;
  // The URL's own connect_timeout wins.
  start = std::chrono::steady_clock::now();
  const ProgramOutput o = run_command("exec timeout 60 " + stend + " db check --db " + shell_quote(url + "?connect_timeout=2"),
                                      {{"PGSSLMODE", "disable"}});
  EXPECT_LT(seconds_since(start), 8.0);
  EXPECT_EQ(o.code, 4) << o.text;
  EXPECT_TRUE(has(o, "connect_timeout as the URL")) << o.text;
}

// ---- a run with no samples --------------------------------------------------------------------------

TEST_F(Hardening, AReportOfARunWithNoSamplesSaysSoInsteadOfCrashing) {
  const fs::path d = copy_of_run("empty");
  const std::string imu = read_text(d / "imu.csv");
  write_text(d / "imu.csv", imu.substr(0, imu.find('\n') + 1));  // the column-name line only
  const ProgramOutput o = run_stend("report " + d.string() + " --no-db");
  EXPECT_NE(o.code, -1) << "ended by a signal:\n" << o.text;
  EXPECT_TRUE(o.code == 0 || o.code == 2) << o.text;
  if (o.code == 0) {
    EXPECT_NE(read_text(d / "report.html").find("The recording has no samples."), std::string::npos);
  }
}

// ---- smaller items --------------------------------------------------------------------------------

TEST_F(Hardening, BatchUsageErrorsExitOne) {
  const ProgramOutput no_model = run_stend("batch fit " + run().string());
  EXPECT_EQ(no_model.code, 1) << no_model.text;
  EXPECT_TRUE(has(no_model, "give the model with -m")) << no_model.text;
  const ProgramOutput no_run = run_stend("batch report");
  EXPECT_EQ(no_run.code, 1) << no_run.text;
  const ProgramOutput no_out = run_stend("batch report " + run().string() + " --slurm");
  EXPECT_EQ(no_out.code, 1) << no_out.text;
}

TEST_F(Hardening, CompareWithAStoreThatIsNotThereCreatesNone) {
  const fs::path missing = *tmp / "missing.sqlite";
  const ProgramOutput o = run_stend("compare --db " + missing.string());
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o, "no results store at " + missing.string())) << o.text;
  EXPECT_FALSE(fs::exists(missing));
}

TEST_F(Hardening, ACutOffResultsFileIsRefusedByReportAndExport) {
  const fs::path d = copy_of_run("cut");
  const std::string whole = read_text(d / "fit.json");
  ASSERT_FALSE(whole.empty());
  write_text(d / "fit.json", whole.substr(0, whole.size() / 2));
  for (const std::string& cmd : std::vector<std::string>{
           "report " + d.string() + " --no-db", "export " + d.string() + " --to json -o " + (*tmp / "cut.json").string()}) {
    const ProgramOutput o = run_stend(cmd);
    EXPECT_EQ(o.code, 2) << cmd << "\n" << o.text;
    EXPECT_TRUE(has(o, (d / "fit.json").string() + ":")) << o.text;
    EXPECT_TRUE(has(o, "the results file is cut off")) << o.text;
  }
}

TEST_F(Hardening, ValidateRefusesWhatTheRunsFitWouldRefuse) {
  const std::string base = read_text(src + "/configs/six_position.yaml");
  ASSERT_FALSE(base.empty());
  const fs::path unknown = *tmp / "unknown_key.yaml";
  write_text(unknown, base + "\nprocessing:\n  extraction: {settle_s: 1.0}\n  segmnets: [orientation]\n");
  const ProgramOutput u = run_stend("validate " + unknown.string());
  EXPECT_EQ(u.code, 2) << u.text;
  EXPECT_TRUE(has(u, unknown.string() + ":")) << u.text;
  EXPECT_TRUE(has(u, "segmnets")) << u.text;
  const fs::path no_model = *tmp / "no_model.yaml";
  write_text(no_model, base + "\nestimation:\n  model: no_such_model.yaml\n");
  const ProgramOutput m = run_stend("validate " + no_model.string());
  EXPECT_EQ(m.code, 2) << m.text;
  EXPECT_TRUE(has(m, "no_such_model.yaml' does not exist")) << m.text;
  const ProgramOutput r = run_stend("run " + no_model.string() + " --quiet --output " + (*tmp / "never").string());
  EXPECT_EQ(r.code, 2) << r.text;
  EXPECT_FALSE(fs::exists(*tmp / "never"));
}

TEST_F(Hardening, ARunMissingAnEventsFileOfNoRowsIsNotDamaged) {
  const fs::path d = copy_of_run("no_events");
  ASSERT_NE(read_text(run() / "run.json").find("\"event_count\": 0"), std::string::npos);
  fs::remove(d / "events.csv");
  const ProgramOutput o = run_stend("info " + d.string());
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_FALSE(has(o, "damaged")) << o.text;
  fs::remove(d / "segments.csv");  // 7 segments recorded: that one is missed
  EXPECT_TRUE(has(run_stend("info " + d.string()), "damaged")) << "a file with rows that is missing is damage";
}

TEST_F(Hardening, AModelFileThatIsADataFileIsQuotedCut) {
  std::string csv = "t,ax,ay,az\n";
  for (int i = 0; i < 2000; ++i) csv += std::to_string(i) + ",0.1,0.2,9.8\n";
  write_text(*tmp / "data.csv", csv);
  const ProgramOutput o = run_stend("fit " + run().string() + " --model " + (*tmp / "data.csv").string());
  EXPECT_EQ(o.code, 2) << o.text.substr(0, 2000);
  EXPECT_TRUE(has(o, " bytes)'")) << o.text.substr(0, 2000);  // stend::excerpt: "…(N bytes)"
  EXPECT_LT(o.text.size(), 600u) << o.text.substr(0, 2000);
}

TEST(Plugins, AWorldWritablePluginIsLoadedWithAWarning) {
  const TempDir dir("writable-plugin");
  const fs::path plugin = dir / "stend_good_copy.so";
  fs::copy_file(fs::path(STEND_BINARY_DIR) / "lib/stend/test-plugins/stend_good_sensor.so", plugin);
  const ProgramOutput safe = run_stend("plugins --path " + dir.str());
  EXPECT_EQ(safe.code, 0) << safe.text;
  EXPECT_FALSE(has(safe, "world-writable")) << safe.text;
  fs::permissions(plugin, fs::perms::others_write, fs::perm_options::add);
  const ProgramOutput file = run_stend("plugins --path " + dir.str());
  EXPECT_EQ(file.code, 0) << file.text;
  EXPECT_TRUE(has(file, "warning: " + plugin.string() + ": the plugin file is world-writable")) << file.text;
  fs::permissions(plugin, fs::perms::others_write, fs::perm_options::remove);
  fs::permissions(dir.path(), fs::perms::others_all | fs::perms::sticky_bit, fs::perm_options::add);
  const ProgramOutput folder = run_stend("plugins --path " + dir.str());
  EXPECT_TRUE(has(folder, "its folder " + dir.str() + " is world-writable")) << folder.text;
}

// An import stopped while it wrote: its run folder (as a CSV run, status still "running").
TEST(UnfinishedImport, IsRefusedByTheAnalysesAndNamedByANewImport) {
  const TempDir dir("unfinished-import");
  std::string log = "t,ax,ay,az,gx,gy,gz\n";
  for (int i = 0; i < 500; ++i) log += std::to_string(0.01 * i) + ",0.01,0.02,9.81,0.001,0.002,0.003\n";
  write_text(dir / "log.csv", log);
  const std::string import = "import " + (dir / "log.csv").string() + " --format csv --time t --accel ax,ay,az " +
                             "--gyro gx,gy,gz -o ";
  ASSERT_EQ(run_stend(import + (dir / "whole").string()).code, 0);
  ASSERT_EQ(run_stend("export " + (dir / "whole").string() + " --to csv -o " + (dir / "cut").string()).code, 0);
  const fs::path run_json = dir / "cut" / "run.json";
  std::string header = read_text(run_json);
  const auto at = header.find("\"status\": \"complete\"");
  ASSERT_NE(at, std::string::npos) << header;
  header.replace(at, std::string("\"status\": \"complete\"").size(), "\"status\": \"running\"");
  write_text(run_json, header);
  const std::string allan = src + "/estimators/allan/example/allan.yaml";
  const ProgramOutput fit = run_stend("fit " + (dir / "cut").string() + " -m " + allan);
  EXPECT_EQ(fit.code, 2) << fit.text;
  EXPECT_TRUE(has(fit, "the import into this run folder did not finish (status running")) << fit.text;
  const ProgramOutput again = run_stend(import + (dir / "cut").string());
  EXPECT_EQ(again.code, 2) << again.text;
  EXPECT_TRUE(has(again, "did not finish")) << again.text;
  EXPECT_TRUE(has(again, "remove the folder and import again")) << again.text;
}

// The disk fills (a file-size limit) while an import writes run.h5: exit 4 with the system's
// reason, the folder removed, and no crash in libhdf5's exit handler.
TEST(FullDisk, AnImportThatCannotWriteItsRunFailsCleanly) {
  const TempDir dir("full-disk");
  std::string log = "t,ax,ay,az,gx,gy,gz\n";
  for (int i = 0; i < 200000; ++i)
    log += std::to_string(0.01 * i) + "," + std::to_string(0.01 + 1e-6 * (i % 977)) + ",0.02,9.81,0.001,0.002," +
           std::to_string(1e-5 * (i % 613)) + "\n";
  write_text(dir / "log.csv", log);
  const fs::path out = dir / "imported";
  const ProgramOutput o = run_command("trap '' XFSZ; ulimit -f 20; exec " + shell_quote(stend::testing::stend_program().string()) +
                                      " import " + shell_quote((dir / "log.csv").string()) +
                                      " --format csv --time t --accel ax,ay,az --gyro gx,gy,gz -o " + shell_quote(out.string()));
  EXPECT_EQ(o.code, 4) << o.text.substr(0, 2000);
  EXPECT_TRUE(has(o, "run.h5: cannot ")) << o.text.substr(0, 2000);  // a dataset, the SWMR start, …
  EXPECT_TRUE(has(o, "File too large")) << o.text.substr(0, 2000);
  EXPECT_FALSE(has(o, "errno =")) << "libhdf5's raw text: " << o.text.substr(0, 2000);
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(Hardening, InfoCountsTheTruthRowsOfACsvRun) {
  const ProgramOutput o = run_command(shell_quote(stend::testing::stend_program().string()) + " info --json " +
                                      shell_quote(run().string()) + " 2>/dev/null");
  ASSERT_EQ(o.code, 0) << o.text;
  const nlohmann::json j = nlohmann::json::parse(o.text, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << o.text;
  const std::string truth = read_text(run() / "truth.csv");
  const auto lines = static_cast<std::uint64_t>(std::count(truth.begin(), truth.end(), '\n'));
  ASSERT_GT(lines, 1u);
  EXPECT_EQ(j["truth_rows"].get<std::uint64_t>(), lines - 1) << "the column-name line and every row";
}
