// The run clock. Hardware runs on the wall clock; the simulated bench on a simulated clock that
// jumps to whatever time the runner asks for, so an hour-long experiment takes seconds.
#pragma once

#include <chrono>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace stend {

// Which clock a run uses: kAuto is the experiment's default (simulated when every plugin of the
// bench is simulated, else the wall clock).
enum class ClockKind { kAuto, kSimulated, kWall };
// "auto" | "simulated" | "wall".
const char* to_string(ClockKind k);
// The kind of that name, or nullopt.
std::optional<ClockKind> clock_kind_from_string(std::string_view name);
// Every kind's name, in the enum's order (for messages).
const std::vector<std::string>& clock_kind_names();
std::ostream& operator<<(std::ostream& os, ClockKind k);

// A clock of that kind (kAuto: the wall clock; resolve it against the bench first).
class Clock;
std::unique_ptr<Clock> make_clock(ClockKind kind);

class Clock {
 public:
  virtual ~Clock() = default;
  virtual double now_s() const = 0;           // run time since start [s]
  virtual void wait_until(double t_s) = 0;    // block (wall) or jump (simulated)
  virtual bool simulated() const = 0;
};

class SimulatedClock final : public Clock {
 public:
  double now_s() const override { return t_; }
  void wait_until(double t_s) override {
    if (t_s > t_) t_ = t_s;
  }
  bool simulated() const override { return true; }

 private:
  double t_ = 0.0;
};

class WallClock final : public Clock {
 public:
  WallClock() : start_(std::chrono::steady_clock::now()) {}
  double now_s() const override {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  void wait_until(double t_s) override {
    std::this_thread::sleep_until(start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                               std::chrono::duration<double>(t_s)));
  }
  bool simulated() const override { return false; }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace stend
