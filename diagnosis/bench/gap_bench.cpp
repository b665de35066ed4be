// Speed of a full gap diagnosis (whole candidate vocabulary, pairwise alias analysis, held-out
// folds, forward selection) of a 100-position experiment — the target is ≤ 2 s on one core.
//   build-*/bin/gap_bench   (or build-*/diagnosis/gap_bench)
#include <benchmark/benchmark.h>

#include "stend/diagnosis/gap.hpp"
#include "stend/diagnosis/validate.hpp"

namespace {

using namespace stend::diagnosis;

GapInput input(int positions, bool planted) {
  Planted p;
  p.model = validation_model().model;
  p.theta = Eigen::VectorXd(12);
  p.theta << 0.05, -0.03, 0.02, 0.002, -0.001, 0.0007, 0.003, -0.002, 0.001, 0.004, -0.003, 0.002;
  p.model.terms.push_back({stend::model::TermKind::kCrossAxis, 1, 25.0});
  if (!planted) p.theta.tail(6).setZero();
  return generate(many_positions_design(positions), validation_model(), p, 7);
}

void BM_GapDiagnosis(benchmark::State& state) {
  const GapInput in = input(static_cast<int>(state.range(0)), state.range(1) != 0);
  GapOptions o;
  o.check_aliases = true;
  o.max_folds = static_cast<int>(state.range(2));
  for (auto _ : state) {
    GapReport r = diagnose(in, o);
    benchmark::DoNotOptimize(r);
  }
  state.SetLabel(std::to_string(in.segments.size()) + " positions, " + (state.range(1) ? "cross_axis planted" : "null") +
                 (state.range(2) ? ", 12 folds" : ", leave-one-position-out"));
}
BENCHMARK(BM_GapDiagnosis)
    ->Args({100, 1, 0})
    ->Args({100, 0, 0})
    ->Args({100, 1, 12})
    ->Args({24, 1, 12})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
