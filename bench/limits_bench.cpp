// The physical limits the bench scripts hold Stend against, measured on this machine, one core:
//   memory  one read pass over a buffer larger than the caches [GB/s, median of the passes];
//   parse   std::from_chars of CSV (or blank-separated) doubles, from memory [MB/s of text, values/s]: a generated log
//           like bench/import_bench.sh's, or the first --parse-mib MiB of --parse-file FILE (then
//           also the time to parse the whole file at that speed);
//   read    read() of the given files into a 1 MiB buffer, page cache warm [s, MB/s, median]; and
//           once more from the device, bypassing the page cache (O_DIRECT) [s, MB/s, median] —
//           what an import of a file not read lately waits for (where the file system allows it).
// Standard C++20 and POSIX read() only: no project library. Prints `key value` lines.
//
//   limits_bench [--memory] [--parse] [--parse-file FILE] [--read FILE]... [--memory-mib N]
//                [--rows N] [--parse-mib N] [--passes N]
//   (no --memory/--parse/--parse-file/--read: --memory --parse)
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Keeps a result alive so that the loop computing it is not optimised away.
volatile std::uint64_t g_sink = 0;

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(" \t", colon + 1));
    }
  }
  return "unknown";
}

// One sequential read of every 64-bit word, eight independent sums.
std::uint64_t read_pass(const std::vector<std::uint64_t>& buffer) {
  std::uint64_t s[8] = {};
  const std::size_t n = buffer.size() / 8 * 8;
  const std::uint64_t* p = buffer.data();
  for (std::size_t i = 0; i < n; i += 8)
    for (std::size_t k = 0; k < 8; ++k) s[k] += p[i + k];
  std::uint64_t total = 0;
  for (const auto v : s) total += v;
  return total;
}

void measure_memory(std::size_t mib, int passes) {
  std::vector<std::uint64_t> buffer(mib * (std::size_t{1} << 20) / sizeof(std::uint64_t));
  for (std::size_t i = 0; i < buffer.size(); ++i) buffer[i] = i * 0x9E3779B97F4A7C15ULL;  // every page touched
  g_sink = g_sink + read_pass(buffer);                                                       // warm-up
  std::vector<double> gbps;
  for (int i = 0; i < passes; ++i) {
    const auto start = Clock::now();
    g_sink = g_sink + read_pass(buffer);
    gbps.push_back(static_cast<double>(buffer.size() * sizeof(std::uint64_t)) / seconds_since(start) / 1e9);
  }
  std::printf("memory_buffer_MiB %zu\nmemory_passes %d\nmemory_read_GBps %.3f\n", mib, passes, median(gbps));
}

// A log as bench/import_bench.sh writes it: t,ax,ay,az,gx,gy,gz at 1 kHz, 4–6 decimals.
std::string generated_csv(std::size_t rows) {
  std::string text = "t,ax,ay,az,gx,gy,gz\n";
  text.reserve(rows * 64);
  std::uint64_t state = 1;
  auto uniform = [&state] {  // xorshift64*, [0, 1)
    state ^= state >> 12;
    state ^= state << 25;
    state ^= state >> 27;
    return static_cast<double>((state * 0x2545F4914F6CDD1DULL) >> 11) * 0x1.0p-53;
  };
  char field[64];
  auto put = [&](double v, int decimals, char end) {
    const auto r = std::to_chars(field, field + sizeof field, v, std::chars_format::fixed, decimals);
    text.append(field, r.ptr);
    text.push_back(end);
  };
  for (std::size_t i = 0; i < rows; ++i) {
    put(static_cast<double>(i) / 1000, 6, ',');
    put(uniform() * 0.02 - 0.01, 4, ',');
    put(uniform() * 0.02 - 0.01, 4, ',');
    put(9.81 + uniform() * 0.02 - 0.01, 4, ',');
    put(uniform() * 0.002 - 0.001, 5, ',');
    put(uniform() * 0.002 - 0.001, 5, ',');
    put(uniform() * 0.002 - 0.001, 5, '\n');
  }
  return text;
}

struct Parsed {
  std::size_t values = 0;
  double sum = 0;
};

bool delimiter(char c) { return c == ',' || c == '\n' || c == ' ' || c == '\t' || c == ';' || c == '\r'; }

// Every field that is a number, parsed with std::from_chars; other fields (a header, a label)
// skipped. Fields end at a comma, semicolon, blank, tab or line break.
Parsed parse_csv(std::string_view text) {
  Parsed out;
  const char* p = text.data();
  const char* const end = p + text.size();
  while (p < end) {
    double v = 0;
    const auto r = std::from_chars(p, end, v);
    if (r.ec == std::errc()) {
      out.sum += v;
      ++out.values;
      p = r.ptr;
    }
    while (p < end && !delimiter(*p)) ++p;  // the rest of a field that is not a number
    ++p;                                   // the delimiter
  }
  return out;
}

// The whole file (at most max_bytes of it, cut at the last line break) as text.
std::string read_text(const std::string& path, std::size_t max_bytes, std::size_t& file_bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::cerr << "limits_bench: cannot open " << path << "\n";
    std::exit(2);
  }
  in.seekg(0, std::ios::end);
  file_bytes = static_cast<std::size_t>(in.tellg());
  in.seekg(0);
  std::string text(std::min(file_bytes, max_bytes), '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (text.size() < file_bytes) {
    const auto last = text.rfind('\n');
    if (last != std::string::npos) text.resize(last + 1);
  }
  return text;
}

