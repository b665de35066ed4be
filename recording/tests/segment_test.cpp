// Segment: printed and compared as a value (GTSAM-style print/equals).
#include <gtest/gtest.h>

#include <stend/recording/recording.hpp>

#include <cmath>
#include <sstream>

using stend::Segment;

namespace {

Segment tilt() {
  Segment s;
  s.id = 3;
  s.kind = stend::SegmentKind::kOrientation;
  s.label = "tilt 10";
  s.t_start_s = 12.0;
  s.t_end_s = 22.0;
  s.settled = false;
  return s;
}

}  // namespace

TEST(Segment, PrintsIdKindLabelIntervalAndFlags) {
  std::ostringstream os;
  tilt().print(os);
  EXPECT_EQ(os.str(), "#3 orientation 'tilt 10' 12.00–22.00 s [unsettled]");
}

TEST(Segment, EqualsComparesEveryFieldAndNanMatchesNan) {
  const Segment a = tilt();
  Segment b = a;
  EXPECT_TRUE(a.equals(b));  // setpoint and rate are NaN on both
  b.t_end_s += 1e-12;
  EXPECT_TRUE(a.equals(b));
  b.t_end_s += 1e-3;
  EXPECT_FALSE(a.equals(b));
  b = a;
  b.setpoint_c = 25.0;
  EXPECT_FALSE(a.equals(b));
  b = a;
  b.complete = false;
  EXPECT_FALSE(a.equals(b));
}

TEST(SegmentKind, EveryKindsNameReadsBackAndOtherNamesAreRefused) {
  ASSERT_EQ(stend::segment_kind_names().size(), 7u);
  for (const std::string& name : stend::segment_kind_names()) {
    const auto k = stend::segment_kind_from_string(name);
    ASSERT_TRUE(k) << name;
    EXPECT_EQ(stend::to_string(*k), name);
  }
  EXPECT_FALSE(stend::segment_kind_from_string("orientations"));
  EXPECT_FALSE(stend::segment_kind_from_string(""));
}
