// Progress on the terminal: one line, rewritten in place, that fits the terminal's width (pieces
// dropped by importance, then cut), and nothing at all when stderr is not a terminal. For
// `stend run` (RunProgress: the procedure, the time left from stend/core/eta.hpp) and for any long
// command (TaskProgress: a share done, the time left extrapolated from the elapsed time).
#pragma once

#include "stend/core/runner.hpp"

#include <chrono>
#include <functional>
#include <memory>
#include <filesystem>
#include <string>
#include <vector>

namespace stend::cli {

// "1h02m40s", "3m05s", "42s"; "?" when not finite.
std::string fmt_duration(double s);

// Columns of the terminal on stderr (TIOCGWINSZ, else $COLUMNS, else 80).
int terminal_columns();

// Display width of UTF-8 text (code points; the line uses no wide characters).
std::size_t display_width(const std::string& s);

// A piece of a progress line; pieces with a higher `drop_order` go first when the line is too wide.
struct LinePiece {
  std::string text;
  int drop_order = 0;
};
// The pieces joined by " | ", in their order, at most `columns` − 1 wide (a line exactly as wide
// as the terminal wraps on some terminals): pieces dropped by drop_order, then the rest cut with "…".
std::string fit_line(const std::vector<LinePiece>& pieces, int columns);

// The run's progress line: "37% | ~1h16m left | step 3/12 set_temperature | settling | air …".
// Once done it says "done" and the run time, never a time left.
std::string run_progress_line(const RunProgress& p, int columns);

// The one line on stderr, drawn only when stderr is a terminal: show() rewrites it in place,
// clear() removes it (call before printing anything else; the destructor does too).
class StatusLine {
 public:
  StatusLine();
  ~StatusLine();
  StatusLine(const StatusLine&) = delete;
  StatusLine& operator=(const StatusLine&) = delete;
  bool enabled() const { return enabled_; }
  void show(const std::string& line);
  void clear();
  void keep();  // ends the line shown with a newline, so that it stays on the terminal

 private:
  bool enabled_ = false;
  bool shown_ = false;
};

// Progress of a long command (validate, gap validate, import, fit): "what 37% | ~2m10s left | detail",
// at most 5 times a second, nothing when stderr is not a terminal.
class TaskProgress {
 public:
  explicit TaskProgress(std::string what);
  void update(double fraction, const std::string& detail = "");
  // The same, with the share asked for only when the line is redrawn (when it costs something).
  void update_lazily(const std::function<double()>& fraction, const std::string& detail = "");
  bool due() const;  // a redraw would happen now
  void clear() { line_.clear(); }

 private:
  std::string what_;
  StatusLine line_;
  std::chrono::steady_clock::time_point start_, last_;
};

// A TaskProgress redrawn by a thread of its own, for a step that reports nothing itself (an
// estimator's fit): `fraction` and `detail` are asked from that thread at each redraw. Nothing
// runs when stderr is not a terminal. stop() (or the destructor) ends the thread and clears the line;
// call it before printing anything else.
class BackgroundProgress {
 public:
  BackgroundProgress(std::string what, std::function<double()> fraction, std::function<std::string()> detail);
  ~BackgroundProgress();
  BackgroundProgress(const BackgroundProgress&) = delete;
  BackgroundProgress& operator=(const BackgroundProgress&) = delete;
  void stop();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// How far this process has read the files `inputs`: the read offsets of its open descriptors on
// them (/proc/self/fd, /proc/self/fdinfo) over their total size, 0…1; 0 when none is open (a
// reader that reads twice shows its pass).
double input_read_share(const std::vector<std::filesystem::path>& inputs);

}  // namespace stend::cli
