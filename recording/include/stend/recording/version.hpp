#pragma once

namespace stend {
// Stend's version, "MAJOR.MINOR.PATCH".
const char* version();
}  // namespace stend