void measure_parse(const std::string& file, std::size_t rows, std::size_t max_mib, int passes) {
  std::size_t file_bytes = 0;
  const std::string text = file.empty() ? generated_csv(rows) : read_text(file, max_mib << 20, file_bytes);
  Parsed parsed = parse_csv(text);  // warm-up
  std::vector<double> times;
  for (int i = 0; i < passes; ++i) {
    const auto start = Clock::now();
    parsed = parse_csv(text);
    times.push_back(seconds_since(start));
    g_sink = g_sink + static_cast<std::uint64_t>(parsed.sum);
  }
  const double s = median(times);
  const double mbps = static_cast<double>(text.size()) / s / 1e6;
  std::printf("parse_source %s\nparse_bytes %zu\nparse_values %zu\nparse_passes %d\nparse_s %.6f\n"
              "parse_MBps %.1f\nparse_values_per_s %.4g\n",
              file.empty() ? "generated" : file.c_str(), text.size(), parsed.values, passes, s, mbps,
              static_cast<double>(parsed.values) / s);
  if (!file.empty()) std::printf("parse_file_bytes %zu\nparse_file_s %.6f\n", file_bytes, static_cast<double>(file_bytes) / mbps / 1e6);
}

// Bytes read from every file, read() into one 1 MiB buffer (aligned for O_DIRECT); `flags` added
// to open()'s. 0 when a file cannot be read so (O_DIRECT where the file system refuses it).
std::size_t read_files(const std::vector<std::string>& files, char* buffer, std::size_t size, int flags) {
  std::size_t total = 0;
  for (const auto& path : files) {
    const int fd = ::open(path.c_str(), O_RDONLY | flags);
    if (fd < 0 && flags != 0) return 0;
    if (fd < 0) {
      std::cerr << "limits_bench: cannot open " << path << "\n";
      std::exit(2);
    }
    for (;;) {
      const ssize_t n = ::read(fd, buffer, size);
      if (n < 0 && flags != 0) {
        ::close(fd);
        return 0;
      }
      if (n < 0) {
        std::cerr << "limits_bench: cannot read " << path << "\n";
        std::exit(2);
      }
      if (n == 0) break;
      total += static_cast<std::size_t>(n);
      g_sink = g_sink + static_cast<unsigned char>(buffer[0]);
    }
    ::close(fd);
  }
  return total;
}

// The median time of `passes` reads of every file with open() flags `flags`; 0 when they cannot be read so.
double read_time(const std::vector<std::string>& files, char* buffer, std::size_t size, int flags, int passes,
                 std::size_t& bytes) {
  std::vector<double> times;
  for (int i = 0; i < passes; ++i) {
    const auto start = Clock::now();
    bytes = read_files(files, buffer, size, flags);
    if (bytes == 0) return 0.0;
    times.push_back(seconds_since(start));
  }
  return median(times);
}

void measure_read(const std::vector<std::string>& files, int passes) {
  constexpr std::size_t kBuffer = std::size_t{1} << 20;
  const std::unique_ptr<char, decltype(&std::free)> buffer(static_cast<char*>(std::aligned_alloc(4096, kBuffer)), std::free);
  std::size_t bytes = read_files(files, buffer.get(), kBuffer, 0);  // warms the page cache
  const double s = read_time(files, buffer.get(), kBuffer, 0, passes, bytes);
  std::printf("read_files %zu\nread_bytes %zu\nread_passes %d\nread_s %.6f\nread_MBps %.1f\n", files.size(), bytes,
              passes, s, static_cast<double>(bytes) / s / 1e6);
  std::size_t direct_bytes = 0;
  const double d = read_time(files, buffer.get(), kBuffer, O_DIRECT, passes, direct_bytes);
  if (d > 0.0 && direct_bytes == bytes)
    std::printf("read_direct_s %.6f\nread_direct_MBps %.1f\n", d, static_cast<double>(bytes) / d / 1e6);
}

[[noreturn]] void usage() {
  std::cerr << "usage: limits_bench [--memory] [--parse] [--parse-file FILE] [--read FILE]... [--memory-mib N]\n"
               "                    [--rows N] [--parse-mib N] [--passes N]\n";
  std::exit(2);
}

std::size_t count(const char* text) {
  std::size_t n = 0;
  const std::string_view s(text);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), n);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size() || n == 0) usage();
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  bool memory = false, parse = false;
  std::string parse_file;
  std::vector<std::string> files;
  std::size_t memory_mib = 512, rows = 1000000, parse_mib = 64;
  int passes = 7;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--memory") memory = true;
    else if (a == "--parse") parse = true;
    else if (a == "--parse-file" && has_value) parse_file = argv[++i];
    else if (a == "--read" && has_value) files.emplace_back(argv[++i]);
    else if (a == "--memory-mib" && has_value) memory_mib = count(argv[++i]);
    else if (a == "--rows" && has_value) rows = count(argv[++i]);
    else if (a == "--parse-mib" && has_value) parse_mib = count(argv[++i]);
    else if (a == "--passes" && has_value) passes = static_cast<int>(std::min<std::size_t>(count(argv[++i]), 1000));
    else usage();
  }
  if (!memory && !parse && parse_file.empty() && files.empty()) memory = parse = true;

  std::printf("cpu %s\nnproc %u\n", cpu_model().c_str(), std::thread::hardware_concurrency());
  if (memory) measure_memory(memory_mib, passes);
  if (parse || !parse_file.empty()) measure_parse(parse_file, rows, parse_mib, passes);
  if (!files.empty()) measure_read(files, passes);
  std::printf("checksum %llu\n", static_cast<unsigned long long>(g_sink));
  return 0;
}
