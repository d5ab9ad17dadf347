// The bad-input table of `loom run`, third part: inputs of a second red-team pass (a careful user's and an
// attacker's), each row run through BadInputCli.NonZeroExitNamedMessageNoCompleteOutput
// (test_bad_input_cli.cpp), and the output-folder and checkpoint guarantees they exercised:
//   - every OBJ reader (cloth meshes, garments, collider meshes) is the one strict reader: trailing text on
//     any line is an error naming the file, the line and the token;
//   - a BVH's frame count is checked by the numbers the MOTION section holds, not by its lines;
//   - a refused run leaves its output folder exactly as it found it (no manifest, nothing deleted);
//   - a checkpoint hashes every file the run read, a glTF clip's external buffers included.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "BadInputCli.h"
#include "CliRunner.h"

namespace loom::test {
namespace {

namespace fs = std::filesystem;

const char* kCollider = "colliders=[{\"shape\":\"mesh\",\"obj\":\"mesh.obj\"}]";

const BadInput kRedteamCases[] = {
    // Collider meshes read as strictly as cloth meshes (one OBJ reader).
    {"collider_obj_vertex_trailing_text",
     nullptr,
     {"--set", kCollider},
     "v 0 0 0 junk\nv 1 0 0\nv 0 0 1\nf 1 2 3\n",
     "obj",
     "line 1 ('v 0 0 0 junk')",
     "unexpected 'junk' after the vertex's coordinates"},
    {"collider_obj_face_trailing_text",
     nullptr,
     {"--set", kCollider},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3x\n",
     "obj",
     "line 4 ('f 1 2 3x')",
     "bad vertex index '3x'"},
    {"collider_obj_unknown_directive",
     nullptr,
     {"--set", kCollider},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nbogus 1 2 3\nf 1 2 3\n",
     "obj",
     "line 4",
     "unknown OBJ directive 'bogus'"},
    {"collider_obj_index_past_64_bits",
     nullptr,
     {"--set", kCollider},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 99999999999999999999\n",
     "obj",
     "line 4",
     "bad vertex index '99999999999999999999'"},
    {"collider_obj_hex_coordinate",
     nullptr,
     {"--set", kCollider},
     "v 0 0 0x1p3\nv 1 0 0\nv 0 0 1\nf 1 2 3\n",
     "obj",
     "line 1",
     "'v' needs three numbers (decimal)"},
    // Normals and corners: every token read.
    {"obj_normal_trailing_text",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nvn 0 1 0 junk\nf 1 2 3\n",
     "obj",
     "line 4",
     "unexpected 'junk' after the normal"},
    {"obj_normal_index_trailing_text",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nvn 0 1 0\nf 1//1x 2//1 3//1\n",
     "obj",
     "line 5",
     "bad normal index '1x'"},
    {"obj_normal_index_out_of_range",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nvn 0 1 0\nf 1//1 2//1 3//5\n",
     "obj",
     "line 5",
     "normal index 5 is out of range (1 defined so far)"},
    {"obj_corner_with_four_parts",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nvt 0 0\nvn 0 1 0\nf 1/1/1/1 2/1/1 3/1/1\n",
     "obj",
     "line 6",
     "a corner is v, v/vt, v//vn or v/vt/vn"},
    {"obj_corner_empty_texture",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1/ 2/ 3/\n",
     "obj",
     "line 4",
     "bad texture index ''"},
    {"obj_vertex_index_relative_before_any",
     nullptr,
     {"@OBJ"},
     "f -1 -2 -3\nv 0 0 0\nv 1 0 0\nv 0 0 1\n",
     "obj",
     "line 1",
     "vertex index -1 is out of range (0 defined so far)"},
    {"obj_normal_nan",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nvn nan 1 0\nf 1 2 3\n",
     "obj",
     "line 4",
     "normal is not finite"},
    // BVH: frame counts that are not whole numbers, channel counts no joint has.
    {"bvh_frames_negative",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: -1\nFrame Time: 0.03\n0 90 0 0 0 0\n",
     "motion.bvh",
     "Frames",
     "expected a whole number of frames (got '-1')"},
    {"bvh_channels_past_32_bits",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 4294967302 Xposition Yposition Zposition Zrotation "
     "Xrotation Yrotation\n End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.03\n0 0 0 "
     "0 "
     "0 0\n",
     "motion.bvh",
     "CHANNELS",
     "expected a channel count in [0, 99] (got '4294967302')"},
    {"bvh_frames_past_the_numbers_on_one_line",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: 3\nFrame Time: 0.03\n0 90 0 0 0 0 0 "
     "90 0 "
     "0 0 0\n",
     "motion.bvh",
     "line 14",
     "frame 1 holds 12 numbers, but the joints' CHANNELS add up to 6 (one frame per line)"},
    {"bvh_frames_zero_with_data",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: 0\nFrame Time: 0.03\n0 90 0 0 0 0\n",
     "motion.bvh",
     "Frames",
     "the MOTION section holds no frame (Frames must be >= 1)"},
    {"bvh_joint_name_twice",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n JOINT Hips\n {\n  OFFSET 0 5 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  "
     "{\n"
     "   OFFSET 0 5 0\n  }\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.03\n0 90 0 0 0 0 0 0 0\n",
     "motion.bvh",
     "joint 'Hips'",
     "the name is given twice (joints 0 and 1)"},
    // A garment is as large as the body it is fitted to: a huge character scale is refused by its memory
    // estimate before the garment is made (it was killed by the system out of memory).
    {"garment_on_a_huge_character",
     nullptr,
     {"@BVH:100000", "--set", "character.scale=7", "--set", "character.garments=[{\"type\":\"shirt\"}]"},
     nullptr,
     "scene",
     "character.garments[0].resolution",
     "vertices, which need about"},
};

INSTANTIATE_TEST_SUITE_P(Redteam, BadInputCli, ::testing::ValuesIn(kRedteamCases), bad_input_name);

const char* kScene = R"({
  "duration": 0.05, "fps": 60,
  "solver": {"method": "symplectic_euler", "substeps": 4},
  "cloths": [{"name": "sheet",
              "mesh": {"type": "grid", "size": [1, 1], "nodes": [5, 5]},
              "material": {"preset": "cotton"}, "mass": 0.2,
              "pins": [{"grid": [0, 0]}, {"grid": [-1, 0]}]}],
  "output": {"formats": ["obj", "pc2", "gltf"]}
})";

// Every entry under `dir` (not following links): its relative path, kind and content or link target.
std::map<std::string, std::string> snapshot(const fs::path& dir) {
  std::map<std::string, std::string> m;
  for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator(); ++it) {
    const fs::path rel = fs::relative(it->path(), dir);
    const fs::file_status st = fs::symlink_status(it->path());
    if (fs::is_symlink(st))
      m[rel.string()] = "link to " + fs::read_symlink(it->path()).string();
    else if (fs::is_directory(st))
      m[rel.string()] = "folder";
    else if (!fs::is_regular_file(st))
      m[rel.string()] = "special";  // a FIFO is never opened (reading one without a writer blocks)
    else
      m[rel.string()] = "file " + slurp(it->path());
  }
  return m;
}

