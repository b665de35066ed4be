// write_file_atomic under concurrent writers (threads and processes on one file): every write
// succeeds and every read sees a whole document; RunFolderLock makes two processes take turns.
#include <gtest/gtest.h>

#include "stend/errors.hpp"
#include "stend/recording/files.hpp"
#include "stend/testing/files.hpp"

#include <nlohmann/json.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using stend::testing::read_text;
using stend::testing::TempDir;

namespace {

constexpr int kThreads = 8;
constexpr int kProcesses = 4;
constexpr int kWritesEach = 60;
constexpr std::size_t kPadBytes = 64 * 1024;  // large enough that two writes overlap in time

// A results-like document that says who wrote it: whole only when it parses and its pad is full.
std::string document(int writer, int n) {
  return nlohmann::json{{"writer", writer}, {"n", n}, {"pad", std::string(kPadBytes, 'a' + writer % 26)}}.dump() + "\n";
}

bool whole(const std::string& text) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  return !j.is_discarded() && j.contains("pad") && j["pad"].get<std::string>().size() == kPadBytes;
}

// Writes `file` kWritesEach times and reads it back after each write; the failures.
int write_and_check(const fs::path& file, int writer) {
  int failures = 0;
  for (int n = 0; n < kWritesEach; ++n) {
    try {
      stend::write_file_atomic(file, document(writer, n));
    } catch (const std::exception&) {
      ++failures;
    }
    if (!whole(read_text(file))) ++failures;
  }
  return failures;
}

std::size_t temporary_files_in(const fs::path& dir) {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".tmp") ++n;
  return n;
}

}  // namespace

TEST(WriteFileAtomic, ConcurrentWritersOfOneFileEachSucceedAndLeaveAWholeFile) {
  const TempDir dir("files");
  const fs::path file = dir / "fit.json";
  std::vector<pid_t> children;
  for (int p = 0; p < kProcesses; ++p) {
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) ::_exit(write_and_check(file, 100 + p) == 0 ? 0 : 1);
    children.push_back(pid);
  }
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) threads.emplace_back([&, t] { failures += write_and_check(file, t); });
  for (auto& t : threads) t.join();
  for (const pid_t pid : children) {
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "a writer process saw a failure";
  }
  EXPECT_EQ(failures.load(), 0);
  EXPECT_TRUE(whole(read_text(file)));
  EXPECT_EQ(temporary_files_in(dir.path()), 0u);
}

TEST(WriteFileAtomic, AFailedWriteLeavesNoTemporaryFile) {
  const TempDir dir("files");
  fs::create_directory(dir / "taken.json");  // the rename onto a folder fails
  EXPECT_THROW(stend::write_file_atomic(dir / "taken.json", "{}\n"), stend::IoError);
  EXPECT_THROW(stend::write_file_atomic(dir / "taken.json", [](const fs::path&) {}), stend::IoError);
  EXPECT_EQ(temporary_files_in(dir.path()), 0u);
}

TEST(RunFolderLock, ASecondProcessWaitsForTheFirstToRelease) {
  const TempDir dir("files");
  constexpr auto kHold = std::chrono::milliseconds(400);
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const stend::RunFolderLock lock(dir.path());
    const char one = 1;
    if (::write(ready[1], &one, 1) != 1) ::_exit(2);
    std::this_thread::sleep_for(kHold);
    ::_exit(lock.held() ? 0 : 1);
  }
  char got = 0;
  ASSERT_EQ(::read(ready[0], &got, 1), 1);
  bool waited = false;
  const auto start = std::chrono::steady_clock::now();
  {
    const stend::RunFolderLock lock(dir.path(), [&] { waited = true; });
    EXPECT_TRUE(lock.held());
  }
  const auto took = std::chrono::steady_clock::now() - start;
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_TRUE(waited);
  EXPECT_GE(took, kHold / 2);
  ::close(ready[0]);
  ::close(ready[1]);
}

TEST(RunFolderLock, APathThatIsNotAFolderIsNotLocked) {
  const TempDir dir("files");
  EXPECT_FALSE(stend::RunFolderLock(dir / "missing").held());
  EXPECT_FALSE(stend::RunFolderLock(fs::path()).held());
}
