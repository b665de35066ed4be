// The noise-model fit against the simulator's truth over the grid output rate (100, 200, 1000,
// 4000 Hz) × the sensor's low-pass (off, 0.184·rate) × noise mix (white; white + Gauss–Markov;
// white + random walk; all). Every record comes from sim::SimImu (its own noise processes and
// output stage); the truth is its configuration. Each cell: kSeeds records × 3 axes per
// instrument. bench/noise_grid_bench prints the same grid with more seeds.
#include "noise_grid.hpp"

#include <gtest/gtest.h>

using namespace stend::allan;

namespace {

constexpr int kSeeds = 2;  // × 6 axes = 12 realisations per cell (the bench runs more)

struct GridParam {
  double rate_hz;
  bool lowpass;
};

class NoiseGrid : public ::testing::TestWithParam<GridParam> {};

TEST_P(NoiseGrid, IntervalsCoverTheTruthAndAbsentTermsAreNotIdentified) {
  const GridParam gp = GetParam();
  for (grid::Mix mix : {grid::Mix::kWhite, grid::Mix::kWhiteGm, grid::Mix::kWhiteRw, grid::Mix::kAll}) {
    const grid::Cell cell{gp.rate_hz, gp.lowpass, mix, 600.0};
    grid::Score score[2];
    std::string example[2];
    for (int s = 1; s <= kSeeds; ++s) {
      const auto res = grid::analyze_record(cell, 1000 + s);
      const auto cfg = grid::config_of(cell, 1000 + s);
      for (std::size_t ch = 0; ch < res.size(); ++ch) {
        const bool gyro = ch >= 3;
        grid::score_channel(res[ch].model, grid::truth_of(cfg, gyro), score[gyro ? 1 : 0]);
        if (s == 1 && (ch == 0 || ch == 3)) {
          std::ostringstream os;
          os << res[ch].model;
          example[gyro ? 1 : 0] = os.str();
        }
      }
    }
    // Pooled over both instruments. The white-only cells must meet the full criteria; the cells
    // with a Gauss–Markov bias or a random walk are held at the levels the fit reaches today
    // (README, "Validation on the simulator": where it falls short of 90 % coverage and ≤ 5 %
    // false identification, and why).
    grid::Score sc;
    for (int g = 0; g < 2; ++g) {
      for (int j = 0; j < 7; ++j) {
        sc.present[j] += score[g].present[j];
        sc.covered[j] += score[g].covered[j];
        sc.off[j] += score[g].off[j];
        sc.absent[j] += score[g].absent[j];
        sc.false_identified[j] += score[g].false_identified[j];
      }
      sc.failed += score[g].failed;
    }
    const std::string where = fmt::format("{} Hz, low-pass {}, {}; first records:\n{}\n{}", cell.rate_hz,
                                          cell.lowpass ? "on" : "off", grid::to_string(mix), example[0], example[1]);
    EXPECT_EQ(sc.failed, 0) << where;
    const bool white_only = mix == grid::Mix::kWhite;
    // Levels on these 12 realisations (the bench's 60 per instrument in brackets): N ≥ 90 % in white
    // noise, ≥ 80 % beside other terms [≥ 87 %]; K ≥ 65 % [77–95 %: the 600 s records hold few
    // long-τ points]; G ≥ 80 % [≥ 90 %].
    const double min_cover[7] = {1, white_only ? 0.9 : 0.8, 1, 0.65, 1, 0.8, 0.0};
    for (int j = 0; j < 7; ++j) {
      if (sc.present[j] > 0) {
        EXPECT_GE(sc.covered[j], min_cover[j] * sc.present[j]) << grid::symbol_of(j) << " coverage, " << where;
      }
      // Absent terms: at most one of the 12 in white noise [≤ 2 %]; with other terms R ≤ 10 % [≤ 2 %],
      // B ≤ 25 % [≤ 10 %], G ≤ 30 % [≤ 23 %: a random walk's slow wander read as a plateau], Q, K ≤ 20 %.
      const double max_false = white_only ? 0.1 : j == 4 ? 0.1 : j == 2 ? 0.25 : j == 5 ? 0.3 : 0.2;
      if (sc.absent[j] > 0 && j != 6) {
        EXPECT_LE(sc.false_identified[j], max_false * sc.absent[j]) << grid::symbol_of(j) << " absent, " << where;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(RatesAndFilters, NoiseGrid,
                         ::testing::Values(GridParam{100.0, false}, GridParam{100.0, true}, GridParam{200.0, false},
                                           GridParam{200.0, true}, GridParam{1000.0, false}, GridParam{1000.0, true},
                                           GridParam{4000.0, false}, GridParam{4000.0, true}),
                         [](const auto& p) {
                           return fmt::format("{}Hz_{}", static_cast<int>(p.param.rate_hz),
                                              p.param.lowpass ? "lowpass" : "nofilter");
                         });

}  // namespace
