// Tables of means without inputs (format means_table): the layouts found (column names or none,
// delimiters, units from the options or the names, counts), the rows' n and sigma held over each row
// (the held-mean truth columns), the event stating the layout, what is refused and why, detection by
// content (a log of samples is not taken for a table); and the same n and sigma on static_table.
#include <gtest/gtest.h>

#include <stend/io/formats.hpp>
#include <stend/io/importers.hpp>
#include <stend/physics/units.hpp>
#include <stend/recording/truth_columns.hpp>
#include <stend/testing/files.hpp>

#include <cmath>
#include <string>

namespace fs = std::filesystem;
using namespace stend;
using namespace stend::io;
using stend::testing::TempDir;
using stend::testing::write_text;

namespace {

constexpr double kG = physics::kStandardGravity;

// Six faces and two diagonals, in g (Magneto's form: one row a line, no names).
const char* kRowsG =
    "1.002 0.001 -0.003\n-0.998 0.002 0.001\n0.003 1.001 0.002\n0.001 -0.999 -0.002\n"
    "0.002 -0.001 1.003\n-0.001 0.002 -0.997\n0.578 0.577 0.576\n-0.577 0.578 -0.579\n";

// The import event's text (the one from the importer, not the format's).
std::string import_event(const Recording& rec) {
  for (const auto& e : rec.events)
    if (e.message.rfind("imported a table of means", 0) == 0) return e.message;
  return {};
}

// The value of held-mean column `name` at the start of row k.
double held(const Recording& rec, const std::string& name, std::size_t k) {
  const int c = rec.truth_column(name);
  EXPECT_GE(c, 0) << name;
  return rec.truth[3 * k][static_cast<std::size_t>(c)];  // three snapshots a row
}

std::string refusal(const fs::path& file, const std::string& format, const ImportOptions& o) {
  try {
    open_dataset({file}, format, o);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(not refused)";
}

ImportOptions in_g() {
  ImportOptions o;
  o.set("accel_unit", "g");
  return o;
}

}  // namespace

TEST(MeansTableImport, MagnetosFormIsDetectedAndHeldRowByRow) {
  TempDir dir("means");
  write_text(dir / "magneto.txt", std::string("# means in g\n") + kRowsG);
  EXPECT_EQ(detect_format({dir / "magneto.txt"}).name, "means_table");
  std::string used;
  const Recording rec = open_dataset({dir / "magneto.txt"}, "auto", in_g(), &used);
  EXPECT_EQ(used, "means_table");
  ASSERT_EQ(rec.segments.size(), 8u);
  EXPECT_EQ(rec.segments[0].kind, SegmentKind::kOrientation);
  EXPECT_NEAR(rec.samples.front().accel_mps2[0], 1.002 * kG, 1e-12);
  EXPECT_NEAR(rec.samples.back().accel_mps2[2], -0.579 * kG, 1e-12);
  EXPECT_FALSE(rec.header.info.has_gyro);
  EXPECT_EQ(rec.truth_column("f_x_mps2"), -1);  // no known input
  EXPECT_TRUE(std::isnan(held(rec, kHeldCountColumn, 0)));
  EXPECT_TRUE(std::isnan(held(rec, kHeldSigmaColumns[0], 0)));
  const std::string event = import_event(rec);
  for (const char* said : {"8 rows", "blanks-delimited", "no column-name line: three columns taken as ax ay az",
                           "means in g (--accel-unit)", "noise columns none",
                           "rows weighted equally, the spread from the fit's residuals"})
    EXPECT_NE(event.find(said), std::string::npos) << said << " not in: " << event;
}

TEST(MeansTableImport, NamedColumnsInCountsWithNAndSigma) {
  TempDir dir("means");
  std::string csv = "label;acc_x;acc_y;acc_z;count;std\n";
  const char* rows[] = {"a;16400;10;-40;500;12", "b;-16380;20;15;800;10", "c;5;16390;-8;400;11",
                        "d;12;-16370;30;600;9",  "e;-3;4;16410;500;12",  "f;7;-9;-16360;700;13"};
  for (const char* r : rows) csv += std::string(r) + "\n";
  write_text(dir / "counts.csv", csv);
  EXPECT_FALSE(looks_like_means_table(dir / "counts.csv"));  // a column it cannot name: --format
  ImportOptions o;
  o.set("accel_lsb", "1/16384g");
  const Recording rec = open_dataset({dir / "counts.csv"}, "means_table", o);
  ASSERT_EQ(rec.segments.size(), 6u);
  const double lsb = kG / 16384.0;
  EXPECT_NEAR(rec.samples.front().accel_mps2[0], 16400 * lsb, 1e-12);
  EXPECT_DOUBLE_EQ(held(rec, kHeldCountColumn, 1), 800);
  for (const char* c : kHeldSigmaColumns) EXPECT_NEAR(held(rec, c, 1), 10 * lsb, 1e-15);  // sigma in counts → m/s^2
  EXPECT_DOUBLE_EQ(rec.header.info.accel_lsb_mps2, lsb);
  const std::string event = import_event(rec);
  for (const char* said : {"semicolon-delimited", "means acc_x, acc_y, acc_z", "count (samples per row)",
                           "std (one sigma per row, all axes)", "ignored columns label", "counts of",
                           "sigma/sqrt(n) from the table"})
    EXPECT_NE(event.find(said), std::string::npos) << said << " not in: " << event;
}

TEST(MeansTableImport, TabsPerAxisSigmaAndUnitsFromTheNames) {
  TempDir dir("means");
  std::string tsv = "a_x_g\ta_y_g\ta_z_g\tn\tsigma_x\tsigma_y\tsigma_z\n";
  for (const char* r : {"1.0\t0.0\t0.0", "-1.0\t0.0\t0.0", "0.0\t1.0\t0.0", "0.0\t-1.0\t0.0", "0.0\t0.0\t1.0"})
    tsv += std::string(r) + "\t100\t0.001\t0.002\t0.003\n";
  write_text(dir / "tabs.tsv", tsv);
  EXPECT_EQ(detect_format({dir / "tabs.tsv"}).name, "means_table");
  const Recording rec = open_dataset({dir / "tabs.tsv"}, "auto");  // g from the names
  EXPECT_NEAR(rec.samples.front().accel_mps2[0], kG, 1e-12);
  EXPECT_NEAR(held(rec, kHeldSigmaColumns[2], 0), 0.003 * kG, 1e-15);
  EXPECT_NE(import_event(rec).find("means in g (from the columns' names)"), std::string::npos) << import_event(rec);
  ImportOptions mps2;
  mps2.set("accel_unit", "m/s^2");
  EXPECT_NE(refusal(dir / "tabs.tsv", "auto", mps2).find("the columns' names state the unit g but the import options "
                                                          "another"),
            std::string::npos);
}

TEST(MeansTableImport, WhatIsRefusedSaysWhy) {
  TempDir dir("means");
  const ImportOptions g = in_g();
  auto refused = [&](const std::string& text, const std::string& why, const ImportOptions& o) {
    write_text(dir / "bad.csv", text);
    const std::string got = refusal(dir / "bad.csv", "means_table", o);
    EXPECT_NE(got.find(why), std::string::npos) << "expected '" << why << "' in: " << got;
  };
  refused("t,ax,ay,az\n0,1,0,0\n", "column 't' is a time: this is a log of samples, not a table of means", g);
  refused("1 0 0 5\n0 1 0 5\n", "without a column-name line has three columns (ax ay az); this one has 4", g);
  refused("ax,ay,n\n1,0,5\n", "no accelerometer mean for each axis", g);
  refused("ax,ay,az,sigma\n1,0,0,0\n", "bad.csv:2: column 'sigma': sigma must be a positive standard deviation", g);
  refused("ax,ay,az,n\n1,0,0,2.5\n", "bad.csv:2: column 'n': the samples averaged must be a count of at least 1", g);
  refused("ax,ay,az,sigma_x,sigma_y\n1,0,0,1,1\n", "sigma per axis needs a column for each of x, y and z", g);
  refused("ax,ay,az\n1,0,0\n0,nan,1\n", "bad.csv:3: column 'ay': not a finite number", g);
  refused("ax,ay,az\n1,0,0\n0,1\n", "bad.csv:3: expected 3 fields, found 2", g);
  refused(kRowsG, "these look like g — give --accel-unit g", ImportOptions{});  // g read as m/s^2
  ImportOptions odd;
  odd.set("accept_implausible", "true");
  write_text(dir / "odd.csv", kRowsG);
  EXPECT_EQ(open_dataset({dir / "odd.csv"}, "means_table", odd).segments.size(), 8u);
}

// A headerless three-column log of samples (still or slowly turned) is no table of means: its
// consecutive rows point the same way. It is not detected; --format means_table still reads it.
TEST(MeansTableImport, ALogOfSamplesIsNotTakenForATable) {
  TempDir dir("means");
  std::string log;
  for (int i = 0; i < 40; ++i) {
    const double a = 0.001 * i;  // 0.06° a row
    log += std::to_string(std::sin(a) * kG) + " 0.01 " + std::to_string(std::cos(a) * kG) + "\n";
  }
  write_text(dir / "log.txt", log);
  EXPECT_FALSE(looks_like_means_table(dir / "log.txt"));
  EXPECT_THROW(detect_format({dir / "log.txt"}), InputError);
  EXPECT_EQ(open_dataset({dir / "log.txt"}, "means_table").segments.size(), 40u);
  write_text(dir / "timed.csv", "t,ax,ay,az\n0,1,0,0\n1,0,1,0\n2,0,0,1\n");
  EXPECT_FALSE(looks_like_means_table(dir / "timed.csv"));
}

// static_table takes the same n and sigma (in m/s^2, like its means): held over each row.
TEST(MeansTableImport, StaticTableHoldsItsRowsNoiseToo) {
  TempDir dir("means");
  write_text(dir / "t.csv", "angle_deg,a_z_mps2,n,sigma_mps2\n0,9.9,100,0.02\n90,0.05,400,0.01\n");
  ASSERT_EQ(detect_format({dir / "t.csv"}).name, "static_table");
  const Recording rec = open_dataset({dir / "t.csv"}, "auto");
  EXPECT_DOUBLE_EQ(held(rec, kHeldCountColumn, 1), 400);
  EXPECT_DOUBLE_EQ(held(rec, kHeldSigmaColumns[2], 1), 0.01);
  EXPECT_GE(rec.truth_column("f_z_mps2"), 0);
  write_text(dir / "g.csv", "angle_deg,a_z_mps2,sigma_g\n0,9.9,0.002\n");
  EXPECT_NE(refusal(dir / "g.csv", "auto", {}).find("a static table's values are in m/s^2"), std::string::npos);
}
