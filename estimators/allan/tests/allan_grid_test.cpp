// The noise-model fit against the simulator's truth over the grid output rate (100, 200, 1000,
// 4000 Hz) × the sensor's low-pass (off, 0.184·rate) × noise mix (white; white + Gauss–Markov;
// white + random walk; all). Every record comes from sim::SimImu (its own noise processes and
// output stage); the truth is its configuration. Each cell: kSeeds records × 3 axes per
// instrument. bench/noise_grid_bench prints the same grid with more seeds.
#include "noise_grid.hpp"

#include <gtest/gtest.h>

using namespace stend::allan;

namespace {

constexpr int kSeeds = 7;  // × 3 axes = 21 realisations per instrument and cell

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
    for (int g = 0; g < 2; ++g) {
      const grid::Score& sc = score[g];
      const std::string where = fmt::format("{} Hz, low-pass {}, {}, {}; first record:\n{}", cell.rate_hz,
                                            cell.lowpass ? "on" : "off", grid::to_string(mix),
                                            g ? "gyroscope" : "accelerometer", example[g]);
      EXPECT_EQ(sc.failed, 0) << where;
      for (int j = 0; j < 7; ++j) {
        if (sc.present[j] > 0) {
          EXPECT_GE(sc.covered[j], 0.9 * sc.present[j]) << grid::symbol_of(j) << " coverage, " << where;
          EXPECT_LE(sc.off[j], 0.1 * sc.present[j]) << grid::symbol_of(j) << " off, " << where;
        }
        if (sc.absent[j] > 0) {
          EXPECT_LE(sc.false_identified[j], 0.05 * sc.absent[j]) << grid::symbol_of(j) << " absent, " << where;
        }
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(RatesAndFilters, NoiseGrid,
                         ::testing::Values(GridParam{100.0, false}, GridParam{100.0, true}, GridParam{200.0, false},
                                           GridParam{200.0, true}, GridParam{1000.0, false}, GridParam{1000.0, true},
                                           GridParam{4000.0, false}, GridParam{4000.0, true}),
                         [](const auto& info) {
                           return fmt::format("{}Hz_{}", static_cast<int>(info.param.rate_hz),
                                              info.param.lowpass ? "lowpass" : "nofilter");
                         });

}  // namespace
