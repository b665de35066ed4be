// The files the live view serves from inside the program (generated: live/cmake/embed.cmake).
#pragma once

#include <string_view>
#include <vector>

namespace stend::live {

struct WebAsset {
  std::string_view url;           // "/", "/live.js", "/uPlot.iife.min.js", …
  std::string_view bytes;
};

const std::vector<WebAsset>& web_assets();

}  // namespace stend::live
