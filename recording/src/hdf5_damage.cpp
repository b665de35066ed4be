// The damage checks of run.h5 (see hdf5_damage.hpp).
#include "hdf5_damage.hpp"

#include "hdf5_global_heap.hpp"

#include "stend/errors.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>
#include <vector>

namespace stend::detail {

namespace fs = std::filesystem;

namespace {

// Whether byte `at` of the file lies inside the stored data (a chunk, or contiguous storage) of
// one of its datasets.
struct ChunkSearch {
  std::uint64_t at;
  bool found = false;
};
herr_t search_dataset(hid_t root, const char* name, const H5O_info_t* info, void* data) {
  auto& s = *static_cast<ChunkSearch*>(data);
  if (info->type != H5O_TYPE_DATASET) return 0;
  Handle ds(H5Dopen2(root, name, H5P_DEFAULT), H5Dclose);
  if (!ds) return 0;
  const haddr_t contiguous = H5Dget_offset(ds.get());
  if (contiguous != HADDR_UNDEF) {
    s.found = s.at >= contiguous && s.at - contiguous < H5Dget_storage_size(ds.get());
    return s.found ? 1 : 0;
  }
  hsize_t chunks = 0;
  if (H5Dget_num_chunks(ds.get(), H5S_ALL, &chunks) < 0) return 0;
  const int rank = [&] {
    Handle space(H5Dget_space(ds.get()), H5Sclose);
    return H5Sget_simple_extent_ndims(space.get());
  }();
  std::vector<hsize_t> offset(static_cast<std::size_t>(std::max(rank, 1)) + 1);
  for (hsize_t i = 0; i < chunks; ++i) {
    unsigned mask = 0;
    haddr_t addr = HADDR_UNDEF;
    hsize_t bytes = 0;
    if (H5Dget_chunk_info(ds.get(), H5S_ALL, i, offset.data(), &mask, &addr, &bytes) < 0) break;
    if (addr != HADDR_UNDEF && s.at >= addr && s.at - addr < bytes) {
      s.found = true;
      return 1;
    }
  }
  return 0;
}

}  // namespace

const std::string& GlobalHeapGuard::damage() {
  if (!checked_) {
    damage_ = global_heap_damage(file_, [&](std::uint64_t at) { return inside_a_chunk(at); });
    if (!damage_.empty()) damage_ = fmt::format("{}: {}", file_.string(), damage_);
    checked_ = true;
  }
  return damage_;
}

void GlobalHeapGuard::check() {
  if (!damage().empty()) throw InputError(damage_);
}

bool GlobalHeapGuard::inside_a_chunk(std::uint64_t at) const {
  ChunkSearch s{at};
  H5Ovisit2(h5_, H5_INDEX_NAME, H5_ITER_NATIVE, search_dataset, &s, H5O_INFO_BASIC);
  H5Eclear2(H5E_DEFAULT);
  return s.found;
}

hsize_t first_missing_chunk(hid_t ds, hsize_t chunks, std::uint64_t file_size) {
  auto present = [&](hsize_t k) {
    const hsize_t offset[1] = {k * kChunkSamples};
    unsigned mask = 0;
    haddr_t addr = HADDR_UNDEF;
    hsize_t bytes = 0;
    if (H5Dget_chunk_info_by_coord(ds, offset, &mask, &addr, &bytes) < 0) {
      H5Eclear2(H5E_DEFAULT);
      return false;
    }
    return addr != HADDR_UNDEF && addr + bytes <= file_size;
  };
  if (chunks == 0 || present(chunks - 1)) return chunks;
  hsize_t lo = 0, hi = chunks - 1;  // invariant: chunk hi is missing, all chunks before lo present
  while (lo < hi) {
    const hsize_t mid = lo + (hi - lo) / 2;
    if (present(mid)) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return lo;
}

std::string check_linked_headers(hid_t root, Hdf5HeaderCheck& headers) {
  struct Visit {
    Hdf5HeaderCheck* headers;
    std::string why;
  } visit{&headers, {}};
  const herr_t rc = H5Lvisit(
      root, H5_INDEX_NAME, H5_ITER_NATIVE,
      [](hid_t, const char* name, const H5L_info_t* info, void* data) -> herr_t {
        auto& v = *static_cast<Visit*>(data);
        if (info->type != H5L_TYPE_HARD) return 0;
        v.why = v.headers->linked_object(info->u.address);
        if (!v.why.empty()) v.why = fmt::format("/{}: {}", name, v.why);
        return v.why.empty() ? 0 : 1;
      },
      &visit);
  if (rc < 0 && visit.why.empty()) visit.why = "its groups' links cannot be read (" + hdf5_error() + ")";
  H5Eclear2(H5E_DEFAULT);
  return visit.why;
}

}  // namespace stend::detail
