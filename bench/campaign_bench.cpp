// Campaign re-analysis and comparison at lab scale (docs/lab-scale.md, docs/benchmarks.md):
//   1. a campaign of N small simulated runs (default 1000: copies of one six-position unit)
//      re-fitted with `stend batch fit` on 1 and 2 local workers and through a Slurm job array
//      on a single-node cluster the bench starts (as the tests do; skipped, saying why, when it
//      cannot start; runs packed into array tasks automatically) — runs/s with the machine's load
//      average, and every run's results checked equal to one `stend fit` by hand;
//   2. `stend compare --procedure` over 10^5 stored parameter rows, SQLite and PostgreSQL
//      (a server started in a temporary folder): the median wall time of 5 calls.
//   build/bin/campaign_bench [--runs N] [--no-slurm] [--no-campaign]
#include "stend/estimators/builtin.hpp"
#include "stend/reporting/results_store.hpp"
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"
#include "stend/testing/services.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace fs = std::filesystem;
namespace rp = stend::reporting;
using stend::testing::ProgramOutput;
using stend::testing::shell_quote;

namespace {

constexpr int kCompareRuns = 5000, kCompareParametersPerRun = 20;  // 10^5 parameter rows
constexpr int kCompareRepeats = 5;

// The 1-minute load average (/proc/loadavg), "?" where there is none.
std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string one;
  return in >> one ? one : std::string("?");
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

ProgramOutput stend_cmd(const std::string& args, const stend::testing::Environment& env = {}) {
  return stend::testing::run_stend(args, env);
}

// Every run of the campaign has the hand fit's numbers (the copies hold the same recording).
std::size_t mismatches(const std::vector<fs::path>& runs, const rp::RunResults& by_hand) {
  std::size_t bad = 0;
  for (const auto& r : runs) {
    const rp::RunResults b = rp::load_run_results(r, stend::estimators::builtin());
    bool same = b.parameters.size() == by_hand.parameters.size();
    for (std::size_t i = 0; same && i < b.parameters.size(); ++i)
      same = b.parameters[i].identifiable == by_hand.parameters[i].identifiable &&
             (!b.parameters[i].identifiable || b.parameters[i].value == by_hand.parameters[i].value);
    bad += !same;
  }
  return bad;
}

void clear_fits(const std::vector<fs::path>& runs) {
  for (const auto& r : runs) {
    fs::remove(r / "fit.json");
    fs::remove(r / "fit.txt");
  }
}

void campaign(int n, bool with_slurm) {
  const stend::testing::TempDir tmp("campaign-bench");
  const std::string model = stend::testing::source_path("diagnosis/examples/bias_scale.yaml").string();
  ProgramOutput r = stend_cmd("run " + shell_quote(stend::testing::source_path("configs/six_position.yaml").string()) +
                              " -q -o " + shell_quote(tmp.str()) + " --name unit --db " +
                              shell_quote((tmp / "scratch.sqlite").string()));
  if (r.code != 0) throw std::runtime_error("stend run failed: " + r.text);
  r = stend_cmd("fit " + shell_quote((tmp / "unit").string()) + " -m " + shell_quote(model));
  if (r.code != 0) throw std::runtime_error("stend fit failed: " + r.text);
  const rp::RunResults by_hand = rp::load_run_results(tmp / "unit", stend::estimators::builtin());
  // One `stend fit` by hand, timed: the cost of one task.
  auto t0 = std::chrono::steady_clock::now();
  stend_cmd("fit " + shell_quote((tmp / "unit").string()) + " -m " + shell_quote(model));
  const double one_fit_s = seconds_since(t0);
  std::vector<fs::path> runs;
  std::string list;
  for (int i = 0; i < n; ++i) {
    runs.push_back(tmp / "campaign" / fmt::format("run-{:04}", i));
    fs::create_directories(runs.back().parent_path());
    fs::copy(tmp / "unit", runs.back(), fs::copy_options::recursive);
    list += runs.back().string() + "\n";
  }
  clear_fits(runs);
  stend::testing::write_text(tmp / "runs.txt", list);
  const std::string words = "$(cat " + shell_quote((tmp / "runs.txt").string()) + ")";
  fmt::print("campaign: {} runs (six-position, 200 Hz, 6 × 20 s), one `stend fit` by hand {:.3f} s\n", n, one_fit_s);
  fmt::print("| how | runs | wall [s] | runs/s | same as by hand | store rows (runs) | load avg before → after |\n"
             "|---|---|---|---|---|---|---|\n");
  auto measure = [&](const std::string& how, const std::string& args, const stend::testing::Environment& env) {
    clear_fits(runs);
    const std::string db = (tmp / fmt::format("{}.sqlite", how.substr(0, how.find(' ')))).string();
    fs::remove(db);
    const std::string load_before = load_average();
    const auto t = std::chrono::steady_clock::now();
    const ProgramOutput o = stend_cmd("batch fit " + words + " -m " + shell_quote(model) + " --db " + shell_quote(db) +
                                      " " + args, env);
    const double wall = seconds_since(t);
    if (o.code != 0) fmt::print(stderr, "{}: exit {}: {}\n", how, o.code, o.text.substr(o.text.size() > 2000 ? o.text.size() - 2000 : 0));
    fmt::print("| {} | {} | {:.1f} | {:.2f} | {} of {} | {} | {} → {} |\n", how, n, wall, n / wall,
               n - static_cast<int>(mismatches(runs, by_hand)), n, rp::ResultsStore(db).check().runs, load_before,
               load_average());
    std::fflush(stdout);
  };
  measure("local -j 1", "-j 1", {});
  measure("local -j 2", "-j 2", {});
  if (!with_slurm) return;
  stend::testing::TempSlurm slurm;
  if (!slurm.why_not().empty()) {
    fmt::print("slurm: skipped: {}\n", slurm.why_not());
    return;
  }
  measure("slurm array (2 CPUs, runs packed automatically)", "--slurm --out " + shell_quote((tmp / "slurm-job").string()), slurm.env());
}

rp::RunResults synthetic_run(int i) {
  rp::RunResults r;
  r.run_name = fmt::format("unit-{:05}", i);
  r.dir = "/lab/campaign/" + r.run_name;
  r.vendor = std::string("vendor-") + char('A' + i % 4);
  r.model = "M" + std::to_string(i % 4);
  r.serial = std::to_string(i);
  r.procedure_fingerprint = std::string(64, 'c');
  r.estimators = {{"batch_lsq", "1.0", "fit.json", "ok", ""}};
  for (int k = 0; k < kCompareParametersPerRun; ++k) {
    rp::ParameterResult p;
    p.estimator = "batch_lsq";
    p.name = "p" + std::to_string(k);
    p.unit = "m/s^2";
    p.identifiable = true;
    p.value = 0.01 * k + 1e-4 * (i % 97);
    p.std_error = 1e-4;
    p.lo = p.value - 2e-4;
    p.hi = p.value + 2e-4;
    p.confidence = 0.95;
    r.parameters.push_back(p);
  }
  return r;
}

void compare_at_scale() {
  const stend::testing::TempDir tmp("compare-bench");
  stend::testing::TempPostgres pg;
  // The SQLite file in /dev/shm when there is one: filling it is 5000 commits, each a disk sync
  // otherwise; what is measured is the query.
  const fs::path lite_dir = fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : tmp.path();
  const std::string lite = (lite_dir / ("stend-compare-bench-" + std::to_string(::getpid()) + ".sqlite")).string();
  struct Remove {
    std::string f;
    ~Remove() { fs::remove(f); }
  } remove{lite};
  std::vector<std::pair<std::string, std::string>> stores = {{"SQLite", lite}};
  if (pg.why_not().empty()) {
    ::setenv("PGPASSWORD", pg.password().c_str(), 1);
    stend_cmd("db migrate --db " + shell_quote(pg.url()), pg.env());
    stores.push_back({"PostgreSQL", pg.url()});
  } else {
    fmt::print("PostgreSQL: skipped: {}\n", pg.why_not());
  }
  fmt::print("\n| store | parameter rows | fill [s] | `stend compare --procedure` median of {} [s] | min | max |\n"
             "|---|---|---|---|---|---|\n",
             kCompareRepeats);
  for (const auto& [name, location] : stores) {
    auto t0 = std::chrono::steady_clock::now();
    {
      rp::ResultsStore store(location);
      for (int i = 0; i < kCompareRuns; ++i) store.add(synthetic_run(i));
    }
    const double fill = seconds_since(t0);
    std::vector<double> t;
    for (int k = 0; k < kCompareRepeats; ++k) {
      t0 = std::chrono::steady_clock::now();
      const ProgramOutput o = stend_cmd("compare --procedure cccccccc --db " + shell_quote(location) + " -o " +
                                            shell_quote((tmp / "compare.html").string()) + " > /dev/null",
                                        pg.env());
      t.push_back(seconds_since(t0));
      if (o.code != 0) fmt::print(stderr, "compare failed: {}\n", o.text);
    }
    std::sort(t.begin(), t.end());
    fmt::print("| {} | {} | {:.1f} | **{:.3f}** | {:.3f} | {:.3f} |\n", name, kCompareRuns * kCompareParametersPerRun,
               fill, t[t.size() / 2], t.front(), t.back());
  }
}

}  // namespace

int main(int argc, char** argv) {
  int n = 1000;
  bool slurm = true, campaign_too = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--runs" && i + 1 < argc) n = std::atoi(argv[++i]);
    else if (a == "--no-slurm") slurm = false;
    else if (a == "--no-campaign") campaign_too = false;
    else {
      fmt::print(stderr, "usage: campaign_bench [--runs N] [--no-slurm] [--no-campaign]\n");
      return 1;
    }
  }
  if (campaign_too) campaign(n, slurm);
  compare_at_scale();
  return 0;
}
