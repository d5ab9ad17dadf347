// The bad-input table of `loom run`, fourth part. Each class is tested by more than
// its first example:
//   - every positive or non-negative real refuses a non-zero value below 1e-12 (subnormals included) by
//   field;
//   - rigid bodies: mass and sizes inside what Bullet's floats hold; attachments by checked integers, a
//     vertex attached once;
//   - names that become file names are bounded before the run;
//   - coordinates (OBJ vertices, BVH joint positions, keyframe speeds) are refused by their line, channel or
//     keyframe;
//   - the output folder: a listed folder replaced by a link is removed (the link), a hard link where the run
//     writes is refused, inputs are compared by identity;
//   - `loom body --image`, `loom compare`, `loom bench` follow the same rules as `loom run`;
//   - a checkpoint's state is validated as an input.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "BadInputCli.h"
#include "CliRunner.h"

namespace loom::test {
namespace {

namespace fs = std::filesystem;

const std::string kLongName(300, 'a');
const std::string kLongNameSet = "cloths[0].name=" + kLongName;
const std::string kLongColliderSet =
    "colliders=[{\"name\":\"" + kLongName + "\",\"shape\":\"sphere\",\"radius\":0.1}]";

const char* kBody =
    "bodies=[{\"name\":\"b\",\"shape\":\"sphere\",\"radius\":0.1,\"mass\":1,\"position\":[0,3,0]}]";

const BadInput kHostileCases[] = {
    // Subnormal and tiny values of positive reals: one check, by field, for every such field.
    {"material_bend_subnormal",
     nullptr,
     {"--set", "cloths[0].material.bend=1e-310", "--set", "solver={\"method\":\"xpbd\",\"substeps\":4}"},
     nullptr,
     "scene",
     "cloths[0].material.bend",
     "must be 0 or at least 1e-12 (got 1e-310)"},
    // Rotations and the camera: bounded like every angle and position.
    {"body_rotation_degrees_huge",
     nullptr,
     {"--set", kBody, "--set", "bodies[0].rotation={\"axis\":[1,0,0],\"degrees\":1e308}"},
     nullptr,
     "scene",
     "bodies[0].rotation.degrees",
     "must be within +-1000000 degrees (got 1e+308)"},
    // A spin about a far centre: the orbit leaves the coordinate bound, or its surface moves too fast.
    {"collider_spin_centre_far",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"box\",\"half_extents\":[0.2,0.2,0.2],\"position\":[0,1,0],\"motion\":{"
      "\"spin\":{\"axis\":[0,1,0],\"rate\":1,\"centre\":[900000,0,0]}}}]"},
     nullptr,
     "scene",
     "colliders[0].motion.spin.centre",
     "puts the collider's orbit (radius 9000"},
    {"collider_spin_surface_fast",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"box\",\"half_extents\":[0.2,0.2,0.2],\"position\":[0,1,0],\"motion\":{"
      "\"spin\":{\"axis\":[0,1,0],\"rate\":10000,\"centre\":[1000,1,0]}}}]"},
     nullptr,
     "scene",
     "colliders[0].motion.spin.rate",
     "m/s about its centre 1000 m away"},
    {"collider_rotation_degrees_huge",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"box\",\"half_extents\":[0.1,0.1,0.1],\"rotation\":{\"axis\":[0,1,0],"
      "\"degrees\":-1e300}}]"},
     nullptr,
     "scene",
     "colliders[0].rotation.degrees",
     "must be within +-1000000 degrees (got -1e+300)"},
    {"render_camera_eye_far",
     nullptr,
     {"--set", "output.render={\"camera\":{\"eye\":[1e300,1,3],\"target\":[0,1,0]}}"},
     nullptr,
     "scene",
     "output.render.camera.eye",
     "coordinates must be within +-1000000 m"},
    {"wind_drag_subnormal",
     nullptr,
     {"--set", "effects.wind={\"velocity\":[5,0,0],\"drag\":1e-310}"},
     nullptr,
     "scene",
     "effects.wind.drag",
     "must be 0 or at least 1e-12 (got 1e-310)"},
    {"wind_gust_frequency_subnormal",
     nullptr,
     {"--set", "effects.wind={\"velocity\":[5,0,0],\"gusts\":[{\"amplitude\":0.5,\"frequency\":1e-310}]}"},
     nullptr,
     "scene",
     "effects.wind.gusts[0].frequency",
     "must be 0 or at least 1e-12 (got 1e-310)"},
    {"material_stretch_subnormal",
     nullptr,
     {"--set", "cloths[0].material.stretch=1e-310"},
     nullptr,
     "scene",
     "cloths[0].material.stretch",
     "must be at least 1e-12 (got 1e-310)"},
    {"material_shear_tiny",
     nullptr,
     {"--set", "cloths[0].material.shear=1e-300"},
     nullptr,
     "scene",
     "cloths[0].material.shear",
     "must be 0 or at least 1e-12"},
    {"guard_energy_bound_subnormal",
     nullptr,
     {"--set", "guard={\"energy_bound\":4e-320}"},
     nullptr,
     "scene",
     "guard.energy_bound",
     "must be 0 or at least 1e-12"},
    {"collision_friction_subnormal",
     nullptr,
     {"--set", "collision={\"friction\":1e-320}"},
     nullptr,
     "scene",
     "collision.friction",
     "must be 0 or at least 1e-12"},
    // Rigid bodies: Bullet keeps mass and sizes as floats.
    {"body_mass_below_float",
     nullptr,
     {"--set", kBody, "--set", "bodies[0].mass=1e-50"},
     nullptr,
     "scene",
     "bodies[0].mass",
     "must be 0 (static) or in [0.0001, 1000000] kg (got 1e-50)"},
    {"body_mass_above_float",
     nullptr,
     {"--set", kBody, "--set", "bodies[0].mass=1e39"},
     nullptr,
     "scene",
     "bodies[0].mass",
     "must be 0 (static) or in [0.0001, 1000000] kg (got 1e+39)"},
    {"body_radius_tiny",
     nullptr,
     {"--set", kBody, "--set", "bodies[0].radius=1e-50"},
     nullptr,
     "scene",
     "bodies[0].radius",
     "must be in [0.001, 1000000] m (got 1e-50)"},
    {"body_half_extents_tiny",
     nullptr,
     {"--set",
      "bodies=[{\"shape\":\"box\",\"half_extents\":[0.1,1e-300,0.1],\"mass\":1,\"position\":[0,3,0]}]"},
     nullptr,
     "scene",
     "bodies[0].half_extents",
     "all three must be in [0.001, 1000000] m"},
    {"body_capsule_half_height_subnormal",
     nullptr,
     {"--set",
      "bodies=[{\"shape\":\"capsule\",\"radius\":0.1,\"half_height\":1e-310,\"mass\":1,\"position\":[0,3,0]}"
      "]"},
     nullptr,
     "scene",
     "bodies[0].half_height",
     "must be in [0.001, 1000000] m"},
    // Attachments: checked integers, the value and range shown; a vertex held once.
    {"attach_grid_past_32_bits",
     nullptr,
     {"--set",
      "bodies=[{\"shape\":\"box\",\"half_extents\":[0.1,0.1,0.1],\"attach\":[{\"cloth\":0,\"grid\":["
      "4294967297,0]}]}]"},
     nullptr,
     "scene",
     "bodies[0].attach[0].grid",
     "iu 4294967297 is outside the 5x5 grid (iu in [-5, 4])"},
    {"attach_grid_past_64_bits",
     nullptr,
     {"--set",
      "bodies=[{\"shape\":\"box\",\"half_extents\":[0.1,0.1,0.1],\"attach\":[{\"grid\":[0,"
      "18446744073709551615]}]}]"},
     nullptr,
     "scene",
     "bodies[0].attach[0].grid",
     "iv 18446744073709551615 is outside the 5x5 grid"},
    {"attach_same_vertex_twice_in_one_body",
     nullptr,
     {"--set",
      "bodies=[{\"shape\":\"box\",\"half_extents\":[0.1,0.1,0.1],\"attach\":[{\"vertex\":2},{\"grid\":[2,0]}]"
      "}]"},
     nullptr,
     "scene",
     "bodies[0].attach[1]",
     "attaches vertex 2 of cloths[0], which bodies[0].attach[0] attaches already"},
    {"attach_same_vertices_by_two_bodies",
     nullptr,
     {"--set",
      "bodies=[{\"shape\":\"box\",\"half_extents\":[0.1,0.1,0.1],\"attach\":[{\"grid\":[\"all\",2]}]},"
      "{\"shape\":\"box\",\"half_extents\":[0.1,0.1,0.1],\"position\":[2,0,0],\"attach\":[{\"grid\":[2,"
      "\"all\"]}]}]"},
     nullptr,
     "scene",
     "bodies[1].attach[0]",
     "which bodies[0].attach[0] attaches already"},
    // A pinned vertex is held by its pin: attached to a body as well, the two pull it apart.
    {"attach_a_pinned_vertex",
     nullptr,
     {"--set", "bodies=[{\"shape\":\"box\",\"half_extents\":[0.1,0.1,0.1],\"attach\":[{\"grid\":[-1,0]}]}]"},
     nullptr,
     "scene",
     "bodies[0].attach[0]",
     "attaches vertex 4 of cloths[0], which cloths[0].pins[1] pins already"},
    // A garment resolution past a quarter of the figure would be clamped to the smallest grid: refused.
    {"garment_resolution_huge",
     nullptr,
     {"@BVH:100000", "--set", "character.garments=[{\"type\":\"cape\",\"resolution\":1e300}]"},
     nullptr,
     "scene",
     "character.garments[0].resolution",
     "must be <= 0.25 x the figure's size"},
    {"garments_empty",
     nullptr,
     {"@BVH:100000", "--set", "character.garments=[]"},
     nullptr,
     "scene",
     "character.garments",
     "is empty: give at least one garment"},
    // Names that become file names (a cloth's PC2 files) or table cells, bounded before the run.
    {"cloth_name_past_200_bytes",
     nullptr,
     {"--set", kLongNameSet.c_str(), "--set", "output={\"formats\":[\"pc2\"]}"},
     nullptr,
     "scene",
     "cloths[0].name",
     "must be 1 to 200 bytes long (got 300)"},
    {"collider_name_past_200_bytes",
     nullptr,
     {"--set", kLongColliderSet.c_str()},
     nullptr,
     "scene",
     "colliders[0].name",
     "must be 1 to 200 bytes long (got 300)"},
    {"body_name_empty",
     nullptr,
     {"--set", kBody, "--set", "bodies[0].name=\"\""},
     nullptr,
     "scene",
     "bodies[0].name",
     "must be 1 to 200 bytes long (got 0)"},
    // Keyframes that would teleport a collider or a body.
    {"collider_keyframes_teleport",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"sphere\",\"radius\":0.1,\"motion\":{\"keyframes\":[{\"t\":0,\"position\":[0,0,"
      "0]},"
      "{\"t\":1e-300,\"position\":[1,0,0]}]}}]"},
     nullptr,
     "scene",
     "colliders[0].motion.keyframes[1].t",
     "at most 10000 m/s between keyframes"},
    {"weil_drape_past_one_frame_by_option",
     nullptr,
     {"--set", "solver={\"method\":\"weil\"}", "--set", "duration=0.0167", "--frames", "3"},
     nullptr,
     "scene",
     "--frames",
     "is one static shape: at most 1 frame (got 3)"},
    {"collider_keyframes_turn_too_fast",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"box\",\"half_extents\":[0.1,0.1,0.1],\"motion\":{\"keyframes\":[{\"t\":0},"
      "{\"t\":1e-9,\"rotation\":{\"axis\":[1,0,0],\"degrees\":90}}]}}]"},
     nullptr,
     "scene",
     "colliders[0].motion.keyframes[1].rotation",
     "turns 1.57 rad in 1e-09 s after the keyframe before: at most 10000 rad/s"},
    {"body_oscillation_too_fast",
     nullptr,
     {"--set",
      "bodies=[{\"shape\":\"box\",\"half_extents\":[0.1,0.1,0.1],\"motion\":{\"oscillate\":{\"amplitude\":"
      "[1000,0,0],\"frequency\":1000}}}]"},
     nullptr,
     "scene",
     "bodies[0].motion.oscillate.amplitude",
     "moves the body at up to 6.28e+06 m/s: at most 10000 m/s"},
    {"body_keyframes_teleport",
     nullptr,
     {"--set",
      "bodies=[{\"shape\":\"box\",\"half_extents\":[0.1,0.1,0.1],\"motion\":{\"keyframes\":[{\"t\":0,"
      "\"position\":"
      "[0,0,0]},{\"t\":0.5,\"position\":[0,0,0]},{\"t\":0.5000001,\"position\":[0,5,0]}]}}]"},
     nullptr,
     "scene",
     "bodies[0].motion.keyframes[2].t",
     "at most 10000 m/s between keyframes"},
    // OBJ coordinates are checked first, by their line (a huge one read as a zero-area triangle).
    {"obj_faces_folded_onto_each_other",
     nullptr,
     {"@OBJ"},
     "v 0 1 0\nv 0.1 1 0\nv 0 1 0.1\nv 0 1 0\nf 1 2 3\nf 4 2 3\n",
     "obj",
     "line 6 ('f 4 2 3')",
     "lies folded onto line 5 ('f 1 2 3') across edge (vertex 2 (line 2), vertex 3 (line 3)): their vertex 1 "
     "(line 1) and vertex 4 (line 4) are at the same position"},
    {"obj_vertex_past_double_bound",
     nullptr,
     {"@OBJ"},
     "v 1e308 1 0\nv 0.1 1 0\nv 0 1 0.1\nv 0.1 1 0.1\nf 1 2 4\nf 1 4 3\n",
     "obj",
     "line 1",
     "coordinates must be within +-1000000 m"},
    {"obj_vertex_past_bound_among_small_ones",
     nullptr,
     {"@OBJ"},
     "v 0 1 0\nv 0.1 1 0\nv 0 1 0.1\nv 5e6 1 0.1\nf 1 2 4\nf 1 4 3\n",
     "obj",
     "line 4",
     "vertex 4 lies at (5000000, 1, 0.1) m"},
    {"obj_vertex_past_bound_after_scale",
     nullptr,
     {"@OBJ", "--set", "cloths[0].mesh.scale=1000"},
     "v 0 1 0\nv 0.1 1 0\nv 0 1 0.1\nv 2000 1 0.1\nf 1 2 4\nf 1 4 3\n",
     "obj",
     "line 4",
     "after cloths[0].mesh.scale and cloths[0].mesh.translate"},
    {"collider_obj_vertex_past_bound",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"mesh\",\"obj\":\"mesh.obj\"}]"},
     "v 0 0 0\nv 1 0 0\nv 1e308 0 1\nf 1 2 3\n",
     "obj",
     "line 3 (vertex 3)",
     "times the scale, it is beyond +-1000000 m"},
    // A clip whose joints leave the bounds: refused by file, joint channel and frame.
    {"bvh_root_position_huge",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.03\n"
     "0 17 0 0 0 0\n1e30 17 0 0 0 0\n",
     "motion.bvh",
     "joint 'Hips' Xposition",
     "frame 2 places it"},
    {"bvh_root_position_huge_on_z",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.03\n"
     "0 17 -1e29 0 0 0\n0 17 0 0 0 0\n",
     "motion.bvh",
     "joint 'Hips' Zposition",
     "frame 1 places it"},
};

