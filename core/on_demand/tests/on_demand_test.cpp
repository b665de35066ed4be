// OnDemandLibrary: a library opened by its SONAME, its functions typed by its own header; what is
// missing named in an IoError (exit 4).
#include <stend/on_demand.hpp>

#include <gtest/gtest.h>
#include <zlib.h>

#include <string>

namespace {

struct Zlib {
  stend::OnDemandLibrary lib{STEND_TEST_ZLIB_SONAME, "the test"};
  STEND_ON_DEMAND(lib, zlibVersion);
  STEND_ON_DEMAND(lib, crc32);
};

TEST(OnDemand, OpensTheLibraryAndCallsItsFunctionsByTheirOwnTypes) {
  const Zlib z;
  EXPECT_EQ(std::string(z.zlibVersion()), std::string(ZLIB_VERSION));  // the library the header describes
  const unsigned char bytes[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  EXPECT_EQ(z.crc32(0, bytes, sizeof bytes), 0xCBF43926u);  // CRC-32's check value
}

TEST(OnDemand, AMissingLibraryIsAnIoErrorNamingItAndWhatNeedsIt) {
  try {
    stend::OnDemandLibrary lib("libstend-no-such-library.so.7", "reading widgets");
    FAIL() << "opened a library that does not exist";
  } catch (const stend::IoError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("reading widgets needs the library libstend-no-such-library.so.7"), std::string::npos) << what;
  }
}

TEST(OnDemand, AMissingFunctionIsAnIoErrorNamingIt) {
  const stend::OnDemandLibrary lib(STEND_TEST_ZLIB_SONAME, "the test");
  try {
    (void)lib.function<int (*)()>("stend_no_such_function");
    FAIL() << "found a function that does not exist";
  } catch (const stend::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("has no function stend_no_such_function"), std::string::npos) << e.what();
  }
}

}  // namespace
