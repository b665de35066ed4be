// Real servers started by a test in a temporary folder, on loopback only, and stopped (by their
// own process ids) at the end of the scope: a PostgreSQL cluster (initdb + pg_ctl on a free port)
// and a single-node Slurm (munged + slurmctld + slurmd on localhost with a generated slurm.conf).
// When a piece is not installed or cannot start, why_not() says which and why, and the test skips
// with it (STEND_SKIP_UNLESS_RUNNING). As root the PostgreSQL server runs as `nobody`: it refuses
// to run as root, and CI runs the tests as root.
#pragma once

#include "stend/testing/program.hpp"
#include "stend/testing/files.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>

namespace stend::testing {

class TempPostgres {
 public:
  TempPostgres();
  ~TempPostgres();
  TempPostgres(const TempPostgres&) = delete;
  TempPostgres& operator=(const TempPostgres&) = delete;

  // "" when the server runs; otherwise what could not start and why.
  const std::string& why_not() const { return why_not_; }
  // libpq URL of the cluster's `postgres` database as role `stend` — without the password, which
  // comes from env() (PGPASSWORD), as a lab's would come from the environment or ~/.pgpass.
  std::string url() const;
  Environment env() const { return {{"PGPASSWORD", password_}}; }
  const std::string& password() const { return password_; }
  int port() const { return port_; }

 private:
  bool start();
  std::unique_ptr<TempDir> dir_;
  std::string bin_, as_user_, password_, why_not_;
  int port_ = 0;
  bool running_ = false;
};

class TempSlurm {
 public:
  TempSlurm();
  ~TempSlurm();
  TempSlurm(const TempSlurm&) = delete;
  TempSlurm& operator=(const TempSlurm&) = delete;

  const std::string& why_not() const { return why_not_; }
  // SLURM_CONF for the clients (sbatch, sinfo) of this cluster.
  Environment env() const { return {{"SLURM_CONF", conf_}}; }
  const std::string& partition() const { return partition_; }

 private:
  bool start();
  void stop_daemon(const std::string& pid_file);
  std::unique_ptr<TempDir> dir_;
  std::string conf_, partition_ = "stend", why_not_;
};

// A free TCP port on 127.0.0.1 (bound, read and released).
int free_loopback_port();

}  // namespace stend::testing

// Skips the running test when `service` (a TempPostgres or TempSlurm) is not running, saying why.
#define STEND_SKIP_UNLESS_RUNNING(service) \
  if ((service).why_not().empty()) {       \
  } else                                   \
    GTEST_SKIP() << (service).why_not()
