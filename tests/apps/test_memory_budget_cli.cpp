// One memory budget for everything loom reads or builds (SceneLimits.h, check_memory): the smallest of
// MemAvailable, what RLIMIT_AS and RLIMIT_DATA leave and LOOM_MEMORY_LIMIT, named in every message that
// gives a memory figure; a character's clip, `loom body` and `loom fabric-test` at its default resolution
// are checked against it before anything is read or written.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "CliRunner.h"

namespace {

namespace fs = std::filesystem;

using loom::test::CliResult;
using loom::test::kAddressSanitizer;
using loom::test::run_loom;
using loom::test::test_dir;

// `loom ARGS` from the test's folder, with `env` (shell words before the command: a ulimit, NAME=VALUE).
CliResult run_with(const std::string& env, const std::string& args) {
  return run_loom(args, "cd " + test_dir().string() + " && " + env);
}

// tests/data/mocap/arm_swing.bvh with its MOTION lines repeated to `frames` frames, as DIR/`name`.
fs::path long_clip(const std::string& name, int frames) {
  std::ifstream in(std::string(LOOM_TEST_DATA) + "/mocap/arm_swing.bvh");
  std::vector<std::string> head, motion;
  std::string line;
  bool in_motion = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (in_motion && line.find_first_not_of(" \t") != std::string::npos) motion.push_back(line);
    if (!in_motion && line.rfind("Frames:", 0) == 0) continue;
    if (!in_motion) head.push_back(line);
    if (line.rfind("Frame Time:", 0) == 0) in_motion = true;
  }
  const fs::path path = test_dir() / name;
  std::ofstream out(path);
  for (size_t k = 0; k + 1 < head.size(); ++k) out << head[k] << "\n";
  out << "Frames: " << frames << "\n" << head.back() << "\n";
  for (int f = 0; f < frames; ++f) out << motion[static_cast<size_t>(f) % motion.size()] << "\n";
  return path;
}

// A clip is counted against the budget from its header before it is parsed: 30000 frames of
// arm_swing.bvh's 96 channels (23 MB of text, about 140 MB when read) under a 100 MB limit are refused by
// `character.bvh`, with the figure and the limit, and no output folder is made.
TEST(MemoryBudget, AClipIsCountedBeforeItIsRead) {
  long_clip("long.bvh", 30000);
  std::ofstream(test_dir() / "scene.json")
      << R"({"name": "m", "quality": "realtime", "duration": 0.02, "fps": 60,
            "character": {"bvh": "long.bvh", "garments": [{"type": "cape", "resolution": 0.1}]}})";
  const CliResult r = run_with("LOOM_MEMORY_LIMIT=100000000 ", "run scene.json --out out");
  if (r.err.find("no loom::characters") != std::string::npos) GTEST_SKIP() << "no loom::characters";
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("character.bvh: the clip (30000 frames of 31 joints and 96 channels) needs about"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("100 MB (set by LOOM_MEMORY_LIMIT) is available"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(test_dir() / "out"));
  // The same clip within a budget that holds it runs.
  const CliResult ok = run_with("LOOM_MEMORY_LIMIT=1000000000 ", "run scene.json --frames 1 --out out");
  EXPECT_EQ(ok.code, 0) << ok.err;
}

