// `loom` end to end: files and keys of `loom run`, stages present only when the scene needs them, help
// texts, and bad input that exits non-zero without leaving a summary behind.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "CliRunner.h"

namespace {

namespace fs = std::filesystem;

using loom::test::slurp;
using Result = loom::test::CliResult;

Result run(const std::string& args) { return loom::test::run_loom(args); }

fs::path fresh_dir(const std::string& name) {
  const fs::path d = loom::test::test_dir() / name;
  fs::remove_all(d);
  return d;
}

const std::string kScenes = std::string("run ") + LOOM_SOURCE_DIR + "/scenes/";

TEST(Cli, RunHangingClothWritesFramesStatsAndSummary) {
  const fs::path out = fresh_dir("hanging");
  const Result r = run(kScenes + "hanging_cloth.json --frames 10 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  for (int f = 0; f <= 10; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", f);
    EXPECT_TRUE(fs::exists(out / "frames" / name)) << name;
  }
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00011.obj"));
  // stats.csv: a header and one row per frame (0..10).
  std::ifstream csv(out / "stats.csv");
  std::string header, line;
  std::getline(csv, header);
  for (const char* col : {"time", "kinetic_energy", "potential_energy", "elastic_energy", "max_strain",
                          "mean_strain", "ms_solve", "ms_pins", "ms_solve/springs"})
    EXPECT_NE(header.find(col), std::string::npos) << col;
  int rows = 0;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, 11);
  const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  for (const char* key : {"frames", "sim_seconds", "wall_seconds", "ms_per_frame", "stages", "max_strain",
                          "mean_strain", "finite"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["frames"], 10);
  EXPECT_NEAR(j["sim_seconds"].get<double>(), 10.0 / 60.0, 1e-12);
  EXPECT_TRUE(j["finite"].get<bool>());
  EXPECT_GT(j["ms_per_frame"].get<double>(), 0.0);
  EXPECT_TRUE(j["stages"].contains("solve"));
  EXPECT_TRUE(j["stages"].contains("pins"));
  // The hanging cloth has no drag: no drag stage at all.
  for (auto it = j["stages"].begin(); it != j["stages"].end(); ++it)
    EXPECT_EQ(it.key().find("drag"), std::string::npos) << it.key();
  // Positions in the last frame moved down from the start (gravity acted) and are finite numbers.
  const std::string last = slurp(out / "frames" / "frame_00010.obj");
  EXPECT_NE(last.find("o sheet"), std::string::npos);
  EXPECT_EQ(last.find("nan"), std::string::npos);
}

TEST(Cli, FlagSceneHasAnAeroStageAndProfileTable) {
  const fs::path out = fresh_dir("flag");
  const Result r = run(kScenes + "flag_in_wind.json --frames 4 --profile --threads 2 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_TRUE(j["stages"].contains("solve/aero"));
  EXPECT_FALSE(j["stages"].contains("solve/drag"));
  EXPECT_EQ(j["threads"], 2);
  EXPECT_NE(r.out.find("stage"), std::string::npos);
  EXPECT_NE(r.out.find("solve/aero"), std::string::npos);
  EXPECT_NE(r.out.find("ms/frame"), std::string::npos);
  // output.every = 2 in the flag scene.
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_00002.obj"));
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00001.obj"));
}

TEST(Cli, SetOverridesAnySceneValue) {
  const fs::path out = fresh_dir("verlet");
  const Result r = run(
      kScenes + "hanging_cloth.json --frames 2 --set solver.method=verlet --set solver.substeps=120 --out " +
      out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(j["solver"], "verlet");
  EXPECT_EQ(j["substeps"], 120);
}

TEST(Cli, DefaultSceneRunsWithoutArguments) {
  const fs::path out = fresh_dir("default");
  const Result r = run("run --frames 1 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out / "summary.json"));
}

// A scene given by a relative path whose mesh is relative to the scene's folder, run from the repository
// root as the README shows (`loom run scenes/draped_layers.json`): the mesh path is resolved once.
TEST(Cli, RelativeSceneWithARelativeMeshRunsFromTheRepositoryRoot) {
  const fs::path out = fresh_dir("relative_mesh");
  const std::string cmd = std::string("cd ") + LOOM_SOURCE_DIR + " && " + LOOM_BINARY +
                          " run scenes/draped_layers.json --frames 1 --out " + out.string() +
                          " >/dev/null 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0);
  EXPECT_TRUE(fs::exists(out / "summary.json"));
}

TEST(Cli, HelpTextsExplainEveryOption) {
  Result r = run("--help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("loom run"), std::string::npos);
  r = run("run --help");
  EXPECT_EQ(r.code, 0);
  for (const char* opt : {"--out", "--frames", "--threads", "--profile", "--set"})
    EXPECT_NE(r.out.find(opt), std::string::npos) << opt;
}

TEST(Cli, BadInputExitsNonZeroWithAClearMessageAndNoOutput) {
  const fs::path out = fresh_dir("bad");
  const fs::path bad = loom::test::test_dir() / "bad.json";
  std::ofstream(bad) << "{\"duration\": 1, \"cloths\": [{\"mesh\": {\"type\": \"grid\", \"size\": [1, 1], "
                        "\"nodes\": [5, 5]}, \"mass\": -1}]}";
  Result r = run("run " + bad.string() + " --out " + out.string());
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(bad.string() + ": cloths[0].mass: must be > 0"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out / "summary.json"));
  EXPECT_FALSE(fs::exists(out));  // nothing is created before the scene is valid
  r = run("run /nonexistent/scene.json");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("/nonexistent/scene.json: no such file"), std::string::npos) << r.err;
  r = run("run --frames abc");
  EXPECT_EQ(r.code, 2);
  r = run("run --bogus");
  EXPECT_EQ(r.code, 2);
  r = run("fly");
  EXPECT_EQ(r.code, 2);
}

TEST(Cli, UnwritableOutputFolderIsAnError) {
  const Result r = run(kScenes + "hanging_cloth.json --frames 1 --out /proc/loom_cannot_write_here");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("--out"), std::string::npos) << r.err;
}

TEST(Cli, DivergedRunIsReportedNotPassedOffAsWhole) {
  // Far above the explicit stability limit: the state explodes to non-finite values.
  const fs::path out = fresh_dir("diverged");
  const Result r =
      run(kScenes + "hanging_cloth.json --frames 200 --set solver.substeps=1 --out " + out.string());
  EXPECT_EQ(r.code, 3) << r.err;
  // The guard names the cause: non-finite, or an explosion caught before it.
  EXPECT_TRUE(r.err.find("non-finite") != std::string::npos || r.err.find("exploded") != std::string::npos)
      << r.err;
  const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_FALSE(j["finite"].get<bool>());
  EXPECT_TRUE(j.contains("error"));
  EXPECT_LT(j["frames"].get<int>(), 200);
  EXPECT_EQ(slurp(out / "stats.csv").find("nan"), std::string::npos);
}

}  // namespace
