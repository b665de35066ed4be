#pragma once

namespace stend {
// libhdf5 prints its error stack to stderr by default; Stend reports what failed itself (file,
// byte, reason). Turns libhdf5's printing off for the process; every reader of HDF5 files calls it
// before opening one (run.h5, MATLAB 7.3 files through matio). Safe to call again and from threads.
void silence_hdf5_error_printing();
}  // namespace stend
