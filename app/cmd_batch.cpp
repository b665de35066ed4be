// `stend batch fit|gap|report (RUN… | --procedure FP) [--model M] [--db L] [--workers N]
// [--retries K] [--slurm --out DIR [--runs-per-task N]]` — campaign re-analysis: one task per run,
// each the very `stend` command one would type for that run (fit RUN -m M --db L …), run by a local
// worker pool or as a Slurm job array (sbatch) whose array tasks each run a chunk of those
// commands. Failed tasks are retried, then reported (docs/lab-scale.md).
#include "commands.hpp"

#include "stend/errors.hpp"
#include "stend/recording/files.hpp"
#include "stend/reporting/results_store.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

extern char** environ;

namespace stend::cli {

namespace {

namespace fs = std::filesystem;
namespace rp = stend::reporting;

// Lines of a failed task's output quoted in the report.
constexpr std::size_t kFailureTailLines = 4;
// Slurm, automatic packing: about this many array tasks per CPU the array may use, so that the
// scheduler starts a few jobs per CPU rather than one per run, yet a slow node still shares work.
constexpr std::size_t kArrayTasksPerSlot = 4;

struct BatchArgs {
  std::string verb;  // fit | gap | report
  std::vector<std::string> runs;
  std::string procedure, model, db, estimator, out, partition;
  unsigned workers = 0;  // 0: one per core
  unsigned runs_per_task = 0;  // Slurm: runs per array task; 0: automatic (kArrayTasksPerSlot)
  int retries = 1;
  bool slurm = false;
};

struct Task {
  std::string run;
  std::vector<std::string> argv;  // the stend command for this run (argv[0] = this program)
  int attempts = 0;
  int exit_code = -1;
  std::string output_tail;  // of the last failed attempt
};

struct Outcome {
  int code = -1;
  std::string output;
};

std::string shell_quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string command_line(const std::vector<std::string>& argv) {
  std::string line;
  for (const auto& a : argv) line += (line.empty() ? "" : " ") + shell_quoted(a);
  return line;
}

std::string tail(const std::string& text, std::size_t lines) {
  std::size_t pos = text.size();
  while (pos > 0 && text[pos - 1] == '\n') --pos;
  for (std::size_t n = 0; pos > 0; --pos)
    if (text[pos - 1] == '\n' && ++n == lines) break;
  std::string t = text.substr(pos);
  while (!t.empty() && t.back() == '\n') t.pop_back();
  return t;
}

// Runs argv with stdout and stderr captured; the exit code, or 128 + signal when killed.
Outcome run_program(const std::vector<std::string>& argv) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw IoError("stend batch: cannot create a pipe");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDERR_FILENO);
  std::vector<std::string> args = argv;
  std::vector<char*> cargs;
  for (auto& a : args) cargs.push_back(a.data());
  cargs.push_back(nullptr);
  pid_t pid = -1;
  const int rc = ::posix_spawnp(&pid, cargs[0], &actions, nullptr, cargs.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  if (rc != 0) {
    ::close(fds[0]);
    throw IoError(fmt::format("stend batch: cannot start {}: {}", argv[0], std::strerror(rc)));
  }
  Outcome out;
  char buf[4096];
  ssize_t n;
  while ((n = ::read(fds[0], buf, sizeof buf)) > 0 || (n < 0 && errno == EINTR))
    if (n > 0) out.output.append(buf, static_cast<std::size_t>(n));
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  out.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return out;
}

// ---- planning ----------------------------------------------------------------------------------

std::vector<std::string> runs_of(const BatchArgs& a) {
  std::vector<std::string> runs = a.runs;
  if (!a.procedure.empty()) {
    const rp::ResultsStore store(rp::results_store_location(a.db));
    const auto found = store.with_fingerprint(a.procedure);
    if (found.empty())
      throw InputError(fmt::format("stend batch: no run in {} has procedure fingerprint {}", store.where(), a.procedure));
    for (const auto& r : found) runs.push_back(r.dir.string());
  }
  if (runs.empty()) throw InputError("stend batch: no run given: name run folders or --procedure FINGERPRINT");
  return runs;
}

std::vector<Task> plan(const BatchArgs& a) {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw IoError("stend batch: cannot find this program (/proc/self/exe): " + ec.message());
  std::vector<Task> tasks;
  for (const auto& run : runs_of(a)) {
    Task t;
    t.run = run;
    t.argv = {self.string(), a.verb, run};
    if (!a.model.empty()) t.argv.insert(t.argv.end(), {"-m", a.model});
    if (a.verb == "fit" && !a.estimator.empty()) t.argv.insert(t.argv.end(), {"--estimator", a.estimator});
    t.argv.insert(t.argv.end(), {"--db", rp::results_store_location(a.db, run)});
    tasks.push_back(std::move(t));
  }
  return tasks;
}

// ---- local worker pool ---------------------------------------------------------------------------

void run_local(std::vector<Task>& tasks, const BatchArgs& a) {
  std::atomic<std::size_t> next{0};
  std::mutex print;
  std::size_t done = 0;
  auto worker = [&] {
    for (std::size_t i; (i = next++) < tasks.size();) {
      Task& t = tasks[i];
      for (t.attempts = 1;; ++t.attempts) {
        const Outcome o = run_program(t.argv);
        t.exit_code = o.code;
        if (o.code == 0) break;
        t.output_tail = tail(o.output, kFailureTailLines);
        if (t.attempts > a.retries) break;
      }
      const std::lock_guard<std::mutex> lock(print);
      fmt::print(human(), "[{}/{}] {} {}{}\n", ++done, tasks.size(), t.exit_code == 0 ? "ok    " : "FAILED", t.run,
                 t.attempts > 1 ? fmt::format(" (attempt {})", t.attempts) : "");
      std::fflush(human());
    }
  };
  const unsigned n = std::max(1u, std::min<unsigned>(a.workers ? a.workers : std::thread::hardware_concurrency(),
                                                     static_cast<unsigned>(tasks.size())));
  std::vector<std::thread> pool;
  for (unsigned w = 0; w < n; ++w) pool.emplace_back(worker);
  for (auto& th : pool) th.join();
}

// ---- Slurm job array -------------------------------------------------------------------------

// The job script: array task k runs the runs listed on line k + 1 of the chunk file ($1), one
// after another, each with its line of tasks.txt (the command the local pool runs), its output in
// logs/run-<i>.log and its exit code in status/<i>.rc (written then renamed, so a partial file is
// never read). The array task fails when one of its runs failed.
std::string job_script(const fs::path& out) {
  const std::string o = shell_quoted(out.string());
  return fmt::format(R"(#!/bin/bash
# stend batch: each array task runs a chunk of runs; each run's command is the one `stend batch` runs locally.
failed=0
for i in $(sed -n "$((SLURM_ARRAY_TASK_ID + 1))p" "$1"); do
  line=$(sed -n "$((i + 1))p" {0}/tasks.txt)
  (eval "$line") > {0}/logs/run-"$i".log 2>&1
  rc=$?
  [ "$rc" -eq 0 ] || failed=1
  echo "$rc" > {0}/status/"$i".rc.tmp && mv {0}/status/"$i".rc.tmp {0}/status/"$i".rc
done
exit "$failed"
)",
                     o);
}

