// Real PostgreSQL and Slurm servers for tests (services.hpp).
#include "stend/testing/services.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

namespace stend::testing {

namespace fs = std::filesystem;

namespace {

// Tries of a server start on a fresh free port (another process may take the port meanwhile).
constexpr int kStartTries = 3;
// How long a started Slurm node may take to report itself idle [s].
constexpr double kSlurmReadyTimeoutS = 30.0;

std::string random_hex(std::size_t n) {
  std::random_device rd;
  std::string s;
  for (std::size_t i = 0; i < n; ++i) s += "0123456789abcdef"[rd() % 16];
  return s;
}

std::string first_line(const std::string& text) { return text.substr(0, text.find('\n')); }

std::string last_lines(const std::string& text, std::size_t lines = 3) {
  std::size_t pos = text.size();
  while (pos > 0 && text[pos - 1] == '\n') --pos;
  for (std::size_t n = 0; pos > 0; --pos)
    if (text[pos - 1] == '\n' && ++n == lines) break;
  return text.substr(pos);
}

// The newest PostgreSQL server's bin folder (Debian: /usr/lib/postgresql/<major>/bin), "" if none.
std::string postgres_bin() {
  std::string best;
  int best_major = -1;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/usr/lib/postgresql", ec)) {
    const fs::path bin = e.path() / "bin";
    if (!fs::exists(bin / "initdb") || !fs::exists(bin / "pg_ctl")) continue;
    const int major = std::atoi(e.path().filename().c_str());
    if (major > best_major) best_major = major, best = bin.string();
  }
  return best;
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p);
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return s;
}

}  // namespace

int free_loopback_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return 0;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  socklen_t len = sizeof a;
  int port = 0;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0)
    port = ntohs(a.sin_port);
  ::close(fd);
  return port;
}

// ---- PostgreSQL --------------------------------------------------------------------------------

TempPostgres::TempPostgres() {
  bin_ = postgres_bin();
  if (bin_.empty()) {
    why_not_ = "PostgreSQL server not installed (no /usr/lib/postgresql/*/bin/initdb; scripts/install-deps.sh "
               "installs Debian's postgresql): PostgreSQL store test skipped";
    return;
  }
  if (::geteuid() == 0) {
    const passwd* pw = ::getpwnam("nobody");
    if (pw == nullptr) {
      why_not_ = "running as root and no user `nobody` to run the PostgreSQL server as";
      return;
    }
    as_user_ = "setpriv --reuid=nobody --regid=" + std::to_string(pw->pw_gid) + " --clear-groups -- ";
  }
  dir_ = std::make_unique<TempDir>("pg");
  fs::permissions(dir_->path(), fs::perms::owner_all | fs::perms::group_exec | fs::perms::others_exec);
  password_ = random_hex(24);
  write_text(*dir_ / "pw", password_ + "\n");
  fs::create_directory(*dir_ / "data");
  if (!as_user_.empty()) {
    const passwd* pw = ::getpwnam("nobody");
    for (const char* f : {"pw", "data"})
      if (::chown((*dir_ / f).c_str(), pw->pw_uid, pw->pw_gid) != 0) {
        why_not_ = "cannot hand the PostgreSQL data folder to `nobody`";
        return;
      }
  }
  fs::permissions(*dir_ / "data", fs::perms::owner_all);
  const ProgramOutput init =
      run_command("cd / && " + as_user_ + shell_quote(bin_ + "/initdb") + " -D " + shell_quote((*dir_ / "data").string()) +
                  " -U stend -A scram-sha-256 --pwfile=" + shell_quote((*dir_ / "pw").string()) +
                  " --locale=C -E UTF8 --no-sync");
  if (init.code != 0) {
    why_not_ = "PostgreSQL initdb failed: " + last_lines(init.text);
    return;
  }
  for (int i = 0; i < kStartTries && !running_; ++i) running_ = start();
}

bool TempPostgres::start() {
  port_ = free_loopback_port();
  const std::string data = (*dir_ / "data").string();
  // Loopback TCP only; the Unix socket in the data folder (not /run/postgresql).
  const std::string opts = "-c listen_addresses=127.0.0.1 -p " + std::to_string(port_) +
                           " -c unix_socket_directories=" + data + " -c fsync=off -c max_connections=40";
  const ProgramOutput r = run_command("cd / && " + as_user_ + shell_quote(bin_ + "/pg_ctl") + " -D " +
                                      shell_quote(data) + " -l " + shell_quote(data + "/server.log") + " -w -t 30 -o " +
                                      shell_quote(opts) + " start");
  if (r.code == 0) {
    why_not_.clear();
    return true;
  }
  why_not_ = "PostgreSQL server did not start (pg_ctl start): " + last_lines(r.text) + " " +
             last_lines(read_file(data + "/server.log"));
  return false;
}

TempPostgres::~TempPostgres() {
  if (!running_) return;
  run_command("cd / && " + as_user_ + shell_quote(bin_ + "/pg_ctl") + " -D " + shell_quote((*dir_ / "data").string()) +
              " -m immediate -w stop");
}

std::string TempPostgres::url() const {
  return "postgresql://stend@127.0.0.1:" + std::to_string(port_) + "/postgres";
}

// ---- Slurm -------------------------------------------------------------------------------------

TempSlurm::TempSlurm() {
  for (const char* tool : {"munged", "slurmctld", "slurmd", "sbatch", "sinfo"})
    if (run_command(std::string("command -v ") + tool + " || test -x /usr/sbin/" + tool).code != 0) {
      why_not_ = std::string("Slurm not installed (no ") + tool +
                 "; scripts/install-deps.sh installs Debian's slurm-wlm and munge): Slurm test skipped";
      return;
    }
  if (::geteuid() != 0) {
    why_not_ = "a single-node Slurm needs root (slurmd starts jobs as their users): Slurm test skipped";
    return;
  }
  dir_ = std::make_unique<TempDir>("slurm");
  start();
}