INSTANTIATE_TEST_SUITE_P(Hostile, BadInputCli, ::testing::ValuesIn(kHostileCases), bad_input_name);

const char* kScene = R"({
  "duration": 0.05, "fps": 60,
  "solver": {"method": "symplectic_euler", "substeps": 4},
  "cloths": [{"name": "sheet",
              "mesh": {"type": "grid", "size": [1, 1], "nodes": [5, 5], "origin": [0.25, 1.5, 0.125]},
              "material": {"preset": "cotton"}, "mass": 0.2,
              "pins": [{"grid": [0, 0]}, {"grid": [-1, 0]}]}],
  "output": {"formats": ["obj", "pc2"]}
})";

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A listed folder (frames/) that the user replaced by a link since: the link itself is removed as any
// listed path is, its target is never entered, and the run goes ahead (a refused run would leave the folder
// as it found it; this one is not refused).
TEST(HostileOutputFolder, AListedFolderReplacedByALinkIsRemovedNeverFollowed) {
  const fs::path dir = test_dir(), out = dir / "out", elsewhere = dir / "elsewhere";
  std::ofstream(dir / "scene.json") << kScene;
  const std::string run = "run " + (dir / "scene.json").string() + " --frames 2 --out " + out.string();
  ASSERT_EQ(run_loom(run).code, 0);
  fs::rename(out / "frames", elsewhere);
  fs::create_symlink(elsewhere, out / "frames");
  std::ofstream(elsewhere / "notes.txt") << "precious";
  const std::string before = read_bytes(elsewhere / "frame_00001.obj");
  const auto r = run_loom(run);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::is_directory(fs::symlink_status(out / "frames"))) << "the link was not replaced";
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  EXPECT_TRUE(fs::exists(out / "stats.csv"));
  EXPECT_EQ(read_bytes(elsewhere / "notes.txt"), "precious");
  EXPECT_EQ(read_bytes(elsewhere / "frame_00001.obj"), before) << "a file behind the link was written";
  EXPECT_TRUE(fs::exists(elsewhere / "frame_00002.obj")) << "a file behind the link was deleted";
}

