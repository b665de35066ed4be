// `stend run`'s progress line as a user sees it: in a pseudo-terminal 60 columns wide (script(1)
// and stty), every line drawn fits in 59 columns (so nothing wraps and no stale line is left), the
// time left shrinks, and the last line says done without a time left; through a pipe, no progress
// output at all.
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace {

using stend::testing::shell_quote;

std::size_t columns(const std::string& s) {
  std::size_t n = 0;
  for (const char c : s)
    if ((static_cast<unsigned char>(c) & 0xC0) != 0x80) ++n;
  return n;
}

// The lines drawn with "\r\033[K" (carriage return, erase line), each up to the next \r or \n.
std::vector<std::string> drawn_lines(const std::string& out) {
  std::vector<std::string> lines;
  const std::string draw = "\r\033[K";
  for (auto p = out.find(draw); p != std::string::npos; p = out.find(draw, p + 1)) {
    const auto from = p + draw.size();
    const auto end = out.find_first_of("\r\n", from);
    const std::string line = out.substr(from, end == std::string::npos ? std::string::npos : end - from);
    if (!line.empty()) lines.push_back(line);
  }
  return lines;
}

}  // namespace

TEST(ProgressLine, FitsTheTerminalAndEndsDone) {
  if (stend::testing::run_command("command -v script && command -v stty").code != 0)
    GTEST_SKIP() << "script(1) or stty not installed (util-linux, coreutils): no pseudo-terminal for the check";
  const stend::testing::TempDir dir("progress");
  const std::string run = shell_quote(stend::testing::stend_program().string()) + " run " +
                          shell_quote(stend::testing::source_path("configs/six_position.yaml").string()) + " -o " +
                          shell_quote(dir.str()) + " --name tty";
  const auto o = stend::testing::run_command("script -qfec " + shell_quote("stty cols 60; " + run) + " /dev/null");
  ASSERT_EQ(o.code, 0) << o.text;
  const std::vector<std::string> lines = drawn_lines(o.text);
  ASSERT_GE(lines.size(), 2u) << o.text;
  for (const std::string& l : lines) EXPECT_LE(columns(l), 59u) << "wider than the terminal: '" << l << "'";
  EXPECT_NE(lines.front().find("left"), std::string::npos) << lines.front();
  EXPECT_EQ(lines.back().rfind("100% | done", 0), 0u) << lines.back();
  EXPECT_EQ(lines.back().find("left"), std::string::npos) << lines.back();

  const auto piped = stend::testing::run_command(run + "-pipe 2>&1 | cat");
  ASSERT_EQ(piped.code, 0) << piped.text;
  EXPECT_EQ(piped.text.find('\r'), std::string::npos) << piped.text;
  EXPECT_EQ(piped.text.find("left"), std::string::npos) << piped.text;
  EXPECT_NE(piped.text.find("status:     complete"), std::string::npos) << piped.text;
}
