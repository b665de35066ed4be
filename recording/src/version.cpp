#include "stend/recording/version.hpp"

namespace stend {
const char* version() { return STEND_VERSION; }
}  // namespace stend