bool TempSlurm::start() {
  const fs::path d = dir_->path();
  for (const char* sub : {"state", "spool", "munge"}) fs::create_directories(d / sub);
  fs::permissions(d / "munge", fs::perms::owner_all);
  // munge: our own key and socket, nothing shared with a munged the machine may run.
  const ProgramOutput key = run_command("dd if=/dev/urandom of=" + shell_quote((d / "munge/munge.key").string()) +
                                        " bs=1024 count=1 2>&1 && chmod 600 " +
                                        shell_quote((d / "munge/munge.key").string()));
  if (key.code != 0) return why_not_ = "cannot write a munge key: " + last_lines(key.text), false;
  const std::string sock = (d / "munge/munge.sock").string();
  const ProgramOutput munge = run_command(
      "/usr/sbin/munged --force --key-file=" + shell_quote((d / "munge/munge.key").string()) + " --socket=" +
      shell_quote(sock) + " --pid-file=" + shell_quote((d / "munge/munged.pid").string()) + " --log-file=" +
      shell_quote((d / "munge/munged.log").string()) + " --seed-file=" + shell_quote((d / "munge/seed").string()));
  if (munge.code != 0)
    return why_not_ = "munged did not start: " + last_lines(munge.text) + last_lines(read_file(d / "munge/munged.log")),
           false;
  const std::string host = first_line(run_command("hostname -s").text);
  const int cpus = static_cast<int>(std::thread::hardware_concurrency());
  conf_ = (d / "slurm.conf").string();
  write_text(conf_, "ClusterName=stendtest\nSlurmctldHost=" + host + "(127.0.0.1)\nSlurmctldPort=" +
                        std::to_string(free_loopback_port()) + "\nSlurmdPort=" + std::to_string(free_loopback_port()) +
                        "\nAuthType=auth/munge\nAuthInfo=socket=" + sock + "\nCredType=cred/munge\nSlurmUser=root\n"
                        "SlurmdUser=root\nStateSaveLocation=" + (d / "state").string() +
                        "\nSlurmdSpoolDir=" + (d / "spool").string() +
                        "\nSlurmctldPidFile=" + (d / "slurmctld.pid").string() +
                        "\nSlurmdPidFile=" + (d / "slurmd.pid").string() +
                        "\nSlurmctldLogFile=" + (d / "slurmctld.log").string() +
                        "\nSlurmdLogFile=" + (d / "slurmd.log").string() +
                        "\nProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nJobAcctGatherType=jobacct_gather/none"
                        "\nAccountingStorageType=accounting_storage/none\nMpiDefault=none\nReturnToService=2"
                        "\nSchedulerType=sched/builtin\nSelectType=select/cons_tres\nSelectTypeParameters=CR_Core"
                        "\nMaxArraySize=100001\nMaxJobCount=200000\nSlurmctldTimeout=30\nSlurmdTimeout=30\nInactiveLimit=0\nKillWait=5"
                        // A test cluster runs short jobs back to back (slurm.conf(5), Slurm 22.05):
                        // batch jobs are scheduled as a node frees, not every batch_sched_delay
                        // (default 3 s); `sbatch --wait` polls every 2 s only while its sleep is
                        // below MinJobAge/2 (else 2, 8, 32 s …), and a finished job is kept 4 s.
                        "\nSchedulerParameters=batch_sched_delay=0\nMinJobAge=4"
                        "\nNodeName=" + host + " NodeAddr=127.0.0.1 CPUs=" + std::to_string(cpus) +
                        " State=UNKNOWN\nPartitionName=" + partition_ + " Nodes=" + host +
                        " Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO\n");
  const std::string env = "SLURM_CONF=" + shell_quote(conf_) + " ";
  const ProgramOutput ctld = run_command(env + "/usr/sbin/slurmctld -i 2>&1");
  if (ctld.code != 0)
    return why_not_ = "slurmctld did not start: " + last_lines(ctld.text) + last_lines(read_file(d / "slurmctld.log")),
           false;
  const ProgramOutput slurmd = run_command(env + "/usr/sbin/slurmd 2>&1");
  if (slurmd.code != 0)
    return why_not_ = "slurmd did not start: " + last_lines(slurmd.text) + last_lines(read_file(d / "slurmd.log")),
           false;
  const auto t0 = std::chrono::steady_clock::now();
  std::string state;
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < kSlurmReadyTimeoutS) {
    state = first_line(run_command(env + "sinfo -h -o %t -p " + partition_ + " 2>&1").text);
    if (state == "idle") return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  why_not_ = "the Slurm node did not become idle within " + std::to_string(static_cast<int>(kSlurmReadyTimeoutS)) +
             " s (sinfo: " + state + "): " + last_lines(read_file(d / "slurmd.log")) +
             last_lines(read_file(d / "slurmctld.log"));
  return false;
}

void TempSlurm::stop_daemon(const std::string& pid_file) {
  const std::string text = read_file(pid_file);
  const pid_t pid = static_cast<pid_t>(std::atoi(text.c_str()));
  if (pid <= 1) return;
  ::kill(pid, SIGTERM);
  for (int i = 0; i < 50 && ::kill(pid, 0) == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
}

TempSlurm::~TempSlurm() {
  if (!dir_) return;
  stop_daemon((dir_->path() / "slurmd.pid").string());
  stop_daemon((dir_->path() / "slurmctld.pid").string());
  stop_daemon((dir_->path() / "munge/munged.pid").string());
}

}  // namespace stend::testing