// A file at a path the run writes that shares its data with another name (a hard link to the run's input
// mesh, to a file outside the folder, a frame log hard-linked to a backup) is refused by path before the
// folder changes; the other names keep their bytes.
TEST(HostileOutputFolder, AHardLinkWhereTheRunWritesIsRefused) {
  const fs::path dir = test_dir(), out = dir / "out";
  fs::create_directories(out / "pc2");
  fs::create_directories(dir / "keep");
  const std::string mesh = "v 0 1 0\nv 0.1 1 0\nv 0 1 0.1\nv 0.1 1 0.1\nf 1 2 4\nf 1 4 3\n";
  std::ofstream(dir / "cloth.obj") << mesh;
  std::ofstream(dir / "keep" / "notes.txt") << "precious notes";
  std::ofstream(dir / "scene.json") << R"({"name":"hl","duration":0.05,"fps":60,
    "solver":{"method":"symplectic_euler","substeps":20},
    "cloths":[{"name":"c","mesh":{"type":"obj","path":"cloth.obj"},"material":"cotton",
               "pins":[{"vertex":0}]}],
    "output":{"formats":["obj","pc2"]}})";
  const std::string run = "run " + (dir / "scene.json").string() + " --overwrite --out " + out.string();
  // The run's own input, hard-linked where the run writes pc2/c.obj: refused naming the input.
  fs::create_hard_link(dir / "cloth.obj", out / "pc2" / "c.obj");
  auto r = run_loom(run);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(
      r.err.find((dir / "cloth.obj").string() + ": --out: is an input of this run and the same file as " +
                 (out / "pc2" / "c.obj").string()),
      std::string::npos)
      << r.err;
  EXPECT_EQ(read_bytes(dir / "cloth.obj"), mesh);
  EXPECT_FALSE(fs::exists(out / ".loom-manifest"));
  // A file outside the folder, hard-linked where the run writes pc2/c.pc2: refused naming that path.
  fs::remove(out / "pc2" / "c.obj");
  fs::create_hard_link(dir / "keep" / "notes.txt", out / "pc2" / "c.pc2");
  r = run_loom(run);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(
      r.err.find((out / "pc2" / "c.pc2").string() + ": --out: is a hard link (2 names share this file)"),
      std::string::npos)
      << r.err;
  EXPECT_EQ(read_bytes(dir / "keep" / "notes.txt"), "precious notes");
  EXPECT_FALSE(fs::exists(out / ".loom-manifest"));
  fs::remove(out / "pc2" / "c.pc2");
  ASSERT_EQ(run_loom(run).code, 0);

  // --resume appends to checkpoint/frames.bin: a frame log hard-linked to a backup is refused, unchanged.
  const fs::path out2 = dir / "out2";
  std::ofstream(dir / "sheet.json") << kScene;
  ASSERT_EQ(run_loom("run " + (dir / "sheet.json").string() + " --frames 3 --checkpoint-every 1 --out " +
                     out2.string())
                .code,
            0);
  fs::copy_file(out2 / "checkpoint" / "frames.bin", dir / "backup.bin");
  fs::remove(out2 / "checkpoint" / "frames.bin");
  fs::create_hard_link(dir / "backup.bin", out2 / "checkpoint" / "frames.bin");
  const std::string backup = read_bytes(dir / "backup.bin");
  r = run_loom("run --resume " + out2.string() + " --frames 5");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find((out2 / "checkpoint" / "frames.bin").string() + ": --resume: is a hard link"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(read_bytes(dir / "backup.bin"), backup);
}