// A glTF export holds one morph target per cloth and written frame in its JSON, built in memory as the run
// ends: 40 small cloths over 5000 frames (200 000 targets, about 540 MB) are refused by `output.formats`
// before the run under a 300 MB limit, and no output folder is made; 500 frames (20 000 targets) run.
TEST(MemoryBudget, TheGltfTargetsAreCountedBeforeTheRun) {
  nlohmann::json cloths = nlohmann::json::array();
  for (int k = 0; k < 40; ++k)
    cloths.push_back(
        {{"name", "c" + std::to_string(k)},
         {"mesh",
          {{"type", "grid"}, {"size", {0.1, 0.1}}, {"nodes", {2, 2}}, {"origin", {0.3 * k, 1.0, 0.0}}}},
         {"material", "cotton"}});
  const nlohmann::json scene = {{"name", "many"},
                                {"duration", 5000.0 / 60.0},
                                {"fps", 60},
                                {"gravity", {0, 0, 0}},
                                {"solver", {{"method", "xpbd"}, {"substeps", 1}}},
                                {"cloths", cloths},
                                {"output", {{"frames", false}, {"formats", {"gltf"}}}}};
  std::ofstream(test_dir() / "many.json") << scene.dump();
  const CliResult r = run_with("LOOM_MEMORY_LIMIT=300000000 ", "run many.json --out out");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("many.json: output.formats: \"gltf\" (one morph target per cloth and written frame: "
                       "2e+05) needs about"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("300 MB (set by LOOM_MEMORY_LIMIT) is available"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(test_dir() / "out"));
  const CliResult ok = run_with("LOOM_MEMORY_LIMIT=300000000 ", "run many.json --frames 500 --out out");
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_TRUE(fs::exists(test_dir() / "out" / "animation.gltf"));
}

// The vertex estimate of a generated garment is an upper bound of what is built: a skirt 100 m long with a
// hem ten times its waist (a frustum 2.2 times the area of a cylinder) is estimated at no fewer vertices
// than the run makes.
TEST(MemoryBudget, AFlaredSkirtIsNotUnderestimated) {
  const std::string sets =
      " --set 'character.garments[0].length=100' --set 'character.garments[0].flare=10'"
      " --set 'character.garments[0].resolution=0.2'";
  const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/character_skirt.json";
  const CliResult refused =
      run_with("LOOM_MEMORY_LIMIT=30000000 ", "run " + scene + " --frames 1 --out o" + sets);
  if (refused.err.find("no loom::characters") != std::string::npos) GTEST_SKIP() << "no loom::characters";
  EXPECT_EQ(refused.code, 1) << refused.err;
  const std::string about = "would have about ";
  const size_t at = refused.err.find(about);
  ASSERT_NE(at, std::string::npos) << refused.err;
  const double estimate = std::stod(refused.err.substr(at + about.size()));
  const CliResult ran = run_with("", "run " + scene + " --frames 1 --out o" + sets);
  ASSERT_EQ(ran.code, 0) << ran.err;
  std::ifstream in(test_dir() / "o" / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(in);
  EXPECT_GE(estimate, summary["vertices"].get<double>()) << refused.err;
}

// `loom body` and `loom fabric-test` at its default resolution go through the same check, before a file is
// read or written.
TEST(MemoryBudget, BodyAndDefaultFabricTestAreChecked) {
  const std::string data = LOOM_TEST_DATA;
  const CliResult body = run_with("LOOM_MEMORY_LIMIT=1 ", "body " + data + "/body/human.zae " + data +
                                                              "/mocap/arm_swing.bvh --image img.png");
  if (body.err.find("unknown command") == std::string::npos) {
    EXPECT_EQ(body.code, 1) << body.err;
    EXPECT_NE(body.err.find("CLIP: reading the mesh"), std::string::npos) << body.err;
    EXPECT_NE(body.err.find("1 bytes (set by LOOM_MEMORY_LIMIT) is available"), std::string::npos)
        << body.err;
    EXPECT_FALSE(fs::exists(test_dir() / "img.png"));
  }
  const CliResult drape = run_with("LOOM_MEMORY_LIMIT=1 ", "fabric-test drape --out ft");
  if (drape.err.find("unknown command") == std::string::npos) {
    EXPECT_EQ(drape.code, 1) << drape.err;
    EXPECT_NE(drape.err.find("--resolution: the default 20 may need about"), std::string::npos) << drape.err;
    EXPECT_NE(drape.err.find("(set by LOOM_MEMORY_LIMIT) is available"), std::string::npos) << drape.err;
    EXPECT_FALSE(fs::exists(test_dir() / "ft"));
  }
}

// A LOOM_MEMORY_LIMIT larger than what bounds the run (here a 4 GB `ulimit -v`) is not named as the bound:
// fabric-test and bench accuracy name the bound that gave the figure.
TEST(MemoryBudget, TheMessageNamesTheBoundThatHolds) {
  if (kAddressSanitizer) GTEST_SKIP() << "a ulimit -v stops the sanitizer build before main";
  const std::string env = "ulimit -v 4000000; LOOM_MEMORY_LIMIT=18446744073709551615 ";
  const CliResult ft = run_with(env, "fabric-test shear --resolution 2000 --out ft");
  if (ft.err.find("unknown command") == std::string::npos) {
    EXPECT_EQ(ft.code, 1) << ft.err;
    EXPECT_NE(ft.err.find("--resolution: 2000 may need about"), std::string::npos) << ft.err;
    EXPECT_EQ(ft.err.find("LOOM_MEMORY_LIMIT"), std::string::npos) << ft.err;
    EXPECT_NE(ft.err.find("(left under RLIMIT_AS, ulimit -v) is available"), std::string::npos) << ft.err;
    EXPECT_FALSE(fs::exists(test_dir() / "ft"));
  }
  const CliResult acc = run_with(env, "bench accuracy --quick --sizes 4096 --out acc");
  if (acc.err.find("unknown command") == std::string::npos) {
    EXPECT_EQ(acc.code, 1) << acc.err;
    EXPECT_NE(acc.err.find("--sizes: N=4096"), std::string::npos) << acc.err;
    EXPECT_EQ(acc.err.find("LOOM_MEMORY_LIMIT"), std::string::npos) << acc.err;
    EXPECT_NE(acc.err.find("(left under RLIMIT_AS, ulimit -v) is available"), std::string::npos) << acc.err;
    EXPECT_FALSE(fs::exists(test_dir() / "acc"));
  }
}

// Under `ulimit -v` below the machine's memory, the address space left is the budget: an 8192 x 8192
// --render is refused by its field before the run, naming RLIMIT_AS, instead of failing after it.
TEST(MemoryBudget, TheAddressSpaceLimitBoundsTheBudget) {
  if (kAddressSanitizer) GTEST_SKIP() << "a ulimit -v stops the sanitizer build before main";
  const CliResult r =
      run_with("ulimit -v 2000000; ", "run " + std::string(LOOM_SOURCE_DIR) +
                                          "/scenes/hanging_cloth.json --frames 1 --render --set "
                                          "'output.render={\"width\":8192,\"height\":8192}' --out out");
  if (r.err.find("offscreen renderer") != std::string::npos) GTEST_SKIP() << "no renderer";
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("output.render.width: --render at 8192x8192 px"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(left under RLIMIT_AS, ulimit -v) is available"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(test_dir() / "out"));
}

}  // namespace
