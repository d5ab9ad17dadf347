// `loom compare` end to end: small trampoline and hanging-cloth runs write compare.csv and
// compare.json with the three systems, and everything but the timings is identical run to run.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "CliRunner.h"

namespace loom::test {
namespace {

nlohmann::json run_compare(const std::string& scene, const std::string& extra, const std::string& sub) {
  const auto dir = test_dir() / sub;
  const CliResult r = run_loom("compare " + std::string(LOOM_SOURCE_DIR) + "/scenes/" + scene + " --out " +
                               dir.string() + " " + extra);
  if (r.code == 2 && r.err.find("unknown command") != std::string::npos) return nullptr;
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "compare.csv"));
  const std::string csv = slurp(dir / "compare.csv");
  EXPECT_NE(csv.find("system,available,ms_per_frame,max_strain,mean_strain,max_penetration,diverged"),
            std::string::npos);
  return nlohmann::json::parse(slurp(dir / "compare.json"));
}

void expect_same_but_timing(nlohmann::json a, nlohmann::json b) {
  for (const char* s : {"loom", "bullet_classic", "bullet_deformable"}) {
    a[s].erase("ms_per_frame");
    b[s].erase("ms_per_frame");
  }
  EXPECT_EQ(a.dump(), b.dump());
}

TEST(CompareCli, TrampolineSmall) {
  const std::string extra = "--frames 24 --set cloths.0.mesh.nodes=[9,9]";
  const nlohmann::json a = run_compare("trampoline.json", extra, "a");
  if (a.is_null()) GTEST_SKIP() << "loom built without the Bullet bridge";
  for (const char* s : {"loom", "bullet_classic", "bullet_deformable"}) {
    ASSERT_TRUE(a.contains(s)) << s;
    for (const char* k : {"ms_per_frame", "max_strain", "mean_strain", "max_penetration", "diverged"})
      EXPECT_TRUE(a[s].contains(k)) << s << "." << k;
  }
  EXPECT_FALSE(a["loom"]["diverged"].get<bool>());
  EXPECT_LT(a["loom"]["max_penetration"].get<double>(), 0.01);
  EXPECT_FALSE(a["bullet_deformable"]["available"].get<bool>());  // rigid bodies: not run, said so
  EXPECT_EQ(a["bodies"], 1);
  expect_same_but_timing(a, run_compare("trampoline.json", extra, "b"));
}

TEST(CompareCli, HangingClothSmall) {
  const std::string extra = "--frames 12 --set cloths.0.mesh.nodes=[9,9] --set solver.substeps=20";
  const nlohmann::json a = run_compare("hanging_cloth.json", extra, "a");
  if (a.is_null()) GTEST_SKIP() << "loom built without the Bullet bridge";
  for (const char* s : {"loom", "bullet_classic", "bullet_deformable"}) {
    ASSERT_TRUE(a[s]["available"].get<bool>()) << s;
    EXPECT_GT(a[s]["mean_strain"].get<double>(), 0.0) << s;
  }
  EXPECT_FALSE(a["loom"]["diverged"].get<bool>());
  expect_same_but_timing(a, run_compare("hanging_cloth.json", extra, "b"));
}

TEST(CompareCli, BadInput) {
  const CliResult none = run_loom("compare");
  if (none.err.find("unknown command") != std::string::npos) GTEST_SKIP();
  EXPECT_EQ(none.code, 2);
  const CliResult frames =
      run_loom("compare " + std::string(LOOM_SOURCE_DIR) + "/scenes/trampoline.json --frames 0");
  EXPECT_EQ(frames.code, 2);  // a bad command line, as for `loom run --frames`
  EXPECT_NE(frames.err.find("--frames"), std::string::npos);
}

}  // namespace
}  // namespace loom::test
