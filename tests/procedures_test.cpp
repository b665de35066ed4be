// A log recorded elsewhere plus the procedure that produced it (docs/procedures.md), as a user
// runs it: `stend import LOG --experiment configs/procedures/…` on imucal's real Ferraris session
// finds the six faces where imucal's own annotations put them and the three turns inside the
// annotated turns; the known-orientation fit on the aligned run agrees with the fit on the
// annotations; a procedure the log does not follow is refused naming the step and writes nothing;
// the turns it finds give the gyro's scale imucal finds (the ferraris model); runs imported with one
// procedure file compare; a bench refuses to run a procedure file.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "stend/recording/recording.hpp"
#include "stend/testing/files.hpp"
#include "stend/testing/paths.hpp"
#include "stend/testing/program.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>

namespace fs = std::filesystem;
using stend::testing::run_stend;
using stend::testing::shell_quote;
using stend::testing::TempDir;

namespace {

const std::string src = STEND_SOURCE_DIR;
const std::string ferraris = src + "/configs/procedures/ferraris.yaml";

std::vector<stend::Segment> segments_of(const fs::path& run, stend::SegmentKind kind) {
  const stend::Recording rec = stend::Recording::open(run, stend::SampleLoading::kStream, stend::TruthLoading::kSkip);
  std::vector<stend::Segment> out;
  for (const auto& s : rec.segments)
    if (s.kind == kind) out.push_back(s);
  return out;
}

struct Value {
  double value = 0.0, std_error = 0.0;
};
std::map<std::string, Value> parameters(const fs::path& json) {
  std::map<std::string, Value> out;
  const auto doc = nlohmann::json::parse(stend::testing::read_text(json));
  for (const auto& p : doc.at("parameters"))
    if (p.at("value").is_number() && p.at("std_error").is_number())
      out[p.at("name").get<std::string>()] = {p.at("value").get<double>(), p.at("std_error").get<double>()};
  return out;
}

std::string import_args(const fs::path& log, const std::string& procedure, const fs::path& run) {
  return "import " + shell_quote(log.string()) + " --experiment " + shell_quote(procedure) + " -o " + shell_quote(run.string());
}

TEST(Procedures, ImucalsFerrarisSessionIsFoundWhereItsAnnotationsPutIt) {
  const fs::path csv = stend::testing::shared_data("imucal/annotated_session.csv");
  STEND_SKIP_IF_ABSENT(csv);
  const TempDir dir("procedures");
  const fs::path annotated = dir.path() / "annotated", aligned = dir.path() / "aligned";
  ASSERT_EQ(run_stend("import " + shell_quote(csv.string()) + " -o " + shell_quote(annotated.string())).code, 0);
  const auto r = run_stend(import_args(csv, ferraris, aligned));
  ASSERT_EQ(r.code, 0) << r.text;

  // Faces: inside the annotated part, and most of it (the alignment trims the moves between).
  const auto parts = segments_of(annotated, stend::SegmentKind::kOrientation);
  const auto faces = segments_of(aligned, stend::SegmentKind::kOrientation);
  ASSERT_EQ(parts.size(), 6u);
  ASSERT_EQ(faces.size(), 6u) << r.text;
  const char* order[6] = {"+x up", "-x up", "+y up", "-y up", "+z up", "-z up"};  // imucal's x_p, x_a, …
  for (std::size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(faces[k].targets, order[k]) << k;
    EXPECT_GE(faces[k].t_start_s, parts[k].t_start_s - 0.15) << k;
    EXPECT_LE(faces[k].t_end_s, parts[k].t_end_s + 0.15) << k;
    EXPECT_GT(faces[k].t_end_s - faces[k].t_start_s, 0.6 * (parts[k].t_end_s - parts[k].t_start_s)) << k;
  }
  // Turns: inside the annotated turn parts (each part: still, the turn, still).
  const auto rot_parts = segments_of(annotated, stend::SegmentKind::kRotation);
  const auto turns = segments_of(aligned, stend::SegmentKind::kRotation);
  ASSERT_EQ(rot_parts.size(), 3u);
  ASSERT_EQ(turns.size(), 3u) << r.text;
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_GE(turns[k].t_start_s, rot_parts[k].t_start_s - 0.15) << k;
    EXPECT_LE(turns[k].t_end_s, rot_parts[k].t_end_s + 0.15) << k;
    EXPECT_NE(turns[k].targets.find("360 deg turn about +" + std::string(1, static_cast<char>('x' + k))), std::string::npos)
        << turns[k].targets;
  }