// DIR/out made afresh, for a test to plant something at `planted` inside it (the path is cleared, its
// folder made): a foreign folder (the user's notes.txt and `foreign_dir`, if any) or the folder of an
// earlier one-frame run of `scene`. Returns false when that run failed.
bool folder_to_plant_in(const fs::path& out, const std::string& scene, const std::string& planted,
                        bool foreign, const char* foreign_dir = "") {
  fs::remove_all(out);
  if (foreign) {
    fs::create_directories(out / foreign_dir);
    std::ofstream(out / "notes.txt") << "user data";
  } else if (run_loom("run " + scene + " --frames 1 --out " + out.string()).code != 0) {
    return false;
  }
  fs::create_directories((out / planted).parent_path());
  fs::remove_all(out / planted);
  return true;
}

// A link planted at any path the run writes refuses the run before the folder changes: a foreign folder
// (with --overwrite) gets no manifest, and a folder of an earlier run keeps every file of that run.
TEST(RedteamOutputFolder, ARefusedRunLeavesTheFolderExactlyAsItFoundIt) {
  const fs::path dir = test_dir(), victim = dir / "victim.txt";
  std::ofstream(dir / "scene.json") << kScene;
  std::ofstream(victim) << "precious";
  const std::string scene = (dir / "scene.json").string();
  // A folder of an earlier run (one frame) deletes the links its manifest lists (the links themselves) and
  // writes anew, so there the links are planted where that run wrote nothing.
  const std::vector<std::pair<std::string, bool>> cases = {{"frames/frame_00001.obj", true},
                                                           {"summary.json", true},
                                                           {"stats.csv.partial", true},
                                                           {"pc2/sheet.pc2", true},
                                                           {"animation.bin", true},
                                                           {"checkpoint", true},
                                                           {"frames", true},
                                                           {".loom-manifest.tmp", true},
                                                           {".loom-manifest.tmp", false},
                                                           {"frames/frame_00002.obj", false},
                                                           {"checkpoint/checkpoint.bin", false}};
  for (const auto& [planted, foreign] : cases) {
    {
      const fs::path out = dir / "out";
      ASSERT_TRUE(folder_to_plant_in(out, scene, planted, foreign, "frames"));
      fs::create_symlink(victim, out / planted);
      const auto before = snapshot(out);
      const auto r = run_loom("run " + scene + " --checkpoint-every 1 --overwrite --out " + out.string());
      EXPECT_EQ(r.code, 1) << planted << ": " << r.err;
      EXPECT_NE(r.err.find((out / planted).string() + ": --out: is a symbolic link"), std::string::npos)
          << planted << ": " << r.err;
      EXPECT_EQ(snapshot(out), before) << planted << (foreign ? " (foreign folder)" : " (Loom's folder)");
      EXPECT_EQ(slurp(victim), "precious");
    }
  }
}

