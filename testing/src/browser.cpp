#include "stend/testing/browser.hpp"

#include "stend/testing/files.hpp"
#include "stend/testing/program.hpp"

#include <zlib.h>

#include <cstdint>
#include <cstdlib>
#include <sstream>

namespace stend::testing {

namespace {

std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

// PNG's per-row filters undone in place (types 0–4).
void unfilter(const std::vector<unsigned char>& raw, Image& img) {
  const std::size_t stride = static_cast<std::size_t>(img.w) * static_cast<std::size_t>(img.channels);
  const auto bpp = static_cast<std::size_t>(img.channels);
  img.px.assign(stride * static_cast<std::size_t>(img.h), 0);
  for (std::size_t y = 0; y < static_cast<std::size_t>(img.h); ++y) {
    const unsigned char f = raw[y * (stride + 1)];
    const unsigned char* in = &raw[y * (stride + 1) + 1];
    unsigned char* out = &img.px[y * stride];
    const unsigned char* up = y ? &img.px[(y - 1) * stride] : nullptr;
    for (std::size_t x = 0; x < stride; ++x) {
      const int a = x >= bpp ? out[x - bpp] : 0, u = up ? up[x] : 0, c = (x >= bpp && up) ? up[x - bpp] : 0;
      int v = in[x];
      switch (f) {
        case 1: v += a; break;
        case 2: v += u; break;
        case 3: v += (a + u) / 2; break;
        case 4: {
          const int p = a + u - c, pa = std::abs(p - a), pb = std::abs(p - u), pc = std::abs(p - c);
          v += (pa <= pb && pa <= pc) ? a : (pb <= pc ? u : c);
          break;
        }
        default: break;
      }
      out[x] = static_cast<unsigned char>(v & 0xff);
    }
  }
}

}  // namespace

std::string find_chromium() {
  for (const char* c : {"/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome"})
    if (std::filesystem::exists(c)) return c;
  return {};
}

BrowserOutput headless_chromium(const std::string& url, int budget_ms, const std::filesystem::path& screenshot,
                                int width, int height) {
  std::ostringstream cmd;
  cmd << "timeout 120 " << shell_quote(find_chromium())
      << " --headless --no-sandbox --disable-gpu --hide-scrollbars --no-first-run --enable-logging=stderr --v=0"
      << " --virtual-time-budget=" << budget_ms << " --window-size=" << width << "," << height;
  if (screenshot.empty()) cmd << " --dump-dom";
  else cmd << " --screenshot=" << shell_quote(screenshot.string());
  cmd << " " << shell_quote(url);
  const ProgramOutput o = run_command(cmd.str());
  BrowserOutput b;
  b.code = o.code;
  b.log = o.text;
  b.dom = o.text;  // the DOM is printed on stdout, among the log lines
  std::istringstream lines(o.text);
  for (std::string line; std::getline(lines, line);)
    if (line.find(":CONSOLE") != std::string::npos) b.console += line + "\n";
  return b;
}

bool read_png(const std::filesystem::path& file, Image& img) {
  const std::string d = read_text(file);
  const auto* b = reinterpret_cast<const unsigned char*>(d.data());
  if (d.size() < 8 || d.compare(1, 3, "PNG") != 0) return false;
  std::string idat;
  int depth = 0, type = 0;
  for (std::size_t p = 8; p + 8 <= d.size();) {
    const std::uint32_t len = be32(b + p);
    const std::string tag = d.substr(p + 4, 4);
    if (tag == "IHDR") {
      img.w = static_cast<int>(be32(b + p + 8));
      img.h = static_cast<int>(be32(b + p + 12));
      depth = b[p + 16];
      type = b[p + 17];
    } else if (tag == "IDAT") {
      idat.append(d, p + 8, len);
    }
    p += 12 + len;
  }
  if (depth != 8 || (type != 2 && type != 6)) return false;
  img.channels = type == 6 ? 4 : 3;
  const std::size_t stride = static_cast<std::size_t>(img.w) * static_cast<std::size_t>(img.channels);
  std::vector<unsigned char> raw((stride + 1) * static_cast<std::size_t>(img.h));
  uLongf n = raw.size();
  if (uncompress(raw.data(), &n, reinterpret_cast<const Bytef*>(idat.data()), idat.size()) != Z_OK) return false;
  unfilter(raw, img);
  return true;
}

std::size_t count_colour(const Image& img, unsigned rgb, int tolerance) {
  const int want[3] = {static_cast<int>((rgb >> 16) & 0xff), static_cast<int>((rgb >> 8) & 0xff),
                       static_cast<int>(rgb & 0xff)};
  std::size_t n = 0;
  for (std::size_t i = 0; i + 2 < img.px.size(); i += static_cast<std::size_t>(img.channels))
    if (std::abs(img.px[i] - want[0]) <= tolerance && std::abs(img.px[i + 1] - want[1]) <= tolerance &&
        std::abs(img.px[i + 2] - want[2]) <= tolerance)
      ++n;
  return n;
}

}  // namespace stend::testing
