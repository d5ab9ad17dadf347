// What `loom run` writes holds only this run's frames, each within what the formats hold:
//   - a resume with fewer frames than the interrupted run deletes the listed frames above its count, keeps
//     the width of the frame names already written (a count that needs more digits is refused naming
//     --frames), and rewrites pc2/<cloth>.obj as frame 0's mesh, as a fresh run does;
//   - a cloth's start `velocity` is bounded when the scene is read; a run whose positions leave the
//     coordinate bound stops as non-finite naming the cloth, before anything of that frame is written;
//   - an export whose file would exceed the documented bound is refused before the run, by field;
//   - bodies.csv quotes a body name holding a comma or a double quote (RFC 4180).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "CliRunner.h"

namespace loom::test {
namespace {

namespace fs = std::filesystem;

const char* kSheet = R"({
  "duration": 0.5, "fps": 60,
  "cloths": [{"name": "sheet",
              "mesh": {"type": "grid", "size": [1, 1], "nodes": [5, 5], "origin": [-0.5, 1, -0.5]},
              "material": {"preset": "cotton"}, "mass": 0.2, "pins": [{"grid": [0, 0]}]}],
  "output": {"formats": ["obj", "pc2"]}
})";

std::string write_text(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
  return p.string();
}

TEST(RunOutputs, ResumeWithFewerFramesDeletesTheLaterFramesAndKeepsFrameZerosMesh) {
  const fs::path dir = test_dir();
  const std::string scene = write_text(dir / "scene.json", kSheet);
  const fs::path fresh = dir / "fresh", cut = dir / "cut";
  ASSERT_EQ(run_loom("run " + scene + " --out " + fresh.string() + " --frames 25").code, 0);
  const CliResult first =
      run_loom("run " + scene + " --out " + cut.string() + " --frames 30 --checkpoint-every 20");
  ASSERT_EQ(first.code, 0) << first.err;
  ASSERT_TRUE(fs::exists(cut / "frames" / "frame_00030.obj"));
  const CliResult resumed = run_loom("run --resume " + cut.string() + " --frames 25");
  ASSERT_EQ(resumed.code, 0) << resumed.err;
  for (int f = 0; f <= 25; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", f);
    EXPECT_EQ(slurp(cut / "frames" / name), slurp(fresh / "frames" / name)) << name;
  }
  for (int f = 26; f <= 30; ++f)
    EXPECT_FALSE(fs::exists(cut / "frames" / ("frame_000" + std::to_string(f) + ".obj"))) << f;
  // pc2/sheet.obj is frame 0's mesh (the checkpoint's positions are frame 20's).
  EXPECT_EQ(slurp(cut / "pc2" / "sheet.obj"), slurp(fresh / "pc2" / "sheet.obj"));
  EXPECT_EQ(slurp(cut / "pc2" / "sheet.pc2"), slurp(fresh / "pc2" / "sheet.pc2"));
  EXPECT_EQ(nlohmann::json::parse(slurp(cut / "summary.json"))["frames"], 25);
}