// A FIFO (or any file that is not a regular one) planted at a path the run writes refuses the run by that
// path before the folder changes: opening a FIFO without a reader to write would block the run forever.
TEST(RedteamOutputFolder, AFifoWhereTheRunWritesIsRefusedNotOpened) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "scene.json") << kScene;
  const std::string scene = (dir / "scene.json").string();
  // In a folder of an earlier run (one frame) the FIFO sits where that run wrote nothing (a listed path is
  // deleted before the run writes).
  const std::vector<std::pair<std::string, bool>> cases = {{"stats.csv.partial", true},
                                                           {"frames/frame_00001.obj", true},
                                                           {"pc2/sheet.obj", true},
                                                           {"checkpoint/checkpoint.bin.tmp", true},
                                                           {"animation.bin", true},
                                                           {"animation.gltf.tmp", true},
                                                           {"summary.json.tmp", true},
                                                           {".loom-manifest.tmp", true},
                                                           {".loom-manifest.tmp", false},
                                                           {"frames/frame_00002.obj", false},
                                                           {"checkpoint/checkpoint.bin", false}};
  for (const auto& [planted, foreign] : cases) {
    {
      const fs::path out = dir / "out";
      ASSERT_TRUE(folder_to_plant_in(out, scene, planted, foreign));
      ASSERT_EQ(::mkfifo((out / planted).c_str(), 0600), 0) << planted;
      const auto before = snapshot(out);
      const auto r = run_loom("run " + scene + " --checkpoint-every 1 --overwrite --out " + out.string());
      EXPECT_EQ(r.code, 1) << planted << ": " << r.err;
      EXPECT_NE(r.err.find((out / planted).string() + ": --out: is not a regular file (a FIFO"),
                std::string::npos)
          << planted << ": " << r.err;
      EXPECT_EQ(snapshot(out), before) << planted << (foreign ? " (foreign folder)" : " (Loom's folder)");
    }
  }
}

// The guard's retries double the substeps; a frame never takes more than 1,000,000 solver steps in all: the
// retry that would pass that is not run and the frame fails naming the cap (the red-team's settings:
// 2^20 retries of a cloth that explodes at every step count).
TEST(RedteamGuard, RetriesStopAtTheStepsAFrameMayTake) {
  const fs::path out = test_dir() / "out";
  const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/hanging_cloth.json";
  const auto r = run_loom("run " + scene + " --out " + out.string() +
                          " --frames 1 --set guard.max_halvings=20 --set cloths[0].material.stretch=1e12"
                          " --set 'cloths[0].mesh.nodes=[3,3]'");
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("above the 1000000 a frame may take (guard.max_halvings)"), std::string::npos)
      << r.err;
  const auto summary = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(summary["frames"], 0);
  EXPECT_EQ(summary["finite"], false);
}

