#pragma once
// A C library opened the first time a command needs it (dlopen by its SONAME), not when the
// program starts (core/on_demand/CMakeLists.txt says why). Its functions are looked up by name
// into a table of pointers of the header's own types, so the compiler checks every call as if
// the library were linked:
//
//   struct LibPq {
//     OnDemandLibrary lib{"libpq.so.5", "the PostgreSQL results store"};
//     STEND_ON_DEMAND(lib, PQexec);  // a member PQexec of type decltype(&::PQexec)
//   };
//
// A missing library or function throws IoError (exit 4, docs/errors.md: an installation that lacks
// it) naming both and what needed them.
#include <stend/errors.hpp>

#include <dlfcn.h>

#include <cstring>
#include <string>

namespace stend {

class OnDemandLibrary {
 public:
  // soname: what dlopen is given (from stend_soname at build time); needed_for: what cannot work
  // without it, for the error ("reading MATLAB files").
  OnDemandLibrary(const char* soname, const char* needed_for)
      : soname_(soname), needed_for_(needed_for), handle_(::dlopen(soname, RTLD_NOW | RTLD_LOCAL)) {
    if (!handle_) {
      const char* why = ::dlerror();
      throw IoError(needed_for_ + " needs the library " + soname_ + ", which cannot be loaded: " +
                               (why ? why : "dlopen failed"));
    }
  }
  // Never closed: its functions may be called until the program exits.
  OnDemandLibrary(const OnDemandLibrary&) = delete;
  OnDemandLibrary& operator=(const OnDemandLibrary&) = delete;

  // The library's function `name`, as a pointer of type F (decltype(&::name)).
  template <class F>
  F function(const char* name) const {
    ::dlerror();
    void* symbol = ::dlsym(handle_, name);
    if (!symbol) {
      throw IoError(needed_for_ + ": the library " + soname_ + " has no function " + name +
                               " (a version other than the one Stend was built against?)");
    }
    F f = nullptr;
    static_assert(sizeof f == sizeof symbol);
    std::memcpy(&f, &symbol, sizeof f);
    return f;
  }
  // The raw handle, for dlsym in the libraries this one loaded (matio's libhdf5).
  void* handle() const { return handle_; }

 private:
  std::string soname_;
  std::string needed_for_;
  void* handle_;
};

}  // namespace stend

// A member named as the C function, holding it: STEND_ON_DEMAND(lib, PQexec) declares
// `decltype(&::PQexec) PQexec`, looked up in `lib` when the table is made.
#define STEND_ON_DEMAND(lib, name) decltype(&::name) name = (lib).function<decltype(&::name)>(#name)
