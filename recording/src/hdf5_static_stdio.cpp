// Debian's static libhdf5.a, which this library links (recording/CMakeLists.txt: the shared
// libhdf5 would load libcurl and ~35 more libraries into every Stend command), is compiled as
// position-independent *executable* code: it reaches libc's `stdout` and `stderr` through copy
// relocations, which only a program has, so as is it cannot go into a shared library. Defined
// here, hidden, they are this library's own, and libhdf5.a's references bind to them; they hold
// libc's streams, set before any other code of this library runs. (libhdf5 writes to them only when
// asked to print its error stack or debug output, which Stend turns off: hdf5.hpp.)
#include <dlfcn.h>

struct _IO_FILE;

extern "C" {
__attribute__((visibility("hidden"))) _IO_FILE* stdout = nullptr;
__attribute__((visibility("hidden"))) _IO_FILE* stderr = nullptr;
}

namespace {
_IO_FILE* libc_stream(const char* name) {
  void* stream = ::dlsym(RTLD_DEFAULT, name);  // libc's: ours are hidden, not in the dynamic symbol table
  return stream ? *static_cast<_IO_FILE**>(stream) : nullptr;
}

__attribute__((constructor(101))) void bind_libc_streams() {
  stdout = libc_stream("stdout");
  stderr = libc_stream("stderr");
}
}  // namespace
