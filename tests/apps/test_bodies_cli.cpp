// `loom run` with rigid `bodies`: the scene runs in a Bullet world with its cloth as a
// BulletCloth. The trampoline's box falls onto the sheet and bounces back (its height rises again after the
// impact); bodies.csv and the summary's bodies keys are written; without the Bullet bridge the scene is
// refused with an error naming the `bodies` field.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "CliRunner.h"

namespace loom::test {
namespace {

bool have_bullet() { return run_loom("compare").err.find("unknown command") == std::string::npos; }

TEST(BodiesCli, TrampolineBoxBouncesBack) {
  const auto dir = test_dir() / "out";
  const CliResult r =
      run_loom("run " + std::string(LOOM_SOURCE_DIR) +
               "/scenes/trampoline.json --frames 50 --set cloths.0.mesh.nodes=[13,13] --out " + dir.string());
  if (!have_bullet()) {
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("bodies"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("Bullet"), std::string::npos) << r.err;
    return;
  }
  ASSERT_EQ(r.code, 0) << r.err;
  // The box's height per frame, from bodies.csv.
  std::istringstream csv(slurp(dir / "bodies.csv"));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "frame,time,body,x,y,z,vx,vy,vz");
  std::vector<double> y;
  while (std::getline(csv, line)) {
    std::vector<std::string> f;
    std::stringstream ls(line);
    for (std::string c; std::getline(ls, c, ',');) f.push_back(c);
    ASSERT_EQ(f.size(), 9u) << line;
    EXPECT_EQ(f[2], "box");
    EXPECT_EQ(std::stoi(f[0]), static_cast<int>(y.size()));
    y.push_back(std::stod(f[4]));
  }
  ASSERT_EQ(y.size(), 51u);
  const auto low = std::min_element(y.begin(), y.end());
  const double y_low = *low, y_after = *std::max_element(low, y.end());
  EXPECT_LT(y_low, 0.5);            // it fell into the sheet (rest height 0.5 + half size 0.1)
  EXPECT_GT(low - y.begin(), 5);    // ... after falling for a while
  EXPECT_GT(y_after, y_low + 0.3);  // and was thrown back up
  EXPECT_GT(y.front(), y_low + 0.3);
  const nlohmann::json s = nlohmann::json::parse(slurp(dir / "summary.json"));
  EXPECT_EQ(s["frames"], 50);
  EXPECT_TRUE(s["completed"].get<bool>());
  EXPECT_TRUE(s["finite"].get<bool>());
  EXPECT_EQ(s["bodies_file"], "bodies.csv");
  // The whole frame (the Bullet world's own step with it) takes at least the cloth pipeline's time.
  EXPECT_GE(s["wall_ms_per_frame"].get<double>(), s["ms_per_frame"].get<double>());
  ASSERT_EQ(s["bodies"].size(), 1u);
  EXPECT_EQ(s["bodies"][0]["name"], "box");
  EXPECT_NEAR(s["bodies"][0]["position"][1].get<double>(), y.back(), 1e-6);
  EXPECT_EQ(s["bullet_substeps"], 4);
  EXPECT_GE(s["cloth_steps"].get<long>(), 200);   // 50 frames x 4 Bullet substeps, more during the impact
  EXPECT_LT(s["max_strain"].get<double>(), 0.5);  // bounded under the impact
  // The scene's reference tier (no `quality`, implicit Euler): the bridge's setup tier.
  EXPECT_EQ(s["quality"], "reference");
  EXPECT_EQ(s["bullet_tier"], "setup");
  EXPECT_EQ(s["solver"], "implicit_euler");
  EXPECT_TRUE(s["stages"].contains("feature_contact"));
  EXPECT_FALSE(s["stages"].contains("body_coupling"));
  // The usual outputs: stats rows for frames 0..50, OBJ frames.
  std::istringstream stats(slurp(dir / "stats.csv"));
  int rows = 0;
  while (std::getline(stats, line)) ++rows;
  EXPECT_EQ(rows, 52);
  EXPECT_TRUE(std::filesystem::exists(dir / "frames" / "frame_00050.obj"));
}

// `--set quality=...` picks the bridge's tier; an explicit solver the coupled tier cannot run wins (the setup
// tier runs it); a bad tier name is refused naming the field.
TEST(BodiesCli, QualityPicksTheBridgeTier) {
  if (!have_bullet()) GTEST_SKIP() << "loom built without the Bullet bridge";
  const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/trampoline.json";
  auto summary = [&](const std::string& sets, const std::string& sub) {
    const auto dir = test_dir() / sub;
    const CliResult r = run_loom("run " + scene + " --frames 3 --set cloths.0.mesh.nodes=[9,9] " + sets +
                                 " --out " + dir.string());
    EXPECT_EQ(r.code, 0) << sets << ": " << r.err;
    return nlohmann::json::parse(slurp(dir / "summary.json"));
  };
  nlohmann::json s = summary("--set quality=realtime --set 'solver={}'", "realtime");
  EXPECT_EQ(s["quality"], "realtime");
  EXPECT_EQ(s["bullet_tier"], "coupled");
  EXPECT_EQ(s["solver"], "xpbd");
  EXPECT_TRUE(s["stages"].contains("body_coupling"));
  EXPECT_FALSE(s["stages"].contains("feature_contact"));
  s = summary("--set quality=balanced --set 'solver={}'", "balanced");
  EXPECT_EQ(s["bullet_tier"], "coupled");
  EXPECT_TRUE(s["stages"].contains("body_coupling"));
  s = summary("--set quality=realtime", "explicit");  // the scene's explicit implicit_euler wins
  EXPECT_EQ(s["quality"], "realtime");
  EXPECT_EQ(s["bullet_tier"], "setup");
  EXPECT_EQ(s["solver"], "implicit_euler");
  EXPECT_TRUE(s["stages"].contains("feature_contact"));
  const CliResult bad =
      run_loom("run " + scene + " --frames 1 --set quality=fast --out " + (test_dir() / "bad").string());
  EXPECT_EQ(bad.code, 1);
  EXPECT_NE(bad.err.find("trampoline.json: quality"), std::string::npos) << bad.err;
  const CliResult unused = run_loom(
      "run " + scene +
      " --frames 1 --set quality=realtime --set 'solver={\"method\":\"xpbd\",\"compliance_scale\":0.5}' "
      "--out " +
      (test_dir() / "unused").string());
  EXPECT_EQ(unused.code, 1);
  EXPECT_NE(unused.err.find("solver.compliance_scale"), std::string::npos) << unused.err;
}

// In a Bullet world `substeps` is the fewest cloth steps a frame runs (an explicit solver.substeps N gives
// ceil(N / 4) per Bullet substep), `dt` the frame over it, and `cloth_steps` (adaptive steps included) at
// least `substeps` per frame: the three agree, and asking for more steps never reports fewer.
TEST(BodiesCli, SummaryStepsAgreeWithAnExplicitSubsteps) {
  if (!have_bullet()) GTEST_SKIP() << "loom built without the Bullet bridge";
  const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/trampoline.json";
  const int frames = 3;
  int last = 0;
  for (const int n : {1, 4, 8, 13, 40}) {
    const auto dir = test_dir() / ("n" + std::to_string(n));
    const CliResult r =
        run_loom("run " + scene + " --frames " + std::to_string(frames) +
                 " --set cloths.0.mesh.nodes=[9,9] --set quality=realtime --set 'solver={\"substeps\":" +
                 std::to_string(n) + "}' --out " + dir.string());
    ASSERT_EQ(r.code, 0) << n << ": " << r.err;
    const nlohmann::json s = nlohmann::json::parse(slurp(dir / "summary.json"));
    const int per_frame = 4 * std::max(1, (n + 3) / 4);
    EXPECT_EQ(s["substeps"], per_frame) << n;
    EXPECT_DOUBLE_EQ(s["dt"].get<double>(), (1.0 / 60.0) / per_frame) << n;
    EXPECT_GE(s["cloth_steps"].get<long>(), static_cast<long>(per_frame) * frames) << n;
    EXPECT_GE(per_frame, last) << n;
    last = per_frame;
  }
}

TEST(BodiesCli, BodiesWithCollidersOrCheckpointsRefused) {
  if (!have_bullet()) GTEST_SKIP() << "loom built without the Bullet bridge";
  const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/trampoline.json";
  const CliResult cp =
      run_loom("run " + scene + " --frames 2 --checkpoint-every 1 --out " + (test_dir() / "cp").string());
  EXPECT_EQ(cp.code, 1);
  EXPECT_NE(cp.err.find("bodies"), std::string::npos) << cp.err;
  EXPECT_NE(cp.err.find("--checkpoint-every"), std::string::npos) << cp.err;
  const CliResult col = run_loom(
      "run " + scene + " --frames 2 --set 'colliders=[{\"shape\":\"sphere\",\"radius\":0.1}]' --out " +
      (test_dir() / "col").string());
  EXPECT_EQ(col.code, 1);
  EXPECT_NE(col.err.find("colliders"), std::string::npos) << col.err;
  EXPECT_FALSE(std::filesystem::exists(test_dir() / "col" / "summary.json"));
}

TEST(BodiesCli, CharacterWithBodiesRuns) {
  if (!have_bullet()) GTEST_SKIP() << "loom built without the Bullet bridge";
  const std::filesystem::path dir = test_dir() / "cape_crates";
  const CliResult r =
      run_loom("run " + std::string(LOOM_SOURCE_DIR) +
               "/scenes/character_cape_crates.json --frames 30 --census --out " + dir.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json s = nlohmann::json::parse(slurp(dir / "summary.json"));
  EXPECT_TRUE(s["finite"].get<bool>());
  EXPECT_EQ(s["bodies"].size(), 8u);
  EXPECT_LT(s["max_penetration"].get<double>(), 1e-3);  // crates and the character's capsules
  EXPECT_TRUE(s["stages"].contains("character"));
  EXPECT_EQ(s["bullet_tier"], "coupled");  // the scene's "quality": "realtime"
  EXPECT_TRUE(s["stages"].contains("body_coupling"));
  // loom compare has no twin of a character among rigid bodies: refused naming the field.
  const CliResult c = run_loom("compare " + std::string(LOOM_SOURCE_DIR) +
                               "/scenes/character_cape_crates.json --frames 2 --out " +
                               (test_dir() / "cape_compare").string());
  EXPECT_EQ(c.code, 1) << c.err;
  EXPECT_NE(c.err.find("character_cape_crates.json: bodies"), std::string::npos) << c.err;
}

}  // namespace
}  // namespace loom::test
