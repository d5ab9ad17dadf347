// A Bullet-world scene (scenes/toy_box.json) whose cloth the guard stops: with `guard.max_strain` at 5 %,
// below what the bodies landing on the cloth stretch it to, the strain guard stops the run within the first
// second. `loom run` names the output frame (60 Hz), not the Bullet substep (1/240 s) the guard failed in:
// frame N spans t in ((N - 1) / fps, N / fps], and frames up to N - 1 are valid. `loom compare` marks Loom's
// row diverged by the same guard and prints why.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>

#include "CliRunner.h"

namespace {

namespace fs = std::filesystem;
using loom::test::run_loom;
using loom::test::slurp;
using loom::test::test_dir;

const std::string kToyBox = std::string(LOOM_SOURCE_DIR) + "/scenes/toy_box.json";

TEST(BulletDivergenceCli, TheGuardNamesTheOutputFrameNotTheBulletSubstep) {
  const fs::path out = test_dir() / "out";
  const auto r =
      run_loom("run " + kToyBox + " --out " + out.string() + " --frames 16 --set guard.max_strain=0.05");
  if (r.err.find("this loom was built without it") != std::string::npos)
    GTEST_SKIP() << "loom built without the Bullet bridge";
  ASSERT_EQ(r.code, 3) << r.err;
  std::smatch m;
  const std::regex re(R"(in frame (\d+) \(t = ([0-9.]+) to ([0-9.]+) s\).*frames up to (\d+) are valid)");
  ASSERT_TRUE(std::regex_search(r.err, m, re)) << r.err;
  const int frame = std::stoi(m[1]), valid = std::stoi(m[4]);
  const double t0 = std::stod(m[2]), t1 = std::stod(m[3]), fps = 60.0;
  // The failed interval lies inside the named output frame, the frame after the last valid one. The times
  // are printed to 6 digits (0.233333 for 14/60 s: 13.99998 frames), so the frame count is read to 1e-3.
  EXPECT_EQ(frame, static_cast<int>(std::floor(t0 * fps + 1e-3)) + 1) << r.err;
  EXPECT_NEAR(t0, (frame - 1) / fps, 1e-6) << r.err;  // the output frame's whole span, not a substep's
  EXPECT_NEAR(t1, frame / fps, 1e-6) << r.err;
  EXPECT_EQ(valid, frame - 1) << r.err;
  EXPECT_NE(r.err.find("limit guard.max_strain 0.05"), std::string::npos) << r.err;  // the bound, by field
  EXPECT_NE(r.err.find("solver.substeps"), std::string::npos) << r.err;  // inside the regime: the step fields
}

TEST(BulletDivergenceCli, CompareMarksTheRunTheGuardStopsAsDiverged) {
  const fs::path out = test_dir() / "out";
  const auto r =
      run_loom("compare " + kToyBox + " --out " + out.string() + " --frames 16 --set guard.max_strain=0.05");
  if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "loom built without Bullet";
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("diverged: the strain exploded"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(slurp(out / "compare.json"));
  EXPECT_EQ(j["loom"]["diverged"], true) << j.dump(1);
  EXPECT_NE(j["loom"]["diverged_why"].get<std::string>().find("strain exploded"), std::string::npos);
  EXPECT_NE(j["loom"]["diverged_why"].get<std::string>().find("guard.max_halvings"), std::string::npos);
  const std::string csv = slurp(out / "compare.csv");
  EXPECT_NE(csv.find("\nloom,1,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",1\nbullet_classic"), std::string::npos) << csv;  // loom's diverged column
  for (const char* bad : {"nan", "inf"}) EXPECT_EQ(csv.find(bad), std::string::npos) << csv;
}

// A character scene's compare (Bullet classic's twin on the character's capsules) says why a system
// diverged too, in the table, compare.json and with the divergence report's fields.
TEST(BulletDivergenceCli, CharacterCompareSaysWhyLoomDiverged) {
  const fs::path out = test_dir() / "out";
  const auto r = run_loom("compare " + std::string(LOOM_SOURCE_DIR) + "/scenes/character_cape.json --out " +
                          out.string() + " --frames 6 --set guard.max_strain=0.001");
  if (r.err.find("unknown command") != std::string::npos || r.err.find("built without") != std::string::npos)
    GTEST_SKIP() << "loom built without Bullet or characters";
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("loom               diverged: the strain exploded"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(slurp(out / "compare.json"));
  EXPECT_EQ(j["loom"]["diverged"], true) << j.dump(1);
  const std::string why = j["loom"]["diverged_why"].get<std::string>();
  EXPECT_NE(why.find("limit guard.max_strain 0.001"), std::string::npos) << why;
  EXPECT_NE(why.find("guard.max_halvings"), std::string::npos) << why;
  const std::string csv = slurp(out / "compare.csv");
  for (const char* bad : {"nan", "inf"}) EXPECT_EQ(csv.find(bad), std::string::npos) << csv;
}

}  // namespace