// Ctrl-C stops the frame in progress (the simulation reads the flag between steps): a frame of 1,000,000
// steps is dropped, the run ends as an interrupted run with frame 0 written and a checkpoint to resume.
TEST(RedteamInterrupt, SigintStopsWithinALongFrame) {
  const fs::path out = test_dir() / "out";
  const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/hanging_cloth.json";
  const std::string err = (test_dir() / "sigint_err.txt").string();
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    if (!std::freopen(err.c_str(), "w", stderr) || !std::freopen("/dev/null", "w", stdout)) ::_exit(99);
    ::execl(LOOM_BINARY, LOOM_BINARY, "run", scene.c_str(), "--out", out.c_str(), "--frames", "3", "--set",
            "solver.substeps=1000000", static_cast<char*>(nullptr));
    ::_exit(98);
  }
  // Frame 0 is written before the first long frame starts.
  for (int k = 0; k < 600 && !fs::exists(out / "frames" / "frame_00000.obj"); ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_EQ(::kill(pid, SIGINT), 0);
  int status = 0;
  // Three frames of 1,000,000 steps each take minutes; an interrupted run ends long before this wait ends.
  int waited = 0;
  for (; waited < 600 && ::waitpid(pid, &status, WNOHANG) == 0; ++waited)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  if (waited == 600) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    FAIL() << "the run did not stop on SIGINT";
  }
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130) << slurp(err);
  EXPECT_NE(slurp(err).find("loom: interrupted after frame 0 of 3"), std::string::npos) << slurp(err);
  const auto summary = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(summary["frames"], 0);
  EXPECT_EQ(summary["interrupted"], true);
  EXPECT_EQ(summary["completed"], false);
  EXPECT_TRUE(fs::exists(out / "checkpoint" / "checkpoint.bin"));
}

// A NUL inside a token is text, not its end: "3<NUL>junk" is no index (for cloth and collider meshes alike).
TEST(RedteamObj, ANulInsideATokenIsNotItsEnd) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "scene.json") << kScene;
  const std::string text = std::string("v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3") + '\0' + "junk\n";
  std::ofstream(dir / "nul.obj", std::ios::binary) << text;
  for (const std::string set : {"cloths[0].mesh={\"type\":\"obj\",\"path\":\"nul.obj\"}",
                                "colliders=[{\"shape\":\"mesh\",\"obj\":\"nul.obj\"}]"}) {
    const auto r = run_loom("run " + (dir / "scene.json").string() + " --out " + (dir / "out").string() +
                            " --set 'cloths[0].pins=[]' --set '" + set + "'");
    EXPECT_EQ(r.code, 1) << set << ": " << r.err;
    EXPECT_NE(r.err.find((dir / "nul.obj").string() + ": line 4"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("bad vertex index '3"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("junk'"), std::string::npos) << r.err;
  }
}

// An option that takes a value, given twice: refused by name (exit 2), never "the last one wins", in every
// command; --set is the one option meant to be repeated.
TEST(RedteamCli, AnOptionGivenTwiceIsRefusedByName) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "scene.json") << kScene;
  const std::string scene = (dir / "scene.json").string(), out = (dir / "out").string();
  for (const std::string& args : std::vector<std::string>{
           "run " + scene + " --out " + out + " --out " + out + "2",
           "run " + scene + " --frames 1 --frames 2",
           "run " + scene + " --threads 1 --out " + out + " --threads 2",
           "compare " + scene + " --frames 1 --frames 2",
           "fabric-test cantilever --resolution 5 --resolution 6", "bench accuracy --sizes 4 --sizes 5",
           "bench realtime --seconds 1 --seconds 2", "ccd-eval --scale-exp 1 --scale-exp 2",
           "body m.obj c.bvh --image " + out + "2 --image b.png",
           "body m.obj c.bvh --seconds 1 --seconds 2"}) {
    const auto r = run_loom(args);
    if (r.err.find("unknown command") != std::string::npos) continue;  // a build without the Bullet bridge
    const std::string flag =
        args.substr(args.rfind(" --") + 1, args.find(' ', args.rfind(" --") + 1) - args.rfind(" --") - 1);
    EXPECT_EQ(r.code, 2) << args << ": " << r.err;
    EXPECT_NE(r.err.find(flag + " given twice"), std::string::npos) << args << ": " << r.err;
    EXPECT_FALSE(fs::exists(out + "2")) << args;
  }
  const auto r = run_loom("run " + scene + " --frames 1 --out " + out +
                          " --set cloths[0].mass=0.3 --set cloths[0].mass=0.25");
  EXPECT_EQ(r.code, 0) << r.err;
}

