// Hostile clip and mesh files and character timing fields through `loom run` and `loom body`: each is
// refused with exit 1 and a message naming the scene's field (or the command's argument), the file and the
// problem, never a crash or a run that ends non-finite.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "BadInputCli.h"
#include "CliRunner.h"
#include "HostileFiles.h"

namespace loom::test {
namespace {

namespace fs = std::filesystem;

const BadInput kHostileFileCases[] = {
    // The clip's timing, bounded by field (a huge speed or start made the pose non-finite or the garment
    // degenerate, blamed on the garment).
    {"character_speed_past_100",
     nullptr,
     {"@BVH:100000", "--set", "character.speed=1e300"},
     nullptr,
     "scene",
     "character.speed",
     "must be in (0, 100] clip seconds per second"},
    {"character_start_past_1e6",
     nullptr,
     {"@BVH:100000", "--set", "character.start=1e300"},
     nullptr,
     "scene",
     "character.start",
     "must be in [0, 1000000] s"},
    {"character_looped_start_past_the_clip",
     nullptr,
     {"@BVH:100000", "--set", "character.loop=true", "--set", "character.start=1000"},
     nullptr,
     "scene",
     "character.start",
     "is past the clip's end"},
};

INSTANTIATE_TEST_SUITE_P(HostileFiles, BadInputCli, ::testing::ValuesIn(kHostileFileCases), bad_input_name);

// The character_cape scene with its clip (and garments) replaced; returns the scene's path.
std::string cape_scene(const fs::path& dir, const nlohmann::json& character) {
  std::ifstream in(std::string(LOOM_SOURCE_DIR) + "/scenes/character_cape.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["duration"] = 0.05;
  for (auto it = character.begin(); it != character.end(); ++it) scene["character"][it.key()] = it.value();
  const fs::path path = dir / "scene.json";
  std::ofstream(path) << scene.dump(1);
  return path.string();
}

// An input path that is a loop of symbolic links (ELOOP) is refused with the system's reason, never "no such
// file": the scene itself, a cloth mesh, the scene's clip, `loom body`'s clip and mesh, and the checkpoint
// `--resume` reads.
TEST(HostileFilesCli, ALoopOfLinksIsNamedAsOneForEveryInput) {
  const fs::path dir = test_dir();
  const fs::path loop = dir / "loop", back = dir / "loop_back";
  fs::create_symlink(back, loop);
  fs::create_symlink(loop, back);
  const std::string reason = "cannot open it: a loop of symbolic links";
  auto expect_loop = [&](const std::string& args, const std::string& what) {
    const auto r = run_loom(args);
    EXPECT_EQ(r.code, 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(loop.string() + ": " + what + reason), std::string::npos) << args << ": " << r.err;
    EXPECT_EQ(r.err.find("no such file"), std::string::npos) << args << ": " << r.err;
  };
  expect_loop("run " + loop.string() + " --frames 1 --out " + (dir / "o1").string(), "");
  {
    std::ifstream in(std::string(LOOM_SOURCE_DIR) + "/scenes/pillow.json");
    nlohmann::json scene = nlohmann::json::parse(in);
    scene["cloths"][0]["mesh"]["path"] = loop.string();
    std::ofstream(dir / "mesh_loop.json") << scene.dump(1);
    expect_loop("run " + (dir / "mesh_loop.json").string() + " --frames 1 --out " + (dir / "o2").string(),
                "");
  }
  const std::string mesh = std::string(LOOM_TEST_DATA) + "/body/human.zae";
  const auto probe = run_loom("body " + mesh + " " + loop.string() + " --seconds 0.05");
  if (probe.err.find("this build has no loom::characters") == std::string::npos) {
    const std::string scene = cape_scene(dir, {{"bvh", loop.string()}});
    expect_loop("run " + scene + " --frames 1 --out " + (dir / "o3").string(), "cannot read motion: ");
    expect_loop("body " + mesh + " " + loop.string() + " --seconds 0.05", "cannot read motion: ");
    expect_loop("body " + loop.string() + " " + std::string(LOOM_TEST_DATA) + "/mocap/arm_swing.bvh",
                "cannot read the mesh: ");
  }
  // The checkpoint --resume reads.
  const fs::path out = dir / "ck";
  std::ifstream in(std::string(LOOM_SOURCE_DIR) + "/scenes/hanging_cloth.json");
  std::ofstream(dir / "sheet.json") << in.rdbuf();
  ASSERT_EQ(run_loom("run " + (dir / "sheet.json").string() + " --frames 2 --checkpoint-every 1 --out " +
                     out.string())
                .code,
            0);
  const fs::path ck = out / "checkpoint" / "checkpoint.bin";
  ASSERT_TRUE(fs::exists(ck));
  fs::remove(ck);
  fs::create_symlink(loop, ck);
  const auto r = run_loom("run --resume " + out.string() + " --frames 3");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(ck.string() + ": cannot open it: a loop of symbolic links"), std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("no checkpoint here"), std::string::npos) << r.err;
}

// A COLLADA nested 20,000 deep inside a deflated .zae: `loom body` refuses the mesh and the clip by archive,
// entry and line, exit 1.
TEST(HostileFilesCli, DeepNestingInsideAnArchiveIsRefusedByEntryAndLine) {
  const fs::path dir = test_dir();
  const std::string zae = (dir / "deep.zae").string();
  std::ofstream(zae, std::ios::binary) << zip({{"model.dae", deep_collada(20000)}}, 0, true);
  const std::string problem = zae + ": model.dae, line 512: XML elements nest more than 512 levels deep";
  auto r = run_loom("body " + zae + " " + std::string(LOOM_TEST_DATA) + "/mocap/arm_swing.bvh");
  if (r.err.find("this build has no loom::characters") != std::string::npos) GTEST_SKIP() << r.err;
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(problem), std::string::npos) << r.err;
  r = run_loom("body " + std::string(LOOM_TEST_DATA) + "/body/human.zae " + zae + " --seconds 0.05");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(problem), std::string::npos) << r.err;
}

