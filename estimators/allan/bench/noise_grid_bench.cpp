// The simulator grid of the noise-model fit as a table (see README.md, "Validation on the
// simulator"): output rate × low-pass × noise mix, `seeds` records each, every axis scored.
//   noise_grid_bench [seeds (20)] [duration_s (600)] [rate_hz (all)]
#include "../tests/noise_grid.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cstdlib>
#include <string>

using namespace stend::allan;

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::atoi(argv[1]) : 20;
  const double duration = argc > 2 ? std::atof(argv[2]) : 600.0;
  const double only_rate = argc > 3 ? std::atof(argv[3]) : 0.0;  // 0: every rate
  fmt::print("# {} seeds x 3 axes per instrument, {} s records; cov = reported interval (95 % or upper bound) "
             "covers the truth, off = identified and outside its interval, id = identified; absent terms: "
             "identified fraction\n",
             seeds, duration);
  fmt::print("| rate Hz | low-pass | mix | inst | N cov/off | K cov/off/id | G cov/off/id | Tc cov | absent identified | s |\n");
  fmt::print("|---|---|---|---|---|---|---|---|---|---|\n");
  for (double rate : {100.0, 200.0, 1000.0, 4000.0}) {
    if (only_rate > 0.0 && rate != only_rate) continue;
    for (bool lp : {false, true}) {
      for (grid::Mix mix : {grid::Mix::kWhite, grid::Mix::kWhiteGm, grid::Mix::kWhiteRw, grid::Mix::kAll}) {
        const grid::Cell cell{rate, lp, mix, duration};
        grid::Score score[2];
        const auto t0 = std::chrono::steady_clock::now();
        for (int s = 1; s <= seeds; ++s) {
          const auto res = grid::analyze_record(cell, 1000 + s);
          const auto cfg = grid::config_of(cell, 1000 + s);
          for (std::size_t ch = 0; ch < res.size(); ++ch) {
            const bool gyro = ch >= 3;
            grid::score_channel(res[ch].model, grid::truth_of(cfg, gyro), score[gyro ? 1 : 0]);
          }
        }
        const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        for (int g = 0; g < 2; ++g) {
          const grid::Score& sc = score[g];
          auto frac = [](int a, int b) { return b > 0 ? fmt::format("{:.0f}%", 100.0 * a / b) : std::string("-"); };
          auto present = [&](int j, bool id) {
            if (sc.present[j] == 0) return std::string("-");
            return frac(sc.covered[j], sc.present[j]) + "/" + frac(sc.off[j], sc.present[j]) +
                   (id ? "/" + frac(sc.identified[j], sc.present[j]) : std::string());
          };
          std::string absent;
          for (int j = 0; j < 7; ++j) {
            if (sc.absent[j] > 0 && j != 6) absent += fmt::format("{}{} {}", absent.empty() ? "" : ", ", grid::symbol_of(j), frac(sc.false_identified[j], sc.absent[j]));
          }
          if (sc.failed > 0) absent += fmt::format("; FAILED {}", sc.failed);
          fmt::print("| {:g} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1f} |\n", rate, lp ? "0.184·rate" : "off",
                     grid::to_string(mix), g ? "gyro" : "accel", present(1, false), present(3, true), present(5, true),
                     sc.present[6] ? frac(sc.covered[6], sc.present[6]) : std::string("-"), absent, secs);
        }
      }
    }
  }
  return 0;
}