// FNV-1a 64 of the checkpoint's bytes before its last 8 (what anyone editing it can recompute).
void resum(std::string& data) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (size_t i = 0; i + 8 < data.size(); ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 0x100000001b3ull;
  }
  std::memcpy(&data[data.size() - 8], &h, 8);
}

// A run of kScene into `out`, 4 frames, checkpointed at frame 2: its exit code.
int checkpointed_run(const fs::path& out) {
  std::ofstream(test_dir() / "scene.json") << kScene;
  return run_loom("run " + (test_dir() / "scene.json").string() + " --frames 4 --checkpoint-every 2 --out " +
                  out.string())
      .code;
}

// A checkpoint whose state was edited and its checksum recomputed is refused by what the state holds: a
// pinned vertex off its pin (1 cm), a position past the scene bound, a non-finite velocity, a clock that is
// not the checkpoint's frame, energies that are not those of stats.csv's row of that frame (written from the
// saved state). The message names the checkpoint file and the quantity.
TEST(HostileCheckpoint, AForgedStateWithARecomputedChecksumIsRefused) {
  const fs::path out = test_dir() / "out";
  ASSERT_EQ(checkpointed_run(out), 0);
  const fs::path ckpt = out / "checkpoint" / "checkpoint.bin";
  const std::string original = read_bytes(ckpt);
  // The state: tag "loom-simulation-state-3", the time, ..., tag "cloth:sheet", then x, v (25 triples each).
  const size_t state_tag = original.find("loom-simulation-state-3");
  const size_t cloth_tag = original.find("cloth:sheet");
  ASSERT_NE(state_tag, std::string::npos);
  ASSERT_NE(cloth_tag, std::string::npos);
  const size_t time_at = state_tag + std::strlen("loom-simulation-state-3");
  const size_t x_at = cloth_tag + std::strlen("cloth:sheet") + 8;
  std::int64_t count = 0;
  std::memcpy(&count, original.data() + x_at - 8, 8);
  ASSERT_EQ(count, 25);
  const size_t v_at = x_at + 25 * 24 + 8;
  struct Forgery {
    size_t at;
    double value;
    bool add;
    const char* field;
    const char* problem;
  };
  const Forgery forgeries[] = {
      {x_at, 0.01, true, "state: cloth 'sheet' vertex 0 position", "is pinned but lies 0.01"},
      {x_at + 12 * 24 + 8, 1e300, false, "state: cloth 'sheet' vertex 12 position", "beyond 1e6 m"},
      {v_at + 7 * 24, std::numeric_limits<double>::quiet_NaN(), false,
       "state: cloth 'sheet' vertex 7 velocity", "is not finite"},
      {time_at, 99.0, false, "state: time", "not the checkpoint's frame 2"},
      // A plausible state (1 mm along x, within every bound) that is not the one the run saved.
      {x_at + 12 * 24, 1e-3, true, "state: elastic_energy", "in the state but"},
  };
  for (const Forgery& f : forgeries) {
    std::string data = original;
    double d;
    std::memcpy(&d, data.data() + f.at, 8);
    d = f.add ? d + f.value : f.value;
    std::memcpy(&data[f.at], &d, 8);
    resum(data);
    std::ofstream(ckpt, std::ios::binary | std::ios::trunc) << data;
    const auto r = run_loom("run --resume " + out.string());
    EXPECT_EQ(r.code, 1) << f.field << ": " << r.err;
    EXPECT_NE(r.err.find(ckpt.string() + ": " + f.field), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(f.problem), std::string::npos) << r.err;
  }
  std::ofstream(ckpt, std::ios::binary | std::ios::trunc) << original;
  const auto r = run_loom("run --resume " + out.string());
  EXPECT_EQ(r.code, 0) << "the untouched checkpoint resumes: " << r.err;
}

// A checkpoint whose header was edited and its checksum recomputed: the run's totals are checked against
// the stats rows they were summed from, and the header must be as Loom writes it (no key twice, no key it
// does not write, its scene among its inputs). Each refusal names the checkpoint and the field or problem.
TEST(HostileCheckpoint, AForgedHeaderWithARecomputedChecksumIsRefused) {
  const fs::path out = test_dir() / "out";
  ASSERT_EQ(checkpointed_run(out), 0);
  const fs::path ckpt = out / "checkpoint" / "checkpoint.bin";
  const std::string original = read_bytes(ckpt);
  // "LOOMCKPT3\n", the header's length (8 bytes), the header, the state's length, the state, the checksum.
  std::uint64_t hn = 0;
  std::memcpy(&hn, original.data() + 10, 8);
  const std::string header = original.substr(18, hn);
  auto with_header = [&](const std::string& h) {
    std::string data = original.substr(0, 10);
    const std::uint64_t n = h.size();
    data.append(reinterpret_cast<const char*>(&n), 8);
    data += h + original.substr(18 + hn);
    resum(data);
    return data;
  };
  auto replace_value = [&](const std::string& key, const std::string& value) {
    const size_t at = header.find("\"" + key + "\":") + key.size() + 3;
    return header.substr(0, at) + value + header.substr(header.find_first_of(",}", at));
  };
  const std::pair<std::string, std::string> forgeries[] = {
      {replace_value("max_strain", "1e+308"), "max_strain: is 1e+308 in the checkpoint but"},
      {replace_value("mean_strain_sum", "-1.0"), "mean_strain_sum: is -1 in the checkpoint but"},
      {replace_value("sim_ms", "1e+300"), "sim_ms: is 1e+300 in the checkpoint but"},
      {"{\"frame\":2," + header.substr(1), "the header is not as Loom writes it"},
      {header.substr(0, header.size() - 1) + ",\"zz\":1}",
       "the header holds a key Loom does not write: 'zz'"},
      {header.substr(0, header.find("\"inputs\":") + 9) + "[]" + header.substr(header.find("}]") + 2),
       "the header's inputs do not list its scene"},
  };
  for (const auto& [h, problem] : forgeries) {
    std::ofstream(ckpt, std::ios::binary | std::ios::trunc) << with_header(h);
    const auto r = run_loom("run --resume " + out.string());
    EXPECT_EQ(r.code, 1) << problem << ": " << r.err;
    EXPECT_NE(r.err.find(ckpt.string() + ": "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(problem), std::string::npos) << r.err;
  }
  std::ofstream(ckpt, std::ios::binary | std::ios::trunc) << with_header(header);
  const auto r = run_loom("run --resume " + out.string());
  EXPECT_EQ(r.code, 0) << "the same header, rewritten, resumes: " << r.err;
}

// `loom body --image` writes by the output rules of `loom run`: never through a link, never over an input,
// never to a device; an empty path is exit 2; the image is whole or absent.
TEST(HostileBody, TheImageFollowsTheOutputRules) {
  const fs::path dir = test_dir();
  const std::string data = LOOM_TEST_DATA;
  fs::copy_file(data + "/body/human.zae", dir / "human.zae");
  const std::string mesh = (dir / "human.zae").string(), clip = data + "/mocap/arm_swing.bvh";
  const std::string body = "body " + mesh + " " + clip + " --seconds 0.05 --image ";
  const std::string input = read_bytes(dir / "human.zae");
  std::ofstream(dir / "outside.txt") << "precious";
  fs::create_symlink(dir / "outside.txt", dir / "link.png");
  auto r = run_loom(body + (dir / "link.png").string());
  if (r.err.find("no renderer") != std::string::npos) GTEST_SKIP() << "no renderer";
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find((dir / "link.png").string() + ": --image: is a symbolic link"), std::string::npos)
      << r.err;
  EXPECT_EQ(read_bytes(dir / "outside.txt"), "precious");
  r = run_loom(body + mesh);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(mesh + ": --image: is the input"), std::string::npos) << r.err;
  EXPECT_EQ(read_bytes(dir / "human.zae"), input);
  r = run_loom(body + "''");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--image: is an empty string"), std::string::npos) << r.err;
  r = run_loom(body + "/dev/full");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("/dev/full: --image: is not a regular file"), std::string::npos) << r.err;
  r = run_loom(body + (dir / "no_such_folder" / "x.png").string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("its folder does not exist"), std::string::npos) << r.err;
  r = run_loom(body + (dir / "cape.png").string());
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(read_bytes(dir / "cape.png").substr(1, 3), "PNG");
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << "left " << e.path();
}

