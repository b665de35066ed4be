#pragma once
// matio, opened the first time a command reads or writes a MATLAB file (core/on_demand/): the
// shared matio loads Debian's shared libhdf5 and with it libcurl and ~35 more libraries, which no
// other command needs. Stend's run store has its own libhdf5, linked statically and hidden
// (recording/CMakeLists.txt); the one matio loads is a separate copy, reached only through matio.
// The importers (io/src/mat_*.cpp) and the results export (reporting) call matio through this.
#include <stend/on_demand.hpp>

#include <matio.h>

#include <cstdint>

namespace stend {

struct MatioLibrary {
  OnDemandLibrary lib{STEND_MATIO_SONAME, "reading or writing MATLAB files"};
  STEND_ON_DEMAND(lib, Mat_Close);
  STEND_ON_DEMAND(lib, Mat_CreateVer);
  STEND_ON_DEMAND(lib, Mat_GetDir);
  STEND_ON_DEMAND(lib, Mat_GetVersion);
  STEND_ON_DEMAND(lib, Mat_Open);
  STEND_ON_DEMAND(lib, Mat_Rewind);
  STEND_ON_DEMAND(lib, Mat_SizeOfClass);
  STEND_ON_DEMAND(lib, Mat_VarCreate);
  STEND_ON_DEMAND(lib, Mat_VarCreateStruct);
  STEND_ON_DEMAND(lib, Mat_VarCreateStruct2);
  STEND_ON_DEMAND(lib, Mat_VarFree);
  STEND_ON_DEMAND(lib, Mat_VarGetNumberOfFields);
  STEND_ON_DEMAND(lib, Mat_VarGetSize);
  STEND_ON_DEMAND(lib, Mat_VarGetStructFieldByIndex);
  STEND_ON_DEMAND(lib, Mat_VarGetStructFieldByName);
  STEND_ON_DEMAND(lib, Mat_VarGetStructFieldnames);
  STEND_ON_DEMAND(lib, Mat_VarRead);
  STEND_ON_DEMAND(lib, Mat_VarReadData);
  STEND_ON_DEMAND(lib, Mat_VarReadInfo);
  STEND_ON_DEMAND(lib, Mat_VarReadNextInfo);
  STEND_ON_DEMAND(lib, Mat_VarSetStructFieldByName);
  STEND_ON_DEMAND(lib, Mat_VarWrite);

  // Turns off, for the calling thread, the error-stack printing of the libhdf5 matio reads MAT 7.3
  // files through (a thread-safe libhdf5 keeps it per thread): a damaged file's errors are the
  // importer's to report, with the file and the reason. Cheap to call again.
  void silence_hdf5_error_printing() const {
    thread_local bool silenced = false;
    if (silenced || !set_hdf5_error_printing_) return;
    set_hdf5_error_printing_(0 /* H5E_DEFAULT */, nullptr, nullptr);
    silenced = true;
  }

 private:
  using SetAuto = int (*)(std::int64_t, void*, void*);  // H5Eset_auto2(hid_t, H5E_auto2_t, void*)
  SetAuto set_hdf5_error_printing_ = optional_function<SetAuto>("H5Eset_auto2");  // in matio's libhdf5

  template <class F>
  F optional_function(const char* name) const {
    try {
      return lib.function<F>(name);
    } catch (const IoError&) {
      return nullptr;  // a matio without HDF5 support reads no MAT 7.3 file: nothing to silence
    }
  }
};

// The one table, made by the first caller; throws IoError when matio cannot be loaded.
inline const MatioLibrary& matio() {
  static const MatioLibrary table;
  return table;
}

}  // namespace stend
