// The fuzz targets' main() in the normal build (no libFuzzer): runs LLVMFuzzerTestOneInput on every
// file of the given folders (or files), then on `-mutations=N` deterministic mutations of each
// (byte flips, truncations, insertions, deletions, repeated chunks; splitmix64 from `-seed=S`), so
// the suite replays the seed corpus and the regression set and explores a little around them.
// A crash or sanitizer report aborts the process, which fails the test; the input is named first.
// `-keep=FILE` writes each input to FILE before running it: after a crash or a hang FILE is the
// reproducer (replay it with fuzz_<target> FILE, or under libFuzzer).
//   fuzz_<target> [-mutations=N] [-seed=S] [-keep=FILE] DIR_OR_FILE...
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

namespace fs = std::filesystem;

std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// One random edit of `s`.
void mutate(std::string& s, std::uint64_t& rng) {
  const auto pick = [&](std::size_t n) { return n == 0 ? std::size_t{0} : static_cast<std::size_t>(splitmix64(rng) % n); };
  switch (pick(6)) {
    case 0:  // flip bits of one byte
      if (!s.empty()) s[pick(s.size())] ^= static_cast<char>(1 + pick(255));
      break;
    case 1:  // truncate
      s.resize(pick(s.size() + 1));
      break;
    case 2:  // insert random bytes
      s.insert(pick(s.size() + 1), std::string(1 + pick(8), static_cast<char>(pick(256))));
      break;
    case 3: {  // delete a run of bytes
      const std::size_t at = pick(s.size() + 1);
      s.erase(at, 1 + pick(16));
      break;
    }
    case 4: {  // repeat a chunk
      const std::size_t at = pick(s.size() + 1);
      s.insert(at, s.substr(at, 1 + pick(64)));
      break;
    }
    default:  // an interesting value at a random place
      if (!s.empty()) {
        static const char kValues[] = {'\0', '\xff', '\x7f', '\x80', '-', '9', ',', '\n', '"', '.'};
        s[pick(s.size())] = kValues[pick(sizeof kValues)];
      }
      break;
  }
}

std::string keep_file;  // -keep=FILE

void run_one(const std::string& input, const std::string& what) {
  const std::size_t n = std::min(input.size(), stend::fuzz::kMaxInputBytes);
  if (!keep_file.empty()) std::ofstream(keep_file, std::ios::binary | std::ios::trunc) << input.substr(0, n);
  std::fprintf(stderr, "%s\r", what.c_str());  // named before a crash; overwritten after
  LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(input.data()), n);
}

}  // namespace

int main(int argc, char** argv) {
  long mutations = 0;
  std::uint64_t seed = 1;
  std::vector<fs::path> inputs;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("-mutations=", 0) == 0) {
      mutations = std::strtol(a.c_str() + 11, nullptr, 10);
    } else if (a.rfind("-keep=", 0) == 0) {
      keep_file = a.substr(6);
    } else if (a.rfind("-seed=", 0) == 0) {
      seed = std::strtoull(a.c_str() + 6, nullptr, 10);
    } else if (fs::is_directory(a)) {
      for (const auto& e : fs::directory_iterator(a))
        if (e.is_regular_file()) inputs.push_back(e.path());
    } else if (fs::is_regular_file(a)) {
      inputs.push_back(a);
    } else {
      std::fprintf(stderr, "%s: no such file or folder\n", a.c_str());
      return 1;
    }
  }
  std::sort(inputs.begin(), inputs.end());
  if (inputs.empty()) {
    std::fprintf(stderr, "usage: %s [-mutations=N] [-seed=S] [-keep=FILE] DIR_OR_FILE...  (no input found)\n", argv[0]);
    return 1;
  }
  std::uint64_t rng = seed;
  long runs = 0;
  for (const fs::path& p : inputs) {
    const std::string original = read_file(p);
    run_one(original, p.string());
    ++runs;
    for (long m = 0; m < mutations; ++m) {
      std::string s = original;
      const std::uint64_t edits = 1 + splitmix64(rng) % 4;
      for (std::uint64_t e = 0; e < edits; ++e) mutate(s, rng);
      run_one(s, p.string() + " mutation " + std::to_string(m));
      ++runs;
    }
  }
  std::fprintf(stderr, "\n%ld inputs from %zu files: no crash\n", runs, inputs.size());
  return 0;
}