TEST(RunOutputs, ResumeNeedingWiderFrameNamesIsRefusedNamingFrames) {
  const fs::path dir = test_dir();
  const std::string scene = write_text(dir / "scene.json", kSheet);
  const fs::path out = dir / "out";
  ASSERT_EQ(run_loom("run " + scene + " --out " + out.string() + " --frames 12 --checkpoint-every 5").code,
            0);
  const CliResult r = run_loom("run --resume " + out.string() + " --frames 100000");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("--frames"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("digits"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_00012.obj"));  // refused before any file changed
  EXPECT_EQ(run_loom("run --resume " + out.string() + " --frames 14").code, 0);
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_00014.obj"));
}

TEST(RunOutputs, ClothStartVelocityIsBoundedByField) {
  const fs::path dir = test_dir();
  const std::string scene = write_text(dir / "scene.json", kSheet);
  const CliResult r = run_loom("run " + scene + " --out " + (dir / "out").string() +
                               " --set 'cloths[0].velocity=[0,1e40,0]'");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("cloths[0].velocity"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1000 m/s"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// summary.json's max_strain leaves out frame 0 when a pin starts away from its vertex (the start state holds
// a stretch no solver made: 22.5 here, above guard.max_strain, for a static run that passed the guard at
// every frame), and counts it when every pin starts at its vertex; mean_strain never exceeds max_strain.
TEST(RunOutputs, SummaryMaxStrainCountsFrameZeroOnlyWithPinsAtTheirVertices) {
  const fs::path dir = test_dir();
  const std::string scene = write_text(dir / "scene.json", kSheet);
  const std::string far =
      " --set 'cloths[0].pins=[{\"grid\":[0,0]},{\"grid\":[-1,0],\"anchor\":[4.5,1,-0.5]}]'";
  const std::string out = (dir / "far").string();
  CliResult r = run_loom("run " + scene + " --out " + out + " --frames 2 --set solver.method=static" + far);
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream csv(fs::path(out) / "stats.csv");
  std::string header, row0;
  std::getline(csv, header);
  std::getline(csv, row0);
  std::vector<double> cells;
  std::stringstream cut(row0);
  for (std::string cell; std::getline(cut, cell, ',');) cells.push_back(std::stod(cell));
  ASSERT_GT(cells.size(), 6u);
  EXPECT_GT(cells[5], 10.0) << row0;  // frame 0: the pinned vertex 4 m from its neighbours
  nlohmann::json j = summary_of(out);
  EXPECT_LT(j["max_strain"].get<double>(), 10.0) << j.dump();
  EXPECT_GT(j["max_strain"].get<double>(), 1.0) << j.dump();  // the equilibrium is stretched
  EXPECT_GE(j["max_strain"].get<double>(), j["mean_strain"].get<double>()) << j.dump();
  // Pins at their vertices: frame 0's strain counts (a start with no stretch: 0).
  const std::string at = (dir / "at").string();
  r = run_loom("run " + scene + " --out " + at + " --frames 2 --set solver.method=static");
  ASSERT_EQ(r.code, 0) << r.err;
  j = summary_of(at);
  EXPECT_GE(j["max_strain"].get<double>(), j["mean_strain"].get<double>()) << j.dump();
}

// Gravity and start speed at their bounds carry the sheet past 1e6 m in about 14 s.
TEST(RunOutputs, PositionsBeyondTheCoordinateBoundStopTheRunBeforeTheFrameIsWritten) {
  const fs::path dir = test_dir();
  const std::string scene = write_text(dir / "far.json", R"({
    "duration": 20, "fps": 30, "gravity": [0, -10000, 0],
    "cloths": [{"name": "sheet", "mesh": {"type": "grid", "size": [1, 1], "nodes": [3, 3], "origin": [0, 0, 0]},
                "material": {"preset": "cotton"}, "mass": 0.2, "velocity": [0, -1000, 0]}],
    "output": {"formats": ["obj", "pc2", "gltf"]}})");
  const fs::path out = dir / "out";
  for (const char* guard : {"", " --set guard.enabled=false"}) {
    const CliResult r = run_loom("run " + scene + " --out " + out.string() + " --overwrite" + guard);
    EXPECT_EQ(r.code, 3) << r.err;
    EXPECT_NE(r.err.find("cloth 'sheet' left the coordinate bound"), std::string::npos) << r.err;
    const auto s = nlohmann::json::parse(slurp(out / "summary.json"));
    EXPECT_FALSE(s["finite"].get<bool>());
    EXPECT_FALSE(s["completed"].get<bool>());
    const int frames = s["frames"];
    EXPECT_FALSE(fs::exists(out / "frames" / ("frame_00" + std::to_string(frames + 1) + ".obj")));
    const std::string gltf = slurp(out / "animation.gltf");
    EXPECT_EQ(gltf.find("null"), std::string::npos);
    EXPECT_EQ(gltf.find("e+38"), std::string::npos);
    // Every PC2 float is within the bound.
    const std::string pc2 = slurp(out / "pc2" / "sheet.pc2");
    ASSERT_GT(pc2.size(), 32u);
    for (size_t i = 32; i + 4 <= pc2.size(); i += 4) {
      float v;
      std::memcpy(&v, pc2.data() + i, 4);
      ASSERT_TRUE(std::abs(v) <= 1e6f) << i;
    }
  }
}

// glTF grows linearly with the frames (sparse weights): a large cloth for many frames passes the 2 GiB bound
// and is refused by its figure; more written frames than 32-bit sparse indices address are refused too.
TEST(RunOutputs, AGltfExportAboveTheSizeBoundIsRefusedBeforeTheRun) {
  const fs::path dir = test_dir();
  const std::string scene = write_text(dir / "scene.json", kSheet);
  CliResult r =
      run_loom("run " + scene + " --out " + (dir / "out").string() +
               " --frames 2500 --set 'cloths[0].mesh.nodes=[300,300]' --set 'output.formats=[\"gltf\"]'");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("output.formats"), std::string::npos) << r.err;
  // 2501 x 90000 x 12 bytes of morph targets plus 2501 x 12 of times and sparse weights
  EXPECT_NE(r.err.find("\"gltf\" would take 2.7 GB for 2501 written frames of 90000 vertices"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
  r = run_loom("run " + scene + " --out " + (dir / "out").string() +
               " --frames 100000 --set 'output.formats=[\"gltf\"]'");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("output.formats: \"gltf\" would hold 100001 written frames, above the 65536"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(RunOutputs, BodiesCsvQuotesABodyNameWithACommaOrAQuote) {
  const fs::path out = test_dir() / "out";
  const CliResult r =
      run_loom("run " + std::string(LOOM_SOURCE_DIR) + "/scenes/trampoline.json --frames 2 --out " +
               out.string() + " --set 'bodies[0].name=a,\"b'");
  if (r.err.find("Bullet") != std::string::npos) GTEST_SKIP() << "loom built without the Bullet bridge";
  ASSERT_EQ(r.code, 0) << r.err;
  std::istringstream csv(slurp(out / "bodies.csv"));
  std::string header, row;
  std::getline(csv, header);
  std::getline(csv, row);
  EXPECT_EQ(row.rfind("0,0,\"a,\"\"b\",", 0), 0u) << row;
}

}  // namespace
}  // namespace loom::test
