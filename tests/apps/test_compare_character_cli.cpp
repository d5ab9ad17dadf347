// `loom compare` on a character scene: a coarse cape on a short excerpt of the CMU 01_01 clip runs
// in Loom and as Bullet's classic soft body anchored to kinematic capsules; both rows carry the `loom
// compare` metrics, the JSON adds penetration counts and attachment errors, and everything but timings
// repeats.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "CliRunner.h"

namespace loom::test {
namespace {

nlohmann::json run_character_compare(const std::string& sub) {
  const auto dir = test_dir() / sub;
  const CliResult r =
      run_loom("compare " + std::string(LOOM_SOURCE_DIR) +
               "/scenes/character_cape.json --frames 20 --set character.garments.0.resolution=0.1 --out " +
               dir.string());
  if (r.code == 2 && r.err.find("unknown command") != std::string::npos) return nullptr;
  if (r.code == 1 && r.err.find("no loom::characters") != std::string::npos) return nullptr;
  EXPECT_EQ(r.code, 0) << r.err;
  const std::string csv = slurp(dir / "compare.csv");
  EXPECT_NE(csv.find("system,available,ms_per_frame,max_strain,mean_strain,max_penetration,diverged\n"),
            std::string::npos);
  EXPECT_NE(csv.find("\nloom,1,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\nbullet_classic,1,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\nbullet_deformable,0,"), std::string::npos) << csv;
  return nlohmann::json::parse(slurp(dir / "compare.json"));
}

TEST(CompareCharacterCli, CapeOnCmu0101InLoomAndBullet) {
  nlohmann::json a = run_character_compare("a");
  if (a.is_null()) GTEST_SKIP() << "loom built without the Bullet bridge or without loom::characters";
  EXPECT_EQ(a["frames"], 20);
  EXPECT_GT(a["character_capsules"].get<int>(), 15);
  EXPECT_EQ(a["garments"], 1);
  for (const char* s : {"loom", "bullet_classic"}) {
    ASSERT_TRUE(a[s]["available"].get<bool>()) << s;
    for (const char* k : {"ms_per_frame", "max_strain", "mean_strain", "max_penetration", "diverged",
                          "penetrating_vertices", "max_attachment_error"})
      EXPECT_TRUE(a[s].contains(k)) << s << "." << k;
    EXPECT_GT(a[s]["mean_strain"].get<double>(), 0.0) << s;  // the garments did deform
    EXPECT_GT(a[s]["ms_per_frame"].get<double>(), 0.0) << s;
  }
  EXPECT_FALSE(a["bullet_deformable"]["available"].get<bool>());
  // Loom: no vertex deeper than the thickness inside a capsule, attachments exact; Bullet's anchors lag
  // (kinematic poses once per frame) but stay attached.
  EXPECT_FALSE(a["loom"]["diverged"].get<bool>());
  EXPECT_LE(a["loom"]["max_penetration"].get<double>(), 0.001);
  EXPECT_LE(a["loom"]["max_attachment_error"].get<double>(), 1e-3);
  EXPECT_LT(a["bullet_classic"]["max_attachment_error"].get<double>(), 0.1);
  nlohmann::json b = run_character_compare("b");
  for (const char* s : {"loom", "bullet_classic"}) {
    a[s].erase("ms_per_frame");
    b[s].erase("ms_per_frame");
  }
  EXPECT_EQ(a.dump(), b.dump());
}

}  // namespace
}  // namespace loom::test
