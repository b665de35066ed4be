#include "progress.hpp"

#include <fmt/format.h>

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <utility>

namespace stend::cli {

namespace {

constexpr double kRedrawPeriod_s = 0.2;  // TaskProgress: at most 5 redraws a second
constexpr double kEtaAfter_s = 1.0;      // TaskProgress: a time left only after this much elapsed
const std::string kSeparator = " | ";

// The first `width` display columns of `s`, cut at a code point boundary.
std::string cut(const std::string& s, std::size_t width) {
  std::size_t cols = 0, i = 0;
  for (; i < s.size(); ++i) {
    if ((static_cast<unsigned char>(s[i]) & 0xC0) == 0x80) continue;
    if (cols == width) break;
    ++cols;
  }
  return s.substr(0, i);
}

std::string join(const std::vector<LinePiece>& pieces) {
  std::string line;
  for (const LinePiece& p : pieces) line += (line.empty() ? "" : kSeparator) + p.text;
  return line;
}

}  // namespace

std::string fmt_duration(double s) {
  if (!std::isfinite(s)) return "?";
  const long t = static_cast<long>(s + 0.5);
  if (t >= 3600) return fmt::format("{}h{:02}m{:02}s", t / 3600, (t / 60) % 60, t % 60);
  if (t >= 60) return fmt::format("{}m{:02}s", t / 60, t % 60);
  return fmt::format("{}s", t);
}

int terminal_columns() {
  winsize ws{};
  if (ioctl(STDERR_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) return ws.ws_col;
  if (const char* c = std::getenv("COLUMNS")) {
    const int n = std::atoi(c);
    if (n > 0) return n;
  }
  return 80;
}

std::size_t display_width(const std::string& s) {
  std::size_t n = 0;
  for (const char c : s)
    if ((static_cast<unsigned char>(c) & 0xC0) != 0x80) ++n;
  return n;
}

std::string fit_line(const std::vector<LinePiece>& pieces, int columns) {
  const std::size_t width = columns > 1 ? static_cast<std::size_t>(columns - 1) : 1;
  std::vector<LinePiece> kept = pieces;
  while (kept.size() > 1 && display_width(join(kept)) > width) {
    auto drop = kept.begin();
    for (auto it = kept.begin(); it != kept.end(); ++it)
      if (it->drop_order >= drop->drop_order) drop = it;  // the last of the most droppable
    kept.erase(drop);
  }
  const std::string line = join(kept);
  if (display_width(line) <= width) return line;
  return width > 1 ? cut(line, width - 1) + "…" : cut(line, width);
}

std::string run_progress_line(const RunProgress& p, int columns) {
  const bool done = p.phase == RunPhase::kDone;
  std::vector<LinePiece> pieces;
  pieces.push_back({fmt::format("{:.0f}%", 100.0 * p.fraction_done()), 0});
  pieces.push_back({done ? std::string("done") : fmt::format("~{} left", fmt_duration(p.time_left_s())), 0});
  pieces.push_back({fmt::format("step {}/{} {}", p.step, p.step_count, p.step_kind_name()), 1});
  if (p.item_count > 0 && !done)
    pieces.push_back({fmt::format("{} {}/{}", p.step_kind == Step::Kind::kRates ? "rate" : "orientation", p.item, p.item_count), 3});
  if (!done) pieces.push_back({to_string(p.phase), 2});
  if (std::isfinite(p.air_c)) {
    const std::string setpoint = std::isfinite(p.setpoint_c) ? fmt::format(" → {:.1f}", p.setpoint_c) : "";
    pieces.push_back({fmt::format("air {:.2f}{} °C", p.air_c, setpoint), 4});
    pieces.push_back({fmt::format("die {:.2f} °C", p.die_c), 6});
  }
  pieces.push_back({fmt::format("t {}", fmt_duration(p.run_time_s)), 5});
  pieces.push_back({fmt::format("{} samples", p.samples), 7});
  return fit_line(pieces, columns);
}

StatusLine::StatusLine() : enabled_(isatty(STDERR_FILENO) != 0) {}
StatusLine::~StatusLine() { clear(); }

// \r and "erase line" before each draw: the line never wraps (fit_line), so nothing stale is left.
void StatusLine::show(const std::string& line) {
  if (!enabled_) return;
  fmt::print(stderr, "\r\033[K{}", line);
  std::fflush(stderr);
  shown_ = true;
}

void StatusLine::clear() {
  if (!shown_) return;
  fmt::print(stderr, "\r\033[K");
  std::fflush(stderr);
  shown_ = false;
}

void StatusLine::keep() {
  if (!shown_) return;
  fmt::print(stderr, "\n");
  std::fflush(stderr);
  shown_ = false;
}

TaskProgress::TaskProgress(std::string what)
    : what_(std::move(what)), start_(std::chrono::steady_clock::now()), last_(start_ - std::chrono::hours(1)) {}

bool TaskProgress::due() const {
  return line_.enabled() &&
         std::chrono::duration<double>(std::chrono::steady_clock::now() - last_).count() >= kRedrawPeriod_s;
}

void TaskProgress::update_lazily(const std::function<double()>& fraction, const std::string& detail) {
  if (due()) update(fraction(), detail);
}

void TaskProgress::update(double fraction, const std::string& detail) {
  if (!due()) return;
  const auto now = std::chrono::steady_clock::now();
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  fraction = std::clamp(fraction, 0.0, 1.0);
  std::vector<LinePiece> pieces = {{fmt::format("{} {:.0f}%", what_, 100.0 * fraction), 0}};
  if (elapsed >= kEtaAfter_s && fraction > 0.0 && fraction < 1.0)
    pieces.push_back({fmt::format("~{} left", fmt_duration(elapsed * (1.0 - fraction) / fraction)), 1});
  if (!detail.empty()) pieces.push_back({detail, 2});
  line_.show(fit_line(pieces, terminal_columns()));
}

}  // namespace stend::cli

namespace stend::cli {

struct BackgroundProgress::State {
  TaskProgress progress;
  std::function<double()> fraction;
  std::function<std::string()> detail;
  std::mutex mutex;
  std::condition_variable wake;
  bool stopping = false;
  std::thread thread;
};

BackgroundProgress::BackgroundProgress(std::string what, std::function<double()> fraction,
                                       std::function<std::string()> detail)
    : state_(new State{TaskProgress(std::move(what)), std::move(fraction), std::move(detail), {}, {}, false, {}}) {
  if (!state_->progress.due()) return;  // stderr is not a terminal
  State* st = state_.get();
  st->thread = std::thread([st] {
    std::unique_lock<std::mutex> lock(st->mutex);
    while (!st->stopping) {
      st->progress.update_lazily(st->fraction, st->detail());
      st->wake.wait_for(lock, std::chrono::duration<double>(kRedrawPeriod_s));
    }
    st->progress.clear();
  });
}

BackgroundProgress::~BackgroundProgress() { stop(); }

void BackgroundProgress::stop() {
  if (!state_ || !state_->thread.joinable()) return;
  {
    const std::lock_guard<std::mutex> lock(state_->mutex);
    state_->stopping = true;
  }
  state_->wake.notify_all();
  state_->thread.join();
}

double input_read_share(const std::vector<std::filesystem::path>& inputs) {
  namespace fs = std::filesystem;
  std::error_code ec;
  double total = 0.0, read = 0.0;
  std::vector<fs::path> files;
  for (const fs::path& in : inputs) {
    if (fs::is_directory(in, ec)) {
      for (const auto& e : fs::recursive_directory_iterator(in, ec))
        if (e.is_regular_file(ec)) files.push_back(fs::canonical(e.path(), ec));
    } else {
      files.push_back(fs::canonical(in, ec));
    }
  }
  for (const fs::path& f : files) {
    const std::uintmax_t n = fs::file_size(f, ec);
    if (!ec) total += static_cast<double>(n);
  }
  if (total <= 0.0) return 0.0;
  for (const auto& fd : fs::directory_iterator("/proc/self/fd", ec)) {
    const fs::path target = fs::read_symlink(fd.path(), ec);
    if (ec || std::find(files.begin(), files.end(), target) == files.end()) continue;
    std::ifstream info("/proc/self/fdinfo/" + fd.path().filename().string());
    std::string key;
    double pos = 0.0;
    while (info >> key)
      if (key == "pos:" && info >> pos) break;
    read += pos;
  }
  return std::clamp(read / total, 0.0, 1.0);
}

}  // namespace stend::cli