// The CPUs of the partition (sinfo's total), 0 when sinfo cannot say.
unsigned partition_cpus(const std::string& partition) {
  std::vector<std::string> sinfo = {"sinfo", "-h", "-o", "%C"};
  if (!partition.empty()) sinfo.insert(sinfo.end(), {"-p", partition});
  const Outcome o = run_program(sinfo);  // "allocated/idle/other/total"
  const std::size_t slash = o.output.rfind('/');
  return o.code == 0 && slash != std::string::npos ? static_cast<unsigned>(std::atoi(o.output.c_str() + slash + 1)) : 0;
}

// Runs per array task: --runs-per-task, else enough that the array has about kArrayTasksPerSlot
// tasks per CPU it may use (-j, else the partition's CPUs), else (unknown) one.
std::size_t runs_per_array_task(std::size_t runs, const BatchArgs& a) {
  if (a.runs_per_task) return a.runs_per_task;
  const std::size_t slots = a.workers ? a.workers : partition_cpus(a.partition);
  if (slots == 0) return 1;
  const std::size_t array_tasks = kArrayTasksPerSlot * slots;
  return std::max<std::size_t>(1, (runs + array_tasks - 1) / array_tasks);
}

// The chunk file: line k = the task indices array task k runs.
std::string chunk_lines(const std::vector<std::size_t>& pending, std::size_t per_task) {
  std::string lines;
  for (std::size_t k = 0; k < pending.size(); ++k)
    lines += std::to_string(pending[k]) + ((k + 1) % per_task == 0 || k + 1 == pending.size() ? "\n" : " ");
  return lines;
}

