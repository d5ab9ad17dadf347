// `loom compare` on a character scene: a coarse cape on a short excerpt of the CMU 01_01 clip runs
// in Loom and as Bullet's classic soft body anchored to kinematic capsules; both rows carry the `loom
// compare` metrics, the JSON adds penetration counts and attachment errors, and everything but timings
// repeats.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "CliRunner.h"

namespace loom::test {
namespace {

nlohmann::json run_character_compare(const std::string& sub) {
  const auto dir = test_dir() / sub;
  const CliResult r = run_loom(
      "compare " + std::string(LOOM_SOURCE_DIR) +
      "/scenes/character_cape_reference.json --frames 20 --set character.garments.0.resolution=0.1 --out " +
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
// What the Bullet twin of a character does not carry is refused by field before the folder is made, as for
// other scenes: scene colliders (the twin sees the capsules only) and a cloth of `cloths` beside the
// garments (the twin runs the garments; its pins, path and velocity would be dropped).
TEST(CompareCharacterCli, WhatTheTwinCannotCarryIsRefusedByField) {
  const std::string cape = std::string(LOOM_SOURCE_DIR) + "/scenes/character_cape_reference.json";
  const std::string flag =
      R"({"name": "flag", "mesh": {"type": "grid", "size": [0.3, 0.3], "nodes": [4, 4], "origin": [2, 1, 0]}, )"
      R"("material": "cotton", "pins": [{"grid": [0, 0]}]})";
  struct Case {
    std::string set, field;
  };
  for (
      const Case& c :
      {Case{
           R"('colliders=[{"name": "slab", "shape": "box", "half_extents": [1, 0.05, 1], "position": [0, 0.5, 0]}]')",
           "colliders"},
       Case{"'cloths=[" + flag + "]'", "cloths[0]"}}) {
    const auto out = test_dir() / "out";
    const CliResult r = run_loom("compare " + cape + " --frames 2 --set " + c.set + " --out " + out.string());
    if (r.code == 2 && r.err.find("unknown command") != std::string::npos) GTEST_SKIP();
    if (r.err.find("no loom::characters") != std::string::npos) GTEST_SKIP();
    EXPECT_EQ(r.code, 1) << c.field << ": " << r.err;
    EXPECT_NE(r.err.find("character_cape_reference.json: " + c.field + ": "), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << c.field;
  }
}

}  // namespace loom::test