  // The accelerometer fitted against the aligned faces equals the fit against the annotations.
  const std::string model = src + "/estimators/ceres_nonlinear/examples/six_positions.yaml";
  ASSERT_EQ(run_stend("fit " + shell_quote(annotated.string()) + " --model " + shell_quote(model)).code, 0);
  ASSERT_EQ(run_stend("fit " + shell_quote(aligned.string()) + " --model " + shell_quote(model)).code, 0);
  // The annotations hold imucal's g (9.81 m/s^2), the procedure its site's (normal gravity at
  // 49.57 deg, 280 m): a scale is compared as (1 + s)·g.
  const auto a = parameters(annotated / "ceres.json"), b = parameters(aligned / "ceres.json");
  const double g_ratio = 9.81 / stend::Recording::open(aligned, stend::SampleLoading::kStream, stend::TruthLoading::kSkip).header.gravity_mps2;
  for (const char* name : {"accel_bias_x", "accel_bias_y", "accel_bias_z", "accel_scale_x", "accel_scale_y", "accel_scale_z"}) {
    ASSERT_TRUE(a.count(name) && b.count(name)) << name;
    const bool scale = std::string(name).find("scale") != std::string::npos;
    const double expect = scale ? (1.0 + a.at(name).value) * g_ratio - 1.0 : a.at(name).value;
    EXPECT_NEAR(b.at(name).value, expect, 2.0 * a.at(name).std_error) << name;
  }
  // …and `stend fit LOG --experiment` on the file gives the run's numbers.
  const auto on_file = run_stend("fit " + shell_quote(csv.string()) + " --experiment " + shell_quote(ferraris) + " --model " +
                                 shell_quote(model) + " --out " + shell_quote((dir.path() / "file.json").string()));
  ASSERT_EQ(on_file.code, 0) << on_file.text;
  const auto c = parameters(dir.path() / "file.json");
  for (const auto& [name, v] : b) EXPECT_DOUBLE_EQ(c.at(name).value, v.value) << name;

  // Runs imported with one procedure file share its fingerprint: compare takes them.
  const fs::path again = dir.path() / "again";
  ASSERT_EQ(run_stend(import_args(csv, ferraris, again)).code, 0);
  ASSERT_EQ(run_stend("fit " + shell_quote(again.string()) + " --model " + shell_quote(model)).code, 0);
  const auto cmp = run_stend("compare " + shell_quote(aligned.string()) + " " + shell_quote(again.string()) + " --db " +
                             shell_quote((dir.path() / "db.sqlite").string()));
  EXPECT_EQ(cmp.code, 0) << cmp.text;
  EXPECT_NE(cmp.text.find("2 run(s)"), std::string::npos) << cmp.text;
}

// The turns the alignment finds give the gyro (estimators/ceres_nonlinear/examples/ferraris.yaml:
// bias and g-sensitivity from the faces, scale and cross-axis from the turns): its scale factors
// agree with imucal's own Ferraris calibration (example_cal.json, K_g in counts per deg/s over the
// importer's 16.4 LSB/(deg/s); its R_g diagonal is negative: its turns ran the negative way).
TEST(Procedures, ImucalsTurnsGiveTheGyroScaleImucalFinds) {
  const fs::path csv = stend::testing::shared_data("imucal/annotated_session.csv");
  const fs::path cal = stend::testing::shared_data("imucal/example_cal.json");
  STEND_SKIP_IF_ABSENT(csv);
  STEND_SKIP_IF_ABSENT(cal);
  const TempDir dir("procedures");
  const fs::path run = dir.path() / "ferraris";
  ASSERT_EQ(run_stend(import_args(csv, ferraris, run)).code, 0);
  const auto fit = run_stend("fit " + shell_quote(run.string()) + " --model " +
                             shell_quote(src + "/estimators/ceres_nonlinear/examples/ferraris.yaml"));
  ASSERT_EQ(fit.code, 0) << fit.text;
  EXPECT_NE(fit.text.find("Ceres gyroscope calibration (turns)"), std::string::npos) << fit.text;
  const auto ours = parameters(run / "ceres.json");
  const auto ref = nlohmann::json::parse(stend::testing::read_text(cal));
  for (int i = 0; i < 3; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double imucal = std::abs(ref["R_g"][k][k].get<double>() * ref["K_g"][k][k].get<double>()) / 16.4 - 1.0;
    const std::string name = std::string("gyro_scale_") + static_cast<char>('x' + i);
    ASSERT_TRUE(ours.count(name)) << name;
    // Within our uncertainty (the turns known to 1 deg: about 0.2 %) and a few per mille: the
    // alignment integrates from still to still, imucal over its whole annotated part.
    EXPECT_NEAR(ours.at(name).value, imucal, std::min(2.0 * ours.at(name).std_error, 2e-3)) << name;
  }
}