// "0-3,7,9-10" (indices ascending), with "%N" when the array may run at most N tasks at once.
std::string array_spec(const std::vector<std::size_t>& indices, unsigned workers) {
  std::string spec;
  for (std::size_t k = 0; k < indices.size();) {
    std::size_t end = k;
    while (end + 1 < indices.size() && indices[end + 1] == indices[end] + 1) ++end;
    spec += (spec.empty() ? "" : ",") + std::to_string(indices[k]);
    if (end > k) spec += "-" + std::to_string(indices[end]);
    k = end + 1;
  }
  return workers ? fmt::format("{}%{}", spec, workers) : spec;
}

int read_status(const fs::path& file) {
  std::ifstream in(file);
  int rc = -1;
  return in >> rc ? rc : -1;
}

void run_slurm(std::vector<Task>& tasks, const BatchArgs& a) {
  if (a.out.empty()) throw InputError("stend batch --slurm: give --out DIR, a folder on storage the nodes share");
  const fs::path out = fs::absolute(a.out);
  fs::create_directories(out / "status");
  fs::create_directories(out / "logs");
  std::string lines;
  for (const auto& t : tasks) lines += command_line(t.argv) + "\n";
  write_file_atomic(out / "tasks.txt", lines);
  write_file_atomic(out / "stend-batch.sbatch", job_script(out));
  std::vector<std::size_t> pending(tasks.size());
  for (std::size_t i = 0; i < tasks.size(); ++i) pending[i] = i;
  for (int attempt = 1; !pending.empty() && attempt <= a.retries + 1; ++attempt) {
    // Only the runs still pending are (re)run, packed among themselves: a failed run's neighbours
    // in its first array task are not run again.
    for (std::size_t i : pending) fs::remove(out / "status" / fmt::format("{}.rc", i));
    const std::size_t per_task = runs_per_array_task(pending.size(), a);
    const std::size_t array_tasks = (pending.size() + per_task - 1) / per_task;
    const fs::path chunks = out / fmt::format("chunks-{}.txt", attempt);
    write_file_atomic(chunks, chunk_lines(pending, per_task));
    std::vector<std::size_t> array_indices(array_tasks);
    for (std::size_t k = 0; k < array_tasks; ++k) array_indices[k] = k;
    std::vector<std::string> sbatch = {"sbatch", "--wait", "--parsable", "--job-name=stend-batch",
                                       "--array=" + array_spec(array_indices, a.workers),
                                       "--output=" + (out / "logs" / fmt::format("array-{}-%a.log", attempt)).string()};
    if (!a.partition.empty()) sbatch.push_back("--partition=" + a.partition);
    sbatch.insert(sbatch.end(), {(out / "stend-batch.sbatch").string(), chunks.string()});
    const Outcome o = run_program(sbatch);  // --wait: exits non-zero when a task failed
    const std::string job = o.output.substr(0, o.output.find_first_of(";\n"));
    if (job.empty() || job.find_first_not_of("0123456789") != std::string::npos)
      throw IoError("stend batch --slurm: sbatch refused the job array: " + tail(o.output, 3) +
                    " (check `sinfo`, the partition and that slurmctld runs)");
    fmt::print(human(), "slurm job {} (attempt {}): {} task(s) in {} array task(s) of up to {} run(s)\n", job, attempt,
               pending.size(), array_tasks, per_task);
    std::fflush(human());
    std::vector<std::size_t> failed;
    for (std::size_t i : pending) {
      Task& t = tasks[i];
      t.attempts = attempt;
      t.exit_code = read_status(out / "status" / fmt::format("{}.rc", i));
      if (t.exit_code == 0) continue;
      std::ifstream log(out / "logs" / fmt::format("run-{}.log", i));
      std::stringstream text;
      text << log.rdbuf();
      t.output_tail = t.exit_code < 0 ? "no exit status: the task did not run to its end (see the node's log)"
                                      : tail(text.str(), kFailureTailLines);
      failed.push_back(i);
    }
    pending = failed;
  }
}

// ---- report ----------------------------------------------------------------------------------