// Scene colliders are not in compare's Bullet world: a scene with them is refused by field before the
// folder (every row was a free fall).
TEST(HostileCompare, SceneCollidersAreRefusedByFieldBeforeTheFolder) {
  const fs::path dir = test_dir(), out = dir / "out";
  const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/sphere_spin.json";
  const auto r = run_loom("compare " + scene + " --frames 2 --out " + out.string());
  if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "no Bullet bridge";
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(scene + ": colliders: loom compare runs the cloth in a Bullet world"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// `loom compare` refuses what its Bullet twins cannot run (a moving pin) by the scene file and the pin's
// field, before the output folder is created.
TEST(HostileCompare, AMovingPinIsRefusedByFieldBeforeTheFolder) {
  const fs::path dir = test_dir(), out = dir / "out";
  const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/buckling_wrinkles.json";
  const auto r = run_loom("compare " + scene + " --frames 2 --out " + out.string());
  if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "no Bullet bridge";
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(scene + ": cloths[0].pins["), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("].path: moves vertex"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

// What the Bullet twins cannot carry (a start velocity, wind, drag, another force model, pressure,
// self-collision, a second cloth) is refused by field before the folder: the rows would otherwise compare
// different problems.
TEST(HostileCompare, ValuesTheTwinsCannotCarryAreRefusedByField) {
  const fs::path out = test_dir() / "out";
  const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/trampoline.json";
  const std::pair<const char*, const char*> cases[] = {
      {"cloths[0].velocity=[0,20,0]", "cloths[0].velocity: is not zero"},
      {"effects={\"wind\":{\"velocity\":[5,0,0]}}", "effects.wind: is set"},
      {"effects={\"drag\":{\"isotropic\":1}}", "effects.drag: is set"},
      {"cloths[0].model=corotated_fem", "cloths[0].model: is 'corotated_fem'"},
      {"collision={\"self\":true}", "collision: is set (self-collision)"},
  };
  for (const auto& [set, expected] : cases) {
    const auto r = run_loom("compare " + scene + " --frames 2 --set '" + set + "' --out " + out.string());
    if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "no Bullet bridge";
    EXPECT_EQ(r.code, 1) << set << ": " << r.err;
    EXPECT_NE(r.err.find(scene + ": " + expected), std::string::npos) << set << ": " << r.err;
    EXPECT_NE(r.err.find("Bullet twins cannot carry it"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << set;
  }
}

// An OBJ's memory is estimated from its `v` and `f` lines before it is parsed: a collider mesh (counted
// per triangle), a cloth mesh (per vertex) and a file whose reading alone passes the budget are refused by
// field, before the folder.
TEST(HostileMemory, ObjMeshesAreEstimatedBeforeTheyAreParsed) {
  const fs::path dir = test_dir(), out = dir / "out";
  {
    std::ofstream obj(dir / "big.obj");
    const int n = 200;  // 40000 vertices, 79202 triangles as quads
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) obj << "v " << i * 0.01 << " 0 " << j * 0.01 << "\n";
    for (int i = 0; i + 1 < n; ++i)
      for (int j = 0; j + 1 < n; ++j)
        obj << "f " << i * n + j + 1 << ' ' << (i + 1) * n + j + 1 << ' ' << (i + 1) * n + j + 2 << ' '
            << i * n + j + 2 << "\n";
  }
  auto run = [&](const std::string& set) {
    const std::string cmd = "cd " + dir.string() + " && LOOM_MEMORY_LIMIT=50000000 " +
                            std::string(LOOM_BINARY) + " run " + std::string(LOOM_SOURCE_DIR) +
                            "/scenes/hanging_cloth.json --frames 1 --set '" + set + "' --out " +
                            out.string() + " 2>" + (dir / "err.txt").string() + " >/dev/null";
    const int status = std::system(cmd.c_str());
    return std::make_pair(WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(dir / "err.txt"));
  };
  const std::string obj = (dir / "big.obj").string();
  auto [code, err] = run("colliders=[{\"shape\":\"mesh\",\"obj\":\"" + obj + "\",\"position\":[0,-1,0]}]");
  EXPECT_EQ(code, 1) << err;
  EXPECT_NE(err.find("colliders[0].obj: the scene's collider meshes would have about 7.92e+04 triangles"),
            std::string::npos)
      << err;
  EXPECT_FALSE(fs::exists(out));
  std::tie(code, err) = run("cloths[0].mesh={\"type\":\"obj\",\"path\":\"" + obj + "\"}");
  EXPECT_EQ(code, 1) << err;
  EXPECT_NE(err.find("cloths[0].mesh: the scene's cloths would have about 4e+04 vertices"), std::string::npos)
      << err;
  EXPECT_FALSE(fs::exists(out));
  // Three vertices and 300000 faces that repeat them: few vertices, but reading the faces needs the memory.
  {
    std::ofstream obj(dir / "stuffed.obj");
    obj << "v 0 0 0\nv 1 0 0\nv 0 0 1\n";
    for (int i = 0; i < 300000; ++i) obj << "f 1 2 3\n";
  }
  std::tie(code, err) =
      run("cloths[0].mesh={\"type\":\"obj\",\"path\":\"" + (dir / "stuffed.obj").string() + "\"}");
  EXPECT_EQ(code, 1) << err;
  EXPECT_NE(err.find("cloths[0].mesh.path: reading its OBJ file (about"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out));
}

// `loom bench accuracy --sizes N` estimates its memory before allocating: refused by the option, with the
// figure, before the output folder.
TEST(HostileBench, AccuracySizesAreEstimatedBeforeAllocating) {
  const fs::path out = test_dir() / "out";
  const std::string cmd = "LOOM_MEMORY_LIMIT=1000000000 " + std::string(LOOM_BINARY) +
                          " bench accuracy --quick --sizes 8,1024 --out " + out.string() + " 2>" +
                          (test_dir() / "err.txt").string() + " >/dev/null";
  const int status = std::system(cmd.c_str());
  const std::string err = slurp(test_dir() / "err.txt");
  if (err.find("unknown command") != std::string::npos) GTEST_SKIP() << "no Bullet bridge";
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << err;
  EXPECT_NE(err.find("--sizes: N=1024 (1048576 vertices"), std::string::npos) << err;
  EXPECT_NE(err.find("1 GB (set by LOOM_MEMORY_LIMIT) is available"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out)) << "the folder was claimed before the estimate";
}

// A one-frame --render of the hanging sheet at size x size under LOOM_MEMORY_LIMIT=`limit`: its exit code
// and stderr; `skipped` when this build or machine cannot render.
struct RenderRefusal {
  int code = -1;
  std::string err;
  bool skipped = false;
};
RenderRefusal render_under_limit(const std::string& limit, int size, const fs::path& out) {
  const std::string cmd = "LOOM_MEMORY_LIMIT=" + limit + " " + std::string(LOOM_BINARY) + " run " +
                          std::string(LOOM_SOURCE_DIR) + "/scenes/hanging_cloth.json --frames 1 --render " +
                          "--set 'output.render={\"width\":" + std::to_string(size) +
                          ",\"height\":" + std::to_string(size) + "}' --out " + out.string() + " 2>" +
                          (test_dir() / "err.txt").string() + " >/dev/null";
  const int status = std::system(cmd.c_str());
  RenderRefusal r;
  r.err = slurp(test_dir() / "err.txt");
  r.skipped = r.err.find("offscreen renderer") != std::string::npos ||
              r.err.find("ffmpeg not found") != std::string::npos;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// --render estimates the recording and the supersampled images before the run: a size the memory cannot
// hold is refused by field, with the figure, before the output folder (not after the simulation).
TEST(HostileRender, ImageSizeIsEstimatedBeforeTheRun) {
  const fs::path out = test_dir() / "out";
  const RenderRefusal r = render_under_limit("1000000000", 8192, out);
  if (r.skipped) GTEST_SKIP() << "no renderer";
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("output.render.width: --render at 8192x8192 px"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("set by LOOM_MEMORY_LIMIT"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out)) << "the folder was claimed before the estimate";
}

// The video is encoded after the run by ffmpeg, a process of its own: its memory at the image size is
// checked before the run too, so a size Loom's own drawing fits but the encoder does not is refused by
// field before the folder is made (not found by a failed encoding after the simulation).
TEST(HostileRender, TheEncodersMemoryIsEstimatedBeforeTheRun) {
  const fs::path out = test_dir() / "out";
  const RenderRefusal r = render_under_limit("600000000", 2048, out);
  if (r.skipped) GTEST_SKIP() << "no renderer";
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("output.render.width: ffmpeg's encoding of 2048x2048 px frames with"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("set by LOOM_MEMORY_LIMIT"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out)) << "the folder was claimed before the estimate";
}

// Bytes that are not UTF-8, quoted from an input (a JSON parser's "last read"), reach the terminal as \xNN,
// never raw: a terminal would take them for part of a character.
TEST(HostileText, BytesThatAreNotUtf8AreShownEscaped) {
  const fs::path dir = test_dir(), out = dir / "out";
  const fs::path bad = dir / "bad.json";
  std::ofstream(bad, std::ios::binary) << "{\"name\": \"a\xff\"";
  const auto r = run_loom("run " + bad.string() + " --out " + out.string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("invalid JSON"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("a\\xff"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\xff'), std::string::npos) << "a raw byte reached the terminal";
}

// An empty LOOM_SCENES (an unset shell variable exported) is unset: `loom run` never reads the working
// directory's character_layers.json.
TEST(HostileEnv, AnEmptyScenesVariableIsUnset) {
  const fs::path dir = test_dir(), out = dir / "out";
  std::ofstream(dir / "character_layers.json") << "{\"decoy\": true}";
  const std::string cmd = "cd " + dir.string() + " && LOOM_SCENES= " + std::string(LOOM_BINARY) +
                          " run --frames 1 --out " + out.string() + " 2>" + (dir / "err.txt").string() +
                          " >/dev/null";
  const int status = std::system(cmd.c_str());
  const std::string err = slurp(dir / "err.txt");
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << err;
  EXPECT_EQ(err.find("decoy"), std::string::npos) << err;
  const auto summary = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_NE(summary["scene"].get<std::string>(), (dir / "character_layers.json").string());
}

// The scenes `bench realtime` reads from LOOM_SCENES must hold what each benchmark runs: a character
// scene without a character, a toy box without bodies, or either with scene colliders (which the Bullet
// twins do not see) is refused by file and field before the output folder is made (no signal).
TEST(HostileEnv, BenchRealtimeScenesMustHoldWhatTheyBenchmark) {
  const fs::path dir = test_dir(), scenes = dir / "scenes", out = dir / "out";
  fs::create_directories(scenes);
  const std::string sheet =
      R"({"name": "s", "duration": 0.1, "cloths": [{"name": "c", "mesh": {"type": "grid", "size": [0.3, 0.3], )"
      R"("nodes": [5, 5]}, "material": "cotton"}])";
  struct Case {
    std::string bench, file, text, field;
  };
  for (const Case& c :
       {Case{"character", "character_layers_reference.json", sheet + "}", "character"},
        Case{"toy_box", "toy_box.json", sheet + "}", "bodies"},
        Case{"toy_box", "toy_box.json",
             sheet + R"(, "bodies": [{"name": "b", "shape": "sphere", "radius": 0.05, "mass": 0.2, )"
                     R"("position": [0, 1, 0]}], "colliders": [{"name": "k", "shape": "sphere", )"
                     R"("radius": 0.1, "position": [0, -1, 0]}]})",
             "colliders"}}) {
    std::ofstream(scenes / c.file) << c.text;
    const auto r = run_loom("bench realtime --quick --scenes " + c.bench + " --out " + out.string(),
                            "LOOM_SCENES=" + scenes.string() + " ");
    if (r.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "no bench realtime in this build";
    EXPECT_EQ(r.code, 1) << c.bench << " " << c.field << ": " << r.err;
    EXPECT_NE(r.err.find(c.file + ": " + c.field + ": "), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << c.field;
  }
}

// --render makes its video after the whole run: a frame rate the encoders cannot take (fps, or fps /
// output.render.every, below 1 Hz) and a missing ffmpeg are refused before the run, by field, and the
// output folder is never made.
TEST(HostileRender, AVideoThatCannotBeMadeIsRefusedBeforeTheRun) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "scene.json") << kScene;
  const std::string scene = (dir / "scene.json").string();
  for (const std::string& set : {std::string("--set fps=0.5 --set duration=10"),
                                 std::string("--set 'output.render={\"every\":100}'")}) {
    const fs::path out = dir / "slow";
    const auto r = run_loom("run " + scene + " --render " + set + " --out " + out.string());
    if (r.err.find("built without the offscreen renderer") != std::string::npos) GTEST_SKIP() << r.err;
    EXPECT_EQ(r.code, 1) << set << ": " << r.err;
    EXPECT_NE(r.err.find(scene + ": fps: with --render"), std::string::npos) << set << ": " << r.err;
    EXPECT_NE(r.err.find("must be in [1, 1000]"), std::string::npos) << set << ": " << r.err;
    EXPECT_FALSE(fs::exists(out)) << set;
  }
  const char* path = std::getenv("PATH");
  const std::string saved = path ? path : "";
  ::setenv("PATH", "/nonexistent", 1);  // std::system runs /bin/sh by its absolute path
  const auto r = run_loom("run " + scene + " --render --out " + (dir / "no_ffmpeg").string());
  ::setenv("PATH", saved.c_str(), 1);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("ffmpeg: --render: ffmpeg not found"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "no_ffmpeg"));
}

// ffmpeg failing after the run (a stand-in on PATH that exits 1): the simulation's outputs are written whole
// (stats.csv, summary.json with the failure under render.video, no partial video, no .partial file), the
// run exits 1 naming the failure and how to render again, and --resume with a working ffmpeg renders it.
TEST(HostileRender, AFailedEncodingKeepsTheRunsOutputsAndResumes) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "scene.json") << kScene;
  const fs::path bin = dir / "bin";
  fs::create_directories(bin);
  std::ofstream(bin / "ffmpeg") << "#!/bin/sh\necho broken encoder >&2\nexit 1\n";
  fs::permissions(bin / "ffmpeg", fs::perms::owner_all);
  const fs::path out = dir / "out";
  const std::string saved = std::getenv("PATH") ? std::getenv("PATH") : "";
  ::setenv("PATH", (bin.string() + ":" + saved).c_str(), 1);
  const auto r = run_loom("run " + (dir / "scene.json").string() + " --render --out " + out.string());
  ::setenv("PATH", saved.c_str(), 1);
  if (r.err.find("built without the offscreen renderer") != std::string::npos) GTEST_SKIP() << r.err;
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("ffmpeg failed (exit 1): broken encoder"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("render again with: loom run --resume " + out.string()), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(out / "stats.csv"));
  EXPECT_FALSE(fs::exists(out / "render.mp4"));
  for (const auto& e : fs::recursive_directory_iterator(out))
    EXPECT_EQ(e.path().string().find(".partial"), std::string::npos) << e.path();
  const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(j["completed"], true);
  EXPECT_NE(j["render"]["video"].get<std::string>().find("failed: "), std::string::npos) << j.dump(1);
  const auto again = run_loom("run --resume " + out.string());
  if (again.err.find("ffmpeg not found") != std::string::npos) GTEST_SKIP() << again.err;
  EXPECT_EQ(again.code, 0) << again.err;
  EXPECT_TRUE(fs::exists(out / "render.mp4"));
}

// loom killed by a signal while ffmpeg makes the video: ffmpeg dies with it (it runs with a death signal),
// and the private folder ffmpeg wrote in is listed in the manifest, so the next run into the folder deletes
// it. A stand-in ffmpeg on PATH writes its output (a partial video) and records its pid, then waits; the
// test kills loom then.
TEST(HostileRender, AKilledRunLeavesNoFfmpegRunningAndTheNextRunRemovesItsFolder) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "scene.json") << kScene;
  const fs::path bin = dir / "bin", marker = dir / "ffmpeg.pid";
  fs::create_directories(bin);
  std::ofstream(bin / "ffmpeg") << "#!/bin/sh\n"
                                   "for a in \"$@\"; do last=\"$a\"; done\n"
                                   ": > \"$last\"\n"  // a partial video, as a real ffmpeg leaves one
                                   "echo $$ > " +
                                       marker.string() +
                                       ".tmp\n"
                                       "mv " +
                                       marker.string() + ".tmp " + marker.string() +
                                       "\n"
                                       "exec sleep 600\n";
  fs::permissions(bin / "ffmpeg", fs::perms::owner_all);
  const fs::path out = dir / "out";
  const std::string saved = std::getenv("PATH") ? std::getenv("PATH") : "";
  ::setenv("PATH", (bin.string() + ":" + saved).c_str(), 1);
  const pid_t loom = ::fork();
  if (loom == 0) {
    const int err = ::open((dir / "err.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    ::dup2(err, 2);
    ::execl(LOOM_BINARY, "loom", "run", (dir / "scene.json").c_str(), "--render", "--out", out.c_str(),
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::setenv("PATH", saved.c_str(), 1);
  ASSERT_GT(loom, 0);
  int status = 0;
  bool exited = false;
  for (int i = 0; i < 6000 && !fs::exists(marker); ++i) {  // up to 60 s: the run, its frames, then ffmpeg
    if (::waitpid(loom, &status, WNOHANG) == loom) {
      exited = true;
      break;
    }
    ::usleep(10000);
  }
  if (exited && slurp(dir / "err.txt").find("built without the offscreen renderer") != std::string::npos)
    GTEST_SKIP() << "loom built without the renderer";
  ASSERT_FALSE(exited) << "loom ended before ffmpeg ran: " << slurp(dir / "err.txt");
  ASSERT_TRUE(fs::exists(marker));
  const pid_t ffmpeg = std::stoi(slurp(marker));
  ASSERT_EQ(::kill(ffmpeg, 0), 0) << "the stand-in ffmpeg is running";
  ::kill(loom, SIGKILL);
  ::waitpid(loom, &status, 0);
  bool gone = false;  // dead: no such process, or a zombie waiting for its new parent to reap it
  for (int i = 0; i < 500 && !gone; ++i) {
    std::ifstream st("/proc/" + std::to_string(ffmpeg) + "/stat");
    std::string pid, comm, state;
    gone = !(st >> pid >> comm >> state) || state == "Z";
    if (!gone) ::usleep(10000);
  }
  EXPECT_TRUE(gone) << "ffmpeg " << ffmpeg << " outlived the killed loom";
  std::vector<fs::path> staging;
  for (const auto& e : fs::directory_iterator(out))
    if (e.path().filename().string().rfind(".loom-helper-", 0) == 0) staging.push_back(e.path());
  ASSERT_EQ(staging.size(), 1u);
  const std::string manifest = slurp(out / ".loom-manifest");
  const std::string name = staging[0].filename().string();
  EXPECT_NE(manifest.find("\n" + name + "/\n"), std::string::npos) << manifest;
  EXPECT_NE(manifest.find("\n" + name + "/render.mp4\n"), std::string::npos) << manifest;
  // The next run into the folder deletes what the killed one listed, the private folder included.
  const auto r = run_loom("run " + (dir / "scene.json").string() + " --frames 1 --out " + out.string());
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(fs::exists(staging[0])) << name;
}

// Paths and names reach gnuplot and ffmpeg as text, never as commands: an output folder whose name holds
// quotes, a ';', `$(...)` and backquotes gets its plot and video, and nothing the name spells is run.
TEST(HostileHelpers, AnOutputPathThatSpellsCommandsIsNeverRun) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "scene.json") << kScene;
  const std::string name = "q'x;touch PWNED;'$(touch PWNED2)`touch PWNED3`\"; set output 'x";
  const fs::path fabric = dir / ("fabric " + name), video = dir / ("video " + name);
  auto quoted = [](const fs::path& p) {  // for the test's own shell only
    std::string q = "'";
    for (char c : p.string()) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
  };
  const auto f = run_loom("fabric-test tensile --out " + quoted(fabric));
  EXPECT_EQ(f.code, 0) << f.err;
  const std::string report = slurp(fabric / "report.md");
  if (std::system("command -v gnuplot >/dev/null 2>&1") == 0) {
    EXPECT_NE(report.find("![plot](plot.png)"), std::string::npos) << report;
    EXPECT_TRUE(fs::is_regular_file(fabric / "plot.png"));
  }
  const auto r = run_loom("run " + (dir / "scene.json").string() + " --render --out " + quoted(video));
  if (r.err.find("built without the offscreen renderer") == std::string::npos) {
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::is_regular_file(video / "render.mp4")) << r.err;
    EXPECT_TRUE(fs::is_regular_file(video / "render.gif")) << r.err;
  }
  for (const fs::path& d : {fs::current_path(), dir, fabric, video})
    for (const char* p : {"PWNED", "PWNED2", "PWNED3", "x"}) EXPECT_FALSE(fs::exists(d / p)) << d / p;
  for (const fs::path& d : {fabric, video})  // no private folder is left
    for (const auto& e : fs::directory_iterator(d))
      EXPECT_NE(e.path().filename().string().rfind(".loom-helper-", 0), 0u) << e.path();
}

// A scene without "name" is named after its file; that name follows the rules of scene text: a file name
// holding a newline or a bidi override is refused by `name`, and no folder is made.
TEST(HostileNames, ANameTakenFromTheFileNameHoldsNoControlCharacter) {
  const fs::path dir = test_dir();
  for (const std::string& file : {std::string("nl\nname.json"), std::string("bidi\u202Egnp.json")}) {
    nlohmann::json j = nlohmann::json::parse(kScene);
    std::ofstream(dir / file) << j.dump();
    const auto r = run_loom("run '" + (dir / file).string() + "' --frames 1");
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find("name: is not given, and the scene's file name holds a control character"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(fs::path("out") / file.substr(0, file.size() - 5)));
  }
}

// A scene path through a link and then ".." names the file the system opens (the link's target's parent),
// not the one a lexical clean-up would name: summary.json records it and --resume finds it.
TEST(HostilePaths, AScenePathThroughALinkThenDotDotNamesTheFileOpened) {
  const fs::path dir = test_dir();
  fs::create_directories(dir / "deep" / "sub");
  fs::create_directory_symlink(dir / "deep" / "sub", dir / "lk");
  std::ofstream(dir / "deep" / "x.json") << kScene;
  std::ofstream(dir / "x.json") << "{\"decoy\": true}";  // what lexical normalisation would name
  const fs::path out = dir / "out";
  const auto r = run_loom("run " + (dir / "lk" / ".." / "x.json").string() +
                          " --frames 2 --checkpoint-every 1 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_EQ(j["scene"].get<std::string>(), fs::canonical(dir / "deep" / "x.json").string());
  const auto resumed = run_loom("run --resume " + out.string() + " --frames 3");
  EXPECT_EQ(resumed.code, 0) << resumed.err;
}

// A message names its input whole: a NUL inside an OBJ line is shown as \x00, not the end of the message;
// a loop of links is named as one, not as a missing file.
TEST(HostilePaths, MessagesShowNulsAndNameLinkLoops) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "mesh.obj") << std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\nx\0yz 1\nf 1 2 3\n", 39);
  std::ofstream(dir / "scene.json")
      << R"({"name":"nul","duration":0.05,"fps":60,"cloths":[{"name":"c","mesh":{"type":"obj","path":"mesh.obj"},"material":{"preset":"cotton"},"mass":0.1}]})";
  const auto r = run_loom("run " + (dir / "scene.json").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("unknown OBJ directive 'x\\x00yz'"), std::string::npos) << r.err;
  fs::create_symlink(dir / "loop_b", dir / "loop_a");
  fs::create_symlink(dir / "loop_a", dir / "loop_b");
  const auto loop = run_loom("run " + (dir / "loop_a").string());
  EXPECT_EQ(loop.code, 1) << loop.err;
  EXPECT_NE(loop.err.find("loop_a: cannot open it: a loop of symbolic links"), std::string::npos) << loop.err;
}

// A scene file of NUL bytes (or one in the middle) is binary data, named with its line and column; the
// parser's "unexpected end of input" would blame the file's first character.
TEST(HostilePaths, NulBytesInASceneFileAreNamedAsBinaryData) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "zeros.json") << std::string(4096, '\0');
  std::ofstream(dir / "middle.json") << std::string("{\n  \"name\": \"x\",\n  \0\"duration\": 1}\n", 35);
  const std::pair<const char*, const char*> cases[] = {{"zeros.json", "zeros.json: line 1, column 1: "},
                                                       {"middle.json", "middle.json: line 3, column 3: "}};
  for (const auto& [file, where] : cases) {
    const auto r = run_loom("run " + (dir / file).string() + " --out " + (dir / "out").string());
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find(std::string(where) + "not JSON text: a NUL byte (binary data)"), std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(dir / "out"));
  }
}

}  // namespace
}  // namespace loom::test
