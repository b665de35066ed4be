#pragma once

namespace stend {
// libhdf5 prints its error stack to stderr by default; Stend reports what failed itself (file,
// byte, reason). Turns libhdf5's printing off for the calling thread (a thread-safe libhdf5, as
// Debian's, keeps the setting per thread; otherwise for the process); every reader and writer of
// HDF5 files calls it on its thread before using one. This is the run store's libhdf5 (linked into
// libstend_recording, recording/CMakeLists.txt); matio's is another: stend/matio_library.hpp.
// Cheap to call again.
void silence_hdf5_error_printing();
}  // namespace stend