ExitCode report(const std::vector<Task>& tasks, const BatchArgs& a, double wall_s) {
  std::size_t ok = 0, retried = 0;
  for (const auto& t : tasks) {
    ok += t.exit_code == 0;
    retried += t.attempts > 1;
  }
  for (const auto& t : tasks)
    if (t.exit_code != 0)
      fmt::print(human(), "failed:     {} (exit {} after {} attempt(s))\n  {}\n", t.run, t.exit_code, t.attempts,
                 [&] {
                   std::string s = t.output_tail;
                   for (std::size_t p = 0; (p = s.find('\n', p)) != std::string::npos; p += 3) s.replace(p, 1, "\n  ");
                   return s;
                 }());
  fmt::print(human(), "batch {}:  {} task(s) {}: {} ok, {} failed, {} retried; {:.2f} s, {:.2f} runs/s\n", a.verb, tasks.size(),
             a.slurm ? "on Slurm" : fmt::format("on {} local worker(s)", a.workers ? a.workers : std::thread::hardware_concurrency()),
             ok, tasks.size() - ok, retried, wall_s, wall_s > 0 ? static_cast<double>(tasks.size()) / wall_s : 0.0);
  // docs/schemas/batch.schema.json
  nlohmann::json js = nlohmann::json::array();
  for (const auto& t : tasks)
    js.push_back({{"run", t.run}, {"ok", t.exit_code == 0}, {"exit_code", t.exit_code}, {"attempts", t.attempts},
                  {"output_tail", t.exit_code == 0 ? nlohmann::json(nullptr) : nlohmann::json(t.output_tail)}});
  print_json({{"verb", a.verb}, {"ok", ok == tasks.size()}, {"where", a.slurm ? "slurm" : "local"}, {"tasks", js},
              {"succeeded", ok}, {"failed", tasks.size() - ok}, {"retried", retried}, {"wall_s", wall_s}});
  return ok == tasks.size() ? ExitCode::kOk : ExitCode::kFitFailed;
}

// What is wrong with the command line itself ("" when nothing is): exit 1, as for CLI11's errors.
std::string usage_problem(const BatchArgs& a) {
  if ((a.verb == "fit" || a.verb == "gap") && a.model.empty())
    return fmt::format("stend batch {}: give the model with -m MODEL.yaml", a.verb);
  if (a.runs.empty() && a.procedure.empty()) return "stend batch: no run given: name run folders or --procedure FINGERPRINT";
  if (a.slurm && a.out.empty()) return "stend batch --slurm: give --out DIR, a folder on storage the nodes share";
  return {};
}

}  // namespace

void add_batch_command(CLI::App& app, std::vector<Command>& out) {
  auto* sub = app.add_subcommand("batch", "Re-analyse a campaign: one `stend fit|gap|report` task per run, on local "
                                          "workers or a Slurm job array; failed tasks retried and reported");
  static BatchArgs a;
  sub->add_option("verb", a.verb, "fit | gap | report")->required()->check(CLI::IsMember({"fit", "gap", "report"}));
  sub->add_option("runs", a.runs, "Run folders (paths on storage every worker sees)");
  sub->add_option("--procedure", a.procedure, "Every run in the store with this procedure fingerprint (or a prefix of "
                                              "at least 8 hex digits)");
  sub->add_option("-m,--model", a.model, "Model YAML (fit, gap)");
  sub->add_option("--estimator", a.estimator, "fit: the estimator (default: the one the model file is written for)");
  sub->add_option("--db", a.db, kDbOptionHelp);
  sub->add_option("-j,--workers", a.workers, "Tasks at once (local: processes, default one per core; Slurm: the "
                                             "array's concurrency limit, default none)")
      ->check(at_least(1));
  sub->add_option("--retries", a.retries, "Times a failed task is run again (default 1)")->check(within(0, 10));
  sub->add_flag("--slurm", a.slurm, "Submit a Slurm job array (sbatch --wait) instead of running locally");
  sub->add_option("--partition", a.partition, "Slurm partition (default: the cluster's default)");
  sub->add_option("--runs-per-task", a.runs_per_task,
                  "Slurm: runs each array task runs one after another (default: about 4 array tasks per CPU "
                  "of -j or the partition)")
      ->check(at_least(1));
  sub->add_option("--out", a.out, "Slurm: folder on shared storage for the job script, task list, logs and statuses");
  add_json_flag(sub, "every task's outcome and the totals");
  out.push_back({sub, [] {
                   if (const std::string why = usage_problem(a); !why.empty()) {
                     fmt::print(stderr, "error: {}\n", why);  // a command line that is wrong: docs/errors.md
                     return ExitCode::kUsage;
                   }
                   std::vector<Task> tasks = plan(a);
                   const auto t0 = std::chrono::steady_clock::now();
                   if (a.slurm) run_slurm(tasks, a);
                   else run_local(tasks, a);
                   const double wall =
                       std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                   return report(tasks, a, wall);
                 }});
}

}  // namespace stend::cli
