// The live view of a run folder (stend watch): the recording re-read on every refresh — samples
// through the store's chunked reader (the last few seconds only), truth, segments and events — and
// turned into the same state a run in this process feeds (LiveState). Works on a run in progress
// (HDF5 SWMR run.h5 or CSV files read up to their last complete line) and on a finished one.
#pragma once

#include <stend/core/experiment.hpp>
#include <stend/live/live_state.hpp>

#include <filesystem>
#include <map>
#include <vector>

namespace stend::live {

class RunFolderFeed {
 public:
  // `procedure`: the run's procedure (its experiment.yaml read with the plugins at hand), for the
  // step count and the time left; empty when it could not be read (then neither is shown).
  RunFolderFeed(std::filesystem::path run_dir, std::vector<Step> procedure, LiveLimits limits = {});

  // Re-reads the folder into `state`; returns the run's status. Throws InputError when the folder
  // is not a readable recording.
  RunStatus refresh(LiveState& state);

 private:
  std::filesystem::path dir_;
  std::vector<Step> procedure_;
  LiveLimits limits_;
  std::map<int, SegmentMean> means_;  // closed segments' means, computed once each
};

}  // namespace stend::live
