// The HDF5 run store's data read where it lies: the samples (a SampleSource) and the bench truth
// (a RecordedTruth) of run.h5, a chunk or window at a time. Internal to stend_recording.
#pragma once

#include "hdf5_common.hpp"

#include "stend/recording/samples.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

namespace stend::detail {

// The bench truth of dataset `ds` (/truth: `rows` rows of `width` values, t_s first).
std::shared_ptr<const RecordedTruth> hdf5_truth(std::filesystem::path path, Handle ds, std::uint64_t rows,
                                                std::size_t width);

// The columns of /samples as they lie in the file, and how each channel is stored.
struct Hdf5SampleColumns {
  Handle t, flags;
  std::array<Handle, kChannels> counts, si;  // si[ch] only where codec[ch].si_stored
  std::array<Codec, kChannels> codec;
  std::vector<std::array<double, 4>> exceptions;  // (index, channel, counts, si), sorted by index
};
// The first `size` samples of the file, which `file` keeps open.
std::shared_ptr<const SampleSource> hdf5_samples(std::filesystem::path path, Handle file, std::uint64_t size,
                                                 Hdf5SampleColumns columns);

}  // namespace stend::detail