// An input that lies where the run writes (a mesh saved as frames/frame_00001.obj, a scene saved as
// summary.json in the output folder) is refused: even with --overwrite the run never replaces its own input.
TEST(RedteamOutputFolder, AnInputWhereTheRunWritesIsRefused) {
  const fs::path dir = test_dir(), out = dir / "out";
  fs::create_directories(out / "frames");
  const std::string mesh = "v 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0 1\nf 1 2 4\nf 1 4 3\n";
  std::ofstream(out / "frames" / "frame_00001.obj") << mesh;
  nlohmann::json scene = nlohmann::json::parse(kScene);
  scene["cloths"][0]["mesh"] = {{"type", "obj"}, {"path", "out/frames/frame_00001.obj"}};
  scene["cloths"][0]["pins"] = nlohmann::json::array({{{"vertex", 0}}});
  std::ofstream(dir / "scene.json") << scene.dump(1);
  auto r = run_loom("run " + (dir / "scene.json").string() + " --overwrite --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("frame_00001.obj: --out: is an input of this run and a file it writes"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(slurp(out / "frames" / "frame_00001.obj"), mesh);
  EXPECT_FALSE(fs::exists(out / ".loom-manifest"));
  // The scene itself saved as the folder's summary.json.
  std::ofstream(out / "summary.json") << kScene;
  r = run_loom("run " + (out / "summary.json").string() + " --overwrite --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("summary.json: --out: is an input of this run"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(out / "summary.json"), kScene);
}

// An output folder whose path holds a '%' (special in ffmpeg's frame pattern) renders its video.
TEST(RedteamOutputFolder, RenderIntoAFolderWithAPercentInItsPath) {
  if (std::system("command -v ffmpeg >/dev/null 2>&1") != 0) GTEST_SKIP() << "no ffmpeg";
  const fs::path dir = test_dir(), out = dir / "run%d";
  std::ofstream(dir / "scene.json") << kScene;
  const auto r =
      run_loom("run " + (dir / "scene.json").string() + " --frames 2 --render --out '" + out.string() + "'");
  if (r.err.find("built without the offscreen renderer") != std::string::npos) GTEST_SKIP() << r.err;
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out / "render.mp4")) << r.err;
  EXPECT_TRUE(fs::exists(out / "render.gif")) << r.err;
}

