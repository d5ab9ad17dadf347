// `loom bench realtime --quick` end to end: the three CSVs (character, toy box, sheet) have their columns and
// one row per tier and for Bullet classic's twin, the toy box's with bodies through the cloth and its
// converged reference and half-step check.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "CliRunner.h"

namespace loom::test {
namespace {

namespace fs = std::filesystem;

using Rows = std::map<std::string, std::vector<std::string>>;  // system -> its fields

// The header line and the rows of a CSV, by system.
Rows read_csv(const fs::path& path, std::string& header) {
  std::istringstream in(slurp(path));
  std::getline(in, header);
  Rows rows;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> f;
    std::stringstream ls(line);
    for (std::string c; std::getline(ls, c, ',');) f.push_back(c);
    if (!f.empty()) rows[f[0]] = f;
  }
  return rows;
}

double num(const Rows& rows, const std::string& system, size_t column) {
  return std::stod(rows.at(system).at(column));
}

TEST(BenchRealtime, QuickRunWritesEveryTierAndBulletClassicForThreeScenes) {
  const fs::path out = test_dir() / "out";
  const CliResult r = run_loom("bench realtime --quick --out " + out.string());
  if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "no bench realtime in this build";
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const std::string columns = "system,ms_per_frame,rms_error_m,max_penetration_m,max_strain,finite";
  for (const char* name : {"character_realtime", "toy_box_realtime", "sheet_realtime"}) {
    std::string header;
    const Rows rows = read_csv(out / (std::string(name) + ".csv"), header);
    const bool toy = std::string(name) == "toy_box_realtime";
    EXPECT_EQ(header, toy ? columns + ",bodies_through" : columns) << name;
    for (const char* system : {"loom:realtime", "loom:balanced", "loom:reference", "bullet_classic"}) {
      ASSERT_TRUE(rows.count(system)) << name << " " << system;
      EXPECT_EQ(rows.at(system).size(), toy ? 7u : 6u) << name << " " << system;
      EXPECT_GT(num(rows, system, 1), 0.0) << name << " " << system;  // ms per frame
      EXPECT_LT(num(rows, system, 4), 1.0) << name << " " << system;  // max strain
    }
    for (const char* system : {"loom:realtime", "loom:balanced", "loom:reference"}) {
      EXPECT_EQ(rows.at(system)[5], "1") << name << " " << system;  // finite
      const double rms = num(rows, system, 2);
      EXPECT_TRUE(std::isfinite(rms) && rms >= 0.0 && rms < 0.1) << name << " " << system << " " << rms;
    }
    EXPECT_TRUE(fs::exists(out / (std::string(name) + ".png")) ||
                fs::exists(out / (std::string(name) + ".gp")))
        << name;
    if (toy) {
      // The converged run is the reference itself; halving its step moves it less than any tier is off.
      ASSERT_TRUE(rows.count("loom:converged"));
      ASSERT_TRUE(rows.count("loom:converged_half_step"));
      EXPECT_EQ(num(rows, "loom:converged", 2), 0.0);
      EXPECT_LT(num(rows, "loom:converged_half_step", 2), num(rows, "loom:realtime", 2));
      for (const char* system : {"loom:realtime", "loom:balanced", "loom:converged"})
        EXPECT_EQ(rows.at(system)[6], "0") << system;  // no body through the cloth
    }
    // Bullet classic's twin is a point of the plot too: its frames against the same reference.
    EXPECT_TRUE(std::isfinite(num(rows, "bullet_classic", 2))) << name;
  }
}

}  // namespace
// What the sheet and toy-box runs hold (the simulations and the frames kept for the errors) is checked
// against the memory budget before the folder is made, by the option that sets it.
TEST(BenchRealtime, TheSheetIsCountedBeforeTheFolderIsMade) {
  const auto out = loom::test::test_dir() / "big";
  const auto r = loom::test::run_loom("bench realtime --scenes sheet --sheet 512 --out " + out.string(),
                                      "LOOM_MEMORY_LIMIT=200000000 ");
  if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "no bench realtime in this build";
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("--sheet: --sheet 512 over 120 frames"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(set by LOOM_MEMORY_LIMIT) is available"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace loom::test