TEST(Procedures, AProcedureTheLogDoesNotFollowIsRefusedNamingTheStep) {
  const fs::path csv = stend::testing::shared_data("imucal/annotated_session.csv");
  STEND_SKIP_IF_ABSENT(csv);
  const TempDir dir("procedures");
  const fs::path procedure = dir.path() / "swapped.yaml";
  stend::testing::write_text(procedure,
                             "experiment: {name: swapped}\n"
                             "bench: {gravity: {value_mps2: 9.81}}\n"
                             "procedure:\n"
                             "  - faces: {list: ['+x up', '-x up', '-y up', '+y up', '+z up', '-z up']}\n");
  const fs::path run = dir.path() / "run";
  const auto r = run_stend(import_args(csv, procedure.string(), run));
  EXPECT_EQ(r.code, 2) << r.text;
  EXPECT_NE(r.text.find("swapped.yaml:4:"), std::string::npos) << r.text;
  EXPECT_NE(r.text.find("face 4 of 6 ('+y up')"), std::string::npos) << r.text;
  EXPECT_FALSE(fs::exists(run)) << "a refused import wrote its folder";
}

// A bench experiment as the procedure of a log of its run written by another logger: the table's
// orientations become faces through the declared (simulated) table's own geometry, found where
// the bench held them, with the bench's specific force as truth.
TEST(Procedures, ABenchExperimentAlignsALogOfItsRun) {
  const TempDir dir("procedures");
  const std::string experiment = src + "/configs/six_position.yaml";
  const auto ran = run_stend("run " + shell_quote(experiment) + " -o " + shell_quote(dir.path().string()) +
                             " --name bench --store csv --quiet");
  ASSERT_EQ(ran.code, 0) << ran.text;
  const fs::path bench = dir.path() / "bench", aligned = dir.path() / "aligned";
  const auto r = run_stend("import " + shell_quote((bench / "imu.csv").string()) +
                           " --format csv --time t_s --accel ax_mps2,ay_mps2,az_mps2 --gyro gx_radps,gy_radps,gz_radps"
                           " --experiment " + shell_quote(experiment) + " -o " + shell_quote(aligned.string()));
  ASSERT_EQ(r.code, 0) << r.text;
  const auto held = segments_of(bench, stend::SegmentKind::kOrientation);
  const auto found = segments_of(aligned, stend::SegmentKind::kOrientation);
  ASSERT_EQ(held.size(), 6u);
  ASSERT_EQ(found.size(), 6u) << r.text;
  const stend::Recording b = stend::Recording::open(bench), a = stend::Recording::open(aligned);
  const int fb = b.truth_column("f_x_mps2"), fa = a.truth_column("f_x_mps2");
  ASSERT_GE(fb, 0);
  ASSERT_GE(fa, 0);
  const auto f_at = [](const stend::Recording& rec, int column, double t) {
    for (std::size_t i = 0; i < rec.truth_t.size(); ++i)
      if (rec.truth_t[i] >= t) return std::vector<double>(rec.truth[i].begin() + column, rec.truth[i].begin() + column + 3);
    return std::vector<double>{};
  };
  for (std::size_t k = 0; k < 6; ++k) {
    EXPECT_LE(found[k].t_start_s, held[k].t_start_s + 0.2) << k;  // the still the bench recorded lies inside
    EXPECT_GE(found[k].t_end_s, held[k].t_end_s - 0.2) << k;
    const auto want = f_at(b, fb, held[k].t_start_s + 1.0), got = f_at(a, fa, found[k].t_start_s);
    ASSERT_EQ(got.size(), 3u);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(got[static_cast<std::size_t>(i)], want[static_cast<std::size_t>(i)], 1e-6) << k;
  }
}

TEST(Procedures, ABenchRefusesToRunAProcedureFile) {
  const auto v = run_stend("validate " + shell_quote(ferraris));
  EXPECT_EQ(v.code, 0) << v.text;
  EXPECT_NE(v.text.find("procedure 'ferraris' for a recording made elsewhere"), std::string::npos) << v.text;
  const TempDir dir("procedures");
  const auto r = run_stend("run " + shell_quote(ferraris) + " -o " + shell_quote(dir.path().string()));
  EXPECT_EQ(r.code, 2) << r.text;
  EXPECT_NE(r.text.find("names no sensor"), std::string::npos) << r.text;
}

}  // namespace