// A clip assimp reads as a mesh scene with null child nodes (RAW), and a COLLADA nested 20,000 deep: both
// refused by the scene's `character.bvh` and by `loom body`'s clip argument, exit 1.
TEST(HostileFilesCli, NonMotionAndDeeplyNestedClipsAreRefusedByField) {
  const fs::path dir = test_dir();
  const std::string raw = (dir / "t.raw").string(), dae = (dir / "deep.dae").string();
  std::ofstream(raw) << "A\n0 0 0 1 0 0 0 1 0\nB\n0 0 0 1 0 0 0 1 0\n";
  std::ofstream(dae) << deep_collada(20000);
  const std::string mesh = std::string(LOOM_TEST_DATA) + "/body/human.zae";
  for (const std::string& clip : {raw, dae}) {
    const std::string scene = cape_scene(dir, {{"bvh", clip}});
    const std::string problem = clip == raw
                                    ? clip + ": cannot read motion: '.raw' is not a motion format"
                                    : clip + ": line 512: XML elements nest more than 512 levels deep";
    auto r = run_loom("run " + scene + " --frames 1 --out " + (dir / "out").string());
    if (r.err.find("this build has no loom::characters") != std::string::npos) GTEST_SKIP() << r.err;
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find(scene + ": character.bvh: " + problem), std::string::npos) << r.err;
    r = run_loom("body " + mesh + " " + clip + " --seconds 0.05");
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find(problem), std::string::npos) << r.err;
  }
  // The body mesh argument, deeply nested: refused the same way.
  const auto r = run_loom("body " + dae + " " + std::string(LOOM_TEST_DATA) + "/mocap/arm_swing.bvh");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(dae + ": line 512: XML elements nest more than 512 levels deep"), std::string::npos)
      << r.err;
}

