// Pages looked at as a user would: headless Chromium (Debian's `chromium`) loading a URL, its
// console messages, its DOM after the scripts ran, a screenshot, and a small PNG reader to check
// what the screenshot shows.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace stend::testing {

// The Chromium program, or "" when none is installed (the test skips, saying so).
std::string find_chromium();

struct BrowserOutput {
  int code = -1;
  std::string dom;      // --dump-dom: the document after `budget_ms` of (virtual) time
  std::string console;  // Chromium's log lines that carry console messages (":CONSOLE"); empty when none
  std::string log;      // everything Chromium printed
};

// Loads `url` for `budget_ms` of virtual time (timers and fetches run) and returns the DOM then;
// with `screenshot` set, writes a PNG of a `width`×`height` window instead of dumping the DOM.
BrowserOutput headless_chromium(const std::string& url, int budget_ms, const std::filesystem::path& screenshot = {},
                                int width = 1280, int height = 1400);

// An 8-bit RGB or RGBA, non-interlaced PNG (what Chromium writes), decoded.
struct Image {
  int w = 0, h = 0, channels = 0;
  std::vector<unsigned char> px;  // rows of w × channels bytes
};
bool read_png(const std::filesystem::path& file, Image& img);

// Pixels of `img` within `tolerance` (per channel) of the colour #rrggbb.
std::size_t count_colour(const Image& img, unsigned rgb, int tolerance = 40);

}  // namespace stend::testing