// The checkpoint records every file the run read, a glTF clip's external .bin buffers included: a buffer
// changed between the checkpoint and --resume is refused by name.
TEST(RedteamCheckpoint, GltfClipBuffersAreHashedAndAChangedBufferIsRefused) {
  const char* kSimpleSkin = "/usr/share/assimp/models/glTF2/simple_skin/simple_skin.gltf";
  if (!fs::exists(kSimpleSkin)) GTEST_SKIP() << kSimpleSkin << " not installed (assimp-testmodels)";
  const fs::path dir = test_dir();
  std::string text = slurp(kSimpleSkin);
  // The first embedded buffer moved to its own file (its base64 text is what assimp decodes; written back
  // as a data-free file named by a relative uri the clip's folder resolves).
  const std::string prefix = "data:application/gltf-buffer;base64,";
  const size_t at = text.find(prefix), end = text.find('"', at);
  ASSERT_NE(at, std::string::npos);
  const std::string b64 = text.substr(at + prefix.size(), end - at - prefix.size());
  std::string bin;
  int bits = 0;
  unsigned acc = 0;  // the undecoded bits (at most 14 of them), kept small
  const std::string abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  for (char c : b64) {
    if (abc.find(c) == std::string::npos) break;
    acc = ((acc << 6) | static_cast<unsigned>(abc.find(c))) & 0xffffu;
    if ((bits += 6) >= 8) bin.push_back(static_cast<char>((acc >> (bits -= 8)) & 0xff));
  }
  text.replace(at, end - at, "clip.bin");
  std::ofstream(dir / "clip.gltf") << text;
  std::ofstream(dir / "clip.bin", std::ios::binary) << bin;
  nlohmann::json scene = nlohmann::json::parse(kScene);
  scene["duration"] = 0.1;
  scene["character"] = {{"bvh", "clip.gltf"}, {"scale", 1.0}, {"fit_radii", false}};
  std::ofstream(dir / "scene.json") << scene.dump(1);
  const fs::path out = dir / "out";
  const auto r = run_loom("run " + (dir / "scene.json").string() + " --frames 2 --checkpoint-every 1 --out " +
                          out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string checkpoint = slurp(out / "checkpoint" / "checkpoint.bin");
  EXPECT_NE(checkpoint.find((dir / "clip.bin").string()), std::string::npos) << "clip.bin not hashed";
  // The buffer changes (same size, one byte): --resume refuses, naming it.
  bin[bin.size() / 2] ^= 1;
  std::ofstream(dir / "clip.bin", std::ios::binary) << bin;
  const auto resumed = run_loom("run --resume " + out.string());
  EXPECT_EQ(resumed.code, 1) << resumed.err;
  EXPECT_NE(resumed.err.find((dir / "clip.bin").string() + ": --resume: this input changed"),
            std::string::npos)
      << resumed.err;
}

// A cloth that explodes in the first frame (a stretch stiffness of 1e12 N/m) with the proximity
// self-collision: the guard rolls the frame back and retries it, which restores the self-collision stage to
// its state before its first run; the run then stops with the guard's named cause (exit 3), never a crash,
// and writes no NaN. (A contact thickness far larger than the cloth, the other way to fling it in frame 1, is
// refused by the scene: the `*_thickness_*` rows.)
TEST(RedteamGuard, AFirstFrameRetryWithSelfCollisionStopsByTheGuard) {
  const fs::path dir = test_dir(), out = dir / "out";
  const auto r = run_loom("run " + std::string(LOOM_SOURCE_DIR) +
                          "/scenes/hanging_cloth.json --frames 1 --set 'collision={\"method\":\"proximity\"}'"
                          " --set cloths[0].material.stretch=1e12 --set 'cloths[0].mesh.nodes=[9,9]'"
                          " --set guard.max_halvings=2 --out " +
                          out.string());
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("non-finite"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("in frame 1"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("also with 400 substeps"), std::string::npos) << r.err;  // retried twice
  const auto summary = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(summary["frames"], 0);
  EXPECT_EQ(summary["finite"], false);
}

// A field that makes a garment impossible is refused by that field, never by the garment's first bad
// triangle or vertex: a figure under 10 cm (height, scale), a capsule radius or clearance beyond a quarter of
// the figure, a skirt flare outside [0.1, 10], a radius of 0 on a bone the garment hangs from.
TEST(RedteamCharacter, AGarmentFailureNamesTheFieldThatCausedIt) {
  const std::string dir = std::string(LOOM_SOURCE_DIR) + "/scenes/";
  const struct {
    const char* scene;
    const char* set;
    const char* where;
    const char* problem;
  } cases[] = {
      {"character_cape.json", "character.height=5e-324", "character.height", "at least 0.1 m"},
      {"character_cape.json", "character.scale=5e-324", "character.scale", "at least 0.1 m"},
      {"character_cape.json", "character.radii={\"LeftArm\":1e6}", "character.radii.LeftArm",
       "must be <= 0.25 x the figure's size"},
      {"character_cape.json", "character.garments[0].clearance=1e6", "character.garments[0].clearance",
       "must be <= 0.25 x the figure's size"},
      {"character_skirt.json", "character.garments[0].flare=1e308", "character.garments[0].flare",
       "must be in [0.1, 10]"},
      // A radius of 0 removes the capsule a garment hangs from: named by the radii entry, not the clip.
      {"character_cape.json", "character.radii={\"LeftArm\":0}", "character.radii.LeftArm",
       "the cape (character.garments[0]) hangs from the LeftArm capsule, which a radius of 0 removes"},
      {"character_skirt.json", "character.radii={\"RightUpLeg\":0}", "character.radii.RightUpLeg",
       "the skirt (character.garments[0]) hangs from the RightUpLeg capsule, which a radius of 0 removes"},
      {"character_shirt.json", "character.radii={\"RightArm\":0}", "character.radii.RightArm",
       "the shirt (character.garments[0]) hangs from the RightArm capsule, which a radius of 0 removes"},
  };
  for (const auto& c : cases) {
    const fs::path out = test_dir() / "out";
    const auto r =
        run_loom("run " + dir + c.scene + " --frames 1 --set '" + c.set + "' --out " + out.string());
    EXPECT_EQ(r.code, 1) << c.set << ": " << r.err;
    EXPECT_NE(r.err.find(std::string(c.where) + ": "), std::string::npos) << c.set << ": " << r.err;
    EXPECT_NE(r.err.find(c.problem), std::string::npos) << c.set << ": " << r.err;
    EXPECT_FALSE(fs::exists(out / "summary.json")) << c.set;
  }
}

}  // namespace
}  // namespace loom::test