// Clips whose node graph or nesting assimp would expand or recurse over without bound (an instance_node
// cycle, nodes instancing the next twice 24 times, a glTF node with two parents, FBX nested 100,000 deep)
// and a BVH whose frame lines disagree with its CHANNELS: refused by the scene's `character.bvh` and by
// `loom body`'s clip argument, exit 1, naming the file and the line, node or byte; never a crash.
TEST(HostileFilesCli, ClipNodeGraphsAndNestingAreRefusedBeforeAssimp) {
  const fs::path dir = test_dir();
  std::string bvh;
  {
    std::ifstream in(std::string(LOOM_TEST_DATA) + "/mocap/arm_swing.bvh");
    bvh.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    const std::string three = "CHANNELS 3 Zrotation Yrotation Xrotation";
    bvh.replace(bvh.find(three), three.size(), "CHANNELS 0");  // the frame lines keep their 96 numbers
  }
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"cycle.dae", collada_instances(1, 1, true)}, {"bomb.dae", collada_instances(24, 2)},
      {"dag.gltf", gltf_two_parents(25)},           {"deep.fbx", ascii_fbx(100000)},
      {"deep_binary.fbx", binary_fbx(100000)},      {"channels.bvh", bvh},
  };
  const std::vector<std::string> problems = {
      "line 5: node 'N1': <instance_node url=\"#N0\"> makes an instance_node cycle ('N0' -> 'N1' -> 'N0')",
      "line 29: node 'Hips': with its <instance_node> copies the scene expands to more than 1000000 nodes",
      "nodes[2].children: nodes[3] is already a child of nodes[1]",
      "line 515: FBX scopes ('{') nest more than 512 levels deep",
      "byte 7195: FBX node records nest more than 512 levels deep",
      "line 188: frame 1 holds 96 numbers, but the joints' CHANNELS add up to 93 (one frame per line)",
  };
  const std::string mesh = std::string(LOOM_TEST_DATA) + "/body/human.zae";
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const std::string clip = (dir / cases[k].first).string();
    std::ofstream(clip, std::ios::binary) << cases[k].second;
    const std::string scene = cape_scene(dir, {{"bvh", clip}});
    auto r = run_loom("run " + scene + " --frames 1 --out " + (dir / "out").string());
    if (r.err.find("this build has no loom::characters") != std::string::npos) GTEST_SKIP() << r.err;
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find(scene + ": character.bvh: " + clip + ": " + problems[k]), std::string::npos)
        << r.err;
    r = run_loom("body " + mesh + " " + clip + " --seconds 0.05");
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find(clip + ": " + problems[k]), std::string::npos) << r.err;
  }
}

// An OBJ garment's error names its mesh and attach table, without the hint about the fields a generated
// garment is made from (an OBJ garment has no resolution, length or flare).
TEST(HostileFilesCli, ObjGarmentErrorsGiveNoParametricHint) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "poncho.obj") << "g top\nv 0 1.5 0\nv 0.1 1.5 0\nv 0 1.4 0\nf 1 2 3\n";
  const std::string scene = cape_scene(
      dir, {{"bvh", std::string(LOOM_TEST_DATA) + "/mocap/01_01.bvh"},
            {"garments", {{{"type", "obj"}, {"path", "poncho.obj"}, {"attach", {{"collar", "Neck"}}}}}}});
  const auto r = run_loom("run " + scene + " --frames 1 --out " + (dir / "out").string());
  if (r.err.find("this build has no loom::characters") != std::string::npos) GTEST_SKIP() << r.err;
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("character.garments[0].attach.collar: no group 'collar' in"), std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("resolution"), std::string::npos) << r.err;
}

// An OBJ garment is counted before it is read, like a cloth mesh: its vertices join the scene's estimate,
// and a file whose lines would take more memory to read than there is (here three vertices and 300000
// faces repeating them) is refused by the garment's path, before the folder is made.
TEST(HostileFilesCli, ObjGarmentIsEstimatedBeforeItIsRead) {
  const fs::path dir = test_dir();
  {
    std::ofstream obj(dir / "stuffed.obj");
    obj << "g top\nv 0 1.5 0\nv 0.1 1.5 0\nv 0 1.4 0\n";
    for (int i = 0; i < 300000; ++i) obj << "f 1 2 3\n";
  }
  const std::string scene = cape_scene(
      dir, {{"bvh", std::string(LOOM_TEST_DATA) + "/mocap/01_01.bvh"},
            {"garments", {{{"type", "obj"}, {"path", "stuffed.obj"}, {"attach", {{"top", "Neck"}}}}}}});
  const fs::path out = dir / "out";
  const auto r = run_loom("run " + scene + " --frames 1 --out " + out.string(), "LOOM_MEMORY_LIMIT=50000000");
  if (r.err.find("this build has no loom::characters") != std::string::npos) GTEST_SKIP() << r.err;
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(scene + ": character.garments[0].path: reading its OBJ file (about"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("(set by LOOM_MEMORY_LIMIT) is available"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace loom::test
