// `loom fabric-test` writes no nan or inf: a figure the test has not (no theory value, a solver that
// measured nothing) is "-" in report.md and an empty cell in curve.csv, and a run that measured nothing
// exits 3 naming the test, the quantity and the solver.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "CliRunner.h"

namespace loom::test {
namespace {

namespace fs = std::filesystem;

void expect_finite_text(const fs::path& file) {
  const std::string text = slurp(file);
  EXPECT_FALSE(text.empty()) << file;
  for (const char* bad : {"nan", "inf"})
    EXPECT_EQ(text.find(bad), std::string::npos) << file << ":\n" << text;
}

TEST(FabricReport, ATestThatMeasuresNothingExitsThreeAndWritesNoInf) {
  const fs::path out = test_dir() / "tensile";
  const auto r = run_loom("fabric-test tensile --solver symplectic_euler --out " + out.string());
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("tensile: measured no finite"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("solver symplectic_euler"), std::string::npos) << r.err;
  expect_finite_text(out / "report.md");
  EXPECT_NE(slurp(out / "report.md").find("measured | - |"), std::string::npos) << slurp(out / "report.md");
}

TEST(FabricReport, ATestWithoutATheoryValueShowsADash) {
  const fs::path out = test_dir() / "drape";
  const auto r = run_loom("fabric-test drape --resolution 9 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  expect_finite_text(out / "report.md");
  expect_finite_text(out / "curve.csv");
  EXPECT_NE(slurp(out / "report.md").find("| theory | - |"), std::string::npos) << slurp(out / "report.md");
}

}  // namespace
}  // namespace loom::test
