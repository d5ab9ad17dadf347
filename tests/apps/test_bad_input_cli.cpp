// Bad input through `loom run` end to end: a table of malformed inputs — JSON syntax errors, wrong
// types, unknown keys, out-of-range values, missing files, OBJ files with bad indices or lines, non-manifold
// and degenerate meshes, unwritable output folders, broken checkpoints. Every case asserts
//   - a non-zero exit (1: bad input or I/O error),
//   - a message naming the file, the field (JSON path) or line, and the problem,
//   - no output passed off as complete: no summary.json (or one marked "completed": false) and no stats.csv.
// The parser-level table of the same kind is tests/scene/test_scene_errors.cpp (it also covers the messages
// of cases not repeated here). BVH files (loom::characters' motion loader) cut short: skipped in builds
// without it.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "CliRunner.h"

namespace {

namespace fs = std::filesystem;

const char* kValid = R"({
  "duration": 0.05, "fps": 60,
  "solver": {"method": "symplectic_euler", "substeps": 20},
  "cloths": [{"name": "sheet",
              "mesh": {"type": "grid", "size": [1, 1], "nodes": [5, 5]},
              "material": {"preset": "cotton"},
              "mass": 0.2,
              "pins": [{"grid": [0, 0]}, {"grid": [-1, 0]}]}]
})";

struct BadInput {
  const char* name;
  const char* scene;              // scene text; nullptr: kValid
  std::vector<const char*> args;  // extra `loom run` arguments (--set ...); "@OBJ" = path of the case's OBJ
  const char* obj;                // text of DIR/mesh.obj (of DIR/motion.bvh with @BVHTEXT) or nullptr
  const char* file;               // whose name the message must hold: "scene", "obj", "out", or a literal
  const char* where;              // field, JSON path or line named in the message
  const char* problem;            // words of the problem
};

const BadInput kCases[] = {
    // JSON syntax: line and column.
    {"trailing_comma", "{\n  \"duration\": 1,\n}\n", {}, nullptr, "scene", "line 3, column", "invalid JSON"},
    {"unclosed_object",
     "{\n  \"duration\": 1,\n  \"cloths\": [\n",
     {},
     nullptr,
     "scene",
     "line 4",
     "invalid JSON"},
    {"single_quotes", "{'duration': 1}", {}, nullptr, "scene", "line 1, column", "invalid JSON"},
    {"empty_file", "", {}, nullptr, "scene", "line 1", "invalid JSON"},
    {"comment", "// a scene\n{\"duration\": 1}", {}, nullptr, "scene", "line 1", "invalid JSON"},
    {"top_level_array", "[1, 2]", {}, nullptr, "scene", "(top level)", "expected an object"},
    // Wrong types.
    {"duration_string",
     nullptr,
     {"--set", "duration=\"long\""},
     nullptr,
     "scene",
     "duration",
     "expected a number, got a string"},
    {"fps_array", nullptr, {"--set", "fps=[60]"}, nullptr, "scene", "fps", "expected a number"},
    {"cloths_object",
     nullptr,
     {"--set", "cloths={\"a\":1}"},
     nullptr,
     "scene",
     "cloths",
     "expected an array"},
    {"nodes_fractional",
     nullptr,
     {"--set", "cloths[0].mesh.nodes=[5.5,5]"},
     nullptr,
     "scene",
     "cloths[0].mesh.nodes",
     "two integers"},
    {"pin_vertex_string",
     nullptr,
     {"--set", "cloths[0].pins=[{\"vertex\":\"one\"}]"},
     nullptr,
     "scene",
     "cloths[0].pins[0].vertex",
     "expected an integer"},
    {"method_number",
     nullptr,
     {"--set", "solver.method=3"},
     nullptr,
     "scene",
     "solver.method",
     "expected a string"},
    {"formats_string",
     nullptr,
     {"--set", "output={\"formats\":\"obj\"}"},
     nullptr,
     "scene",
     "output.formats",
     "expected an array"},
    {"gravity_words",
     nullptr,
     {"--set", "gravity=[0,\"down\",0]"},
     nullptr,
     "scene",
     "gravity[1]",
     "expected a number, got a string"},
    // Unknown keys.
    {"unknown_top_key", nullptr, {"--set", "colour=1"}, nullptr, "scene", "colour", "unknown key"},
    {"unknown_solver_param",
     nullptr,
     {"--set", "solver.method=pbd", "--set", "solver.stiffnes=1"},
     nullptr,
     "scene",
     "solver.stiffnes",
     "unknown parameter for method 'pbd'"},
    {"unknown_drag_key",
     nullptr,
     {"--set", "effects={\"drag\":{\"windd\":[1,0,0]}}"},
     nullptr,
     "scene",
     "effects.drag.windd",
     "unknown key"},
    {"unknown_constraint",
     nullptr,
     {"--set", "constraints={\"strain_limt\":{}}"},
     nullptr,
     "scene",
     "constraints.strain_limt",
     "unknown key"},
    {"unknown_guard_key",
     nullptr,
     {"--set", "guard={\"halvings\":3}"},
     nullptr,
     "scene",
     "guard.halvings",
     "unknown key"},
    // Out-of-range values.
    {"fps_too_high", nullptr, {"--set", "fps=1e6"}, nullptr, "scene", "fps", "must be <= 100000"},
    {"substeps_too_many",
     nullptr,
     {"--set", "solver.substeps=2000000"},
     nullptr,
     "scene",
     "solver.substeps",
     "must be <= 1000000"},
    {"grid_too_big",
     nullptr,
     {"--set", "cloths[0].mesh.nodes=[5000,5]"},
     nullptr,
     "scene",
     "cloths[0].mesh.nodes",
     "[2, 4096]"},
    {"zero_stretch",
     nullptr,
     {"--set", "cloths[0].material={\"stretch\":0}"},
     nullptr,
     "scene",
     "cloths[0].material.stretch",
     "must be > 0"},
    {"pbd_stiffness",
     nullptr,
     {"--set", "solver.method=pbd", "--set", "solver.stiffness=2"},
     nullptr,
     "scene",
     "solver.stiffness",
     "must be in [0"},
    {"guard_halvings",
     nullptr,
     {"--set", "guard={\"max_halvings\":50}"},
     nullptr,
     "scene",
     "guard.max_halvings",
     "must be <= 20"},
    {"render_width",
     nullptr,
     {"--set", "output={\"render\":{\"width\":4}}"},
     nullptr,
     "scene",
     "output.render.width",
     "must be >= 16"},
    {"pin_off_grid",
     nullptr,
     {"--set", "cloths[0].pins=[{\"grid\":[9,0]}]"},
     nullptr,
     "scene",
     "cloths[0].pins[0].grid",
     "outside the 5x5 grid"},
    {"negative_mass",
     nullptr,
     {"--set", "cloths[0].mass=-1"},
     nullptr,
     "scene",
     "cloths[0].mass",
     "must be > 0"},
    // Missing files.
    {"missing_obj",
     nullptr,
     {"--set", "cloths[0].mesh={\"type\":\"obj\",\"path\":\"nowhere.obj\"}"},
     nullptr,
     "nowhere.obj",
     "cloths[0].mesh",
     "no such file (cannot open it)"},
    // OBJ files: bad indices, bad lines, non-manifold and degenerate meshes.
    {"obj_index_past_end",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
     "obj",
     "line 4",
     "out of range"},
    {"obj_index_zero", nullptr, {"@OBJ"}, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "obj", "line 4", "index"},
    {"obj_negative_past_start",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -7\n",
     "obj",
     "line 4",
     "out of range"},
    {"obj_index_word",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 two 3\n",
     "obj",
     "line 4",
     "bad vertex index 'two'"},
    {"obj_vertex_short",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n",
     "obj",
     "line 2",
     "'v' needs three numbers"},
    {"obj_vertex_nan",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
     "obj",
     "line 2",
     "not finite"},
    {"obj_two_vertex_face",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nf 1 2\n",
     "obj",
     "line 3",
     "at least 3 vertices"},
    {"obj_unknown_directive",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nq 1 2 3\nf 1 2 3\n",
     "obj",
     "line 4",
     "unknown OBJ directive 'q'"},
    {"obj_non_manifold",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n",
     "obj",
     "edge (0, 1)",
     "non-manifold edge"},
    {"obj_zero_area",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
     "obj",
     "triangle 0",
     "zero area"},
    {"obj_repeated_vertex",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2\n",
     "obj",
     "triangle 0",
     "repeats a vertex"},
    {"obj_unused_vertex",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nf 1 2 3\n",
     "obj",
     "vertex 3",
     "not used by any triangle"},
    {"obj_no_faces",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
     "obj",
     "cloths[0].mesh",
     "no triangles"},
    // BVH motion files (loom::characters, through assimp) cut short, and missing.
    {"bvh_cut_in_hierarchy",
     nullptr,
     {"@BVH:90"},
     nullptr,
     "motion.bvh",
     "character.bvh",
     "cannot read motion"},
    {"bvh_cut_in_frames",
     nullptr,
     {"@BVH:190"},
     nullptr,
     "motion.bvh",
     "character.bvh",
     "Unexpected end of file"},
    {"bvh_cut_after_motion",
     nullptr,
     {"@BVH:187"},
     nullptr,
     "motion.bvh",
     "character.bvh",
     "Unexpected end of file"},
    {"bvh_missing", nullptr, {"@BVH:0"}, nullptr, "motion.bvh", "character.bvh", "cannot read motion"},
    // A BVH that reads but holds a number past double range (a corrupt digit string): the joint is named.
    {"bvh_infinite_key",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n"
     " JOINT Spine\n {\n  OFFSET 0 10 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   "
     "OFFSET 0 5 0\n  }\n }\n}\n"
     "MOTION\nFrames: 2\nFrame Time: 0.0333333\n0 90 0 0 0 0 0 0 0\n1e999 90 0 0 0 0 0 0 0\n",
     "motion.bvh",
     "joint 'Hips'",
     "position key 1 is not finite"},
    // A garment resolution that would allocate without bound: estimated and refused before it is made.
    {"garment_resolution_tiny",
     nullptr,
     {"@BVH:100000", "--set", "character.garments=[{\"type\":\"cape\",\"resolution\":0.0001}]"},
     nullptr,
     "scene",
     "character.garments[0].resolution",
     "of memory"},
    // A BVH whose frame time or frame count makes no motion.
    {"bvh_frame_time_zero",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n"
     " End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0\n0 90 0 0 0 0\n1 90 0 0 0 0\n",
     "motion.bvh",
     "Frame Time",
     "positive number of seconds"},
    {"bvh_frame_time_negative",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n"
     " End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: -0.03\n0 90 0 0 0 0\n1 90 0 0 0 "
     "0\n",
     "motion.bvh",
     "Frame Time",
     "positive number of seconds"},
    // Output folder and checkpoints.
    {"out_under_proc",
     nullptr,
     {"--out", "/proc/loom_cannot_write_here"},
     nullptr,
     "/proc/loom_cannot_write_here",
     "--out",
     "cannot create output folder"},
    {"out_is_a_file", nullptr, {"--out", "@FILE"}, nullptr, "out", "--out", "cannot create output folder"},
    {"resume_without_checkpoint",
     nullptr,
     {"--resume", "@EMPTY"},
     nullptr,
     "checkpoint.bin",
     "--resume",
     "no checkpoint here"},
    {"resume_broken_checkpoint",
     nullptr,
     {"--resume", "@BROKEN"},
     nullptr,
     "checkpoint.bin",
     "checkpoint.bin",
     "not a valid checkpoint"},
    // Integers past 32 (or 64) bits: refused by value, never wrapped to a small one.
    {"nodes_past_32_bits",
     nullptr,
     {"--set", "cloths[0].mesh.nodes=[4294967301,5]"},
     nullptr,
     "scene",
     "cloths[0].mesh.nodes",
     "[2, 4096] (got 4294967301)"},
    {"nodes_past_64_bits",
     nullptr,
     {"--set", "cloths[0].mesh.nodes=[18446744073709551621,5]"},
     nullptr,
     "scene",
     "cloths[0].mesh.nodes",
     "two integers"},
    {"pin_grid_past_32_bits",
     nullptr,
     {"--set", "cloths[0].pins=[{\"grid\":[4294967296,0]}]"},
     nullptr,
     "scene",
     "cloths[0].pins[0].grid",
     "outside the 5x5 grid"},
    {"pin_vertex_past_64_bits",
     nullptr,
     {"--set", "cloths[0].pins=[{\"vertex\":18446744073709551615}]"},
     nullptr,
     "scene",
     "cloths[0].pins[0].vertex",
     "is out of range [0, 25)"},
    {"collider_index_past_32_bits",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"mesh\",\"vertices\":[[0,0,0],[1,0,0],[0,0,1]],\"triangles\":[[0,1,4294967298]]"
      "}]"},
     nullptr,
     "scene",
     "colliders[0].triangles[0][2]",
     "must be <= 2"},
    {"threads_past_int", nullptr, {"--set", "threads=4294967297"}, nullptr, "scene", "threads", "must be <="},
    // Frame and step counts that would overflow int.
    {"duration_huge",
     nullptr,
     {"--set", "duration=1e300"},
     nullptr,
     "scene",
     "duration",
     "frames (duration x fps)"},
    {"fps_makes_too_many_frames",
     nullptr,
     {"--set", "duration=1e6", "--set", "fps=100000"},
     nullptr,
     "scene",
     "duration",
     "at most 10000000"},
    {"dt_tiny",
     nullptr,
     {"--set", "solver={\"method\":\"symplectic_euler\",\"dt\":1e-300}"},
     nullptr,
     "scene",
     "solver.dt",
     "steps per frame"},
    // Messages that name the field and show the numbers as written.
    {"number_past_double_range",
     "{\n  \"duration\": 1e999\n}\n",
     {},
     nullptr,
     "scene",
     "line 2, column",
     "number overflow"},
    {"mesh_size_huge",
     nullptr,
     {"--set", "cloths[0].mesh.size=[1e300,1]"},
     nullptr,
     "scene",
     "cloths[0].mesh.size",
     "must be in [0.001, 1000000] m (got 1e+300)"},
    {"mesh_origin_huge",
     nullptr,
     {"--set", "cloths[0].mesh.origin=[1e300,0,0]"},
     nullptr,
     "scene",
     "cloths[0].mesh.origin",
     "within"},
    {"mass_over_tiny_density",
     nullptr,
     {"--set", "cloths[0].mass=1e-300"},
     nullptr,
     "scene",
     "cloths[0].mass",
     "areal density"},
    {"pbd_stiffness_shown_as_written",
     nullptr,
     {"--set", "solver.method=pbd", "--set", "solver.stiffness=2"},
     nullptr,
     "scene",
     "solver.stiffness",
     "must be in [0, 1] (got 2)"},
    {"mesh_is_a_folder",
     nullptr,
     {"--set", "cloths[0].mesh={\"type\":\"obj\",\"path\":\"/tmp\"}", "--set", "cloths[0].pins=[]"},
     nullptr,
     "scene",
     "cloths[0].mesh.path",
     "is a folder"},
    {"mesh_is_dev_zero",
     nullptr,
     {"--set", "cloths[0].mesh={\"type\":\"obj\",\"path\":\"/dev/zero\"}", "--set", "cloths[0].pins=[]"},
     nullptr,
     "scene",
     "cloths[0].mesh.path",
     "not a regular file"},
    {"collider_obj_is_a_folder",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"mesh\",\"obj\":\"/tmp\"}]"},
     nullptr,
     "scene",
     "colliders[0].obj",
     "is a folder"},
    // Output injection: control characters in any scene string.
    {"newline_in_cloth_name",
     nullptr,
     {"--set", "cloths[0].name=\"a\\nv 1 2 3\""},
     nullptr,
     "scene",
     "cloths[0].name",
     "control character (0x0a"},
    {"nul_in_scene_name",
     nullptr,
     {"--set", "name=\"a\\u0000b\""},
     nullptr,
     "scene",
     "name",
     "control character (0x00"},
    {"escape_in_collider_name",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"plane\",\"name\":\"\\u001b[2J\"}]"},
     nullptr,
     "scene",
     "colliders[0].name",
     "control character (0x1b"},
    // The scene name is a file name, never a path (it names the default folder out/<name>).
    {"name_is_absolute_path",
     nullptr,
     {"--set", "name=/tmp/loom_name_path"},
     nullptr,
     "scene",
     "name",
     "plain file name"},
    {"name_climbs_out", nullptr, {"--set", "name=../../x"}, nullptr, "scene", "name", "plain file name"},
    {"name_is_dot_dot", nullptr, {"--set", "name=\"..\""}, nullptr, "scene", "name", "plain file name"},
    // Silent nonsense.
    {"duplicate_key",
     "{\"duration\": 0.05, \"duration\": 5,\n \"cloths\": [{\"mesh\": {\"type\": \"grid\", \"size\": [1, 1], "
     "\"nodes\": [3, 3]}}]}",
     {},
     nullptr,
     "scene",
     "duration",
     "key given twice"},
    {"duplicate_nested_key",
     nullptr,
     {"--set", "cloths[0].mesh={\"type\":\"grid\",\"type\":\"grid\",\"size\":[1,1],\"nodes\":[5,5]}"},
     nullptr,
     "scene",
     "cloths[0].mesh.type",
     "key given twice"},
    {"vertex_pinned_twice",
     nullptr,
     {"--set", "cloths[0].pins=[{\"grid\":[0,0]},{\"vertex\":0,\"anchor\":[0,2,0]}]"},
     nullptr,
     "scene",
     "cloths[0].pins[1]",
     "already pinned by cloths[0].pins[0]"},
    // The same pin entry given twice, or a vertex two entries reach with different anchors or paths (two grid
    // nodes that coincide, a node on a pinned grid edge): each names both entries.
    {"pin_identical_twice",
     nullptr,
     {"--set", "cloths[0].pins=[{\"grid\":[0,0]},{\"grid\":[0,0]}]"},
     nullptr,
     "scene",
     "cloths[0].pins[1]",
     "already pinned by cloths[0].pins[0]"},
    {"pin_vertex_identical_twice",
     nullptr,
     {"--set", "cloths[0].pins=[{\"vertex\":3},{\"grid\":[0,0]},{\"vertex\":3}]"},
     nullptr,
     "scene",
     "cloths[0].pins[2]",
     "already pinned by cloths[0].pins[0]"},
    {"pin_grid_nodes_coincide",
     nullptr,
     {"--set", "cloths[0].pins=[{\"grid\":[-1,0]},{\"grid\":[4,0],\"anchor\":[0,2,0]}]"},
     nullptr,
     "scene",
     "cloths[0].pins[1]",
     "already pinned by cloths[0].pins[0]"},
    {"pin_node_on_pinned_edge",
     nullptr,
     {"--set", "cloths[0].pins=[{\"grid_edge\":\"u0\"},{\"grid\":[0,2],\"anchor\":[0,2,0]}]"},
     nullptr,
     "scene",
     "cloths[0].pins[1]",
     "already pinned by cloths[0].pins[0]"},
    // Collider lengths and positions are bounded as the cloth's are (1e6 m).
    {"collider_radius_huge",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"sphere\",\"radius\":1e300}]"},
     nullptr,
     "scene",
     "colliders[0].radius",
     "must be <= 1000000 m (got 1e+300)"},
    {"collider_position_huge",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"sphere\",\"radius\":0.1,\"position\":[1e300,0,0]}]"},
     nullptr,
     "scene",
     "colliders[0].position",
     "within +-1000000 m"},
    {"collider_capsule_half_height_huge",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"capsule\",\"radius\":0.1,\"half_height\":1e300}]"},
     nullptr,
     "scene",
     "colliders[0].half_height",
     "must be <= 1000000 m"},
    {"collider_box_extent_huge",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"box\",\"half_extents\":[1,1e300,1]}]"},
     nullptr,
     "scene",
     "colliders[0].half_extents",
     "(0, 1000000] m"},
    {"collider_thickness_huge",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"plane\",\"thickness\":1e300}]"},
     nullptr,
     "scene",
     "colliders[0].thickness",
     "must be <= 1000000 m"},
    {"collider_vertex_huge",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"mesh\",\"vertices\":[[0,0,0],[1e300,0,0],[0,0,1]],\"triangles\":[[0,1,2]]}]"},
     nullptr,
     "scene",
     "colliders[0].vertices[1]",
     "within +-1000000 m"},
    {"collider_keyframe_huge",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"plane\",\"motion\":{\"keyframes\":[{\"t\":0,\"position\":[0,-1e300,0]}]}}]"},
     nullptr,
     "scene",
     "colliders[0].motion.keyframes[0].position",
     "within +-1000000 m"},
    {"collider_spin_centre_huge",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"plane\",\"motion\":{\"spin\":{\"axis\":[0,1,0],\"rate\":1,\"centre\":[1e300,0,"
      "0]}}"
      "}]"},
     nullptr,
     "scene",
     "colliders[0].motion.spin.centre",
     "within +-1000000 m"},
    {"collider_velocity_escapes",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"plane\",\"motion\":{\"velocity\":[0,1e300,0]}}]"},
     nullptr,
     "scene",
     "colliders[0].motion.velocity",
     "beyond +-1000000 m"},
    // Collider meshes: a zero-area triangle (repeated or collinear vertices) is refused by index.
    {"collider_triangle_collinear",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"mesh\",\"vertices\":[[0,0,0],[1,0,0],[2,0,0],[0,0,1]],"
      "\"triangles\":[[0,1,3],[0,1,2]]}]"},
     nullptr,
     "scene",
     "colliders[0].triangles[1]",
     "triangle 1 has zero area"},
    {"collider_triangle_repeats_vertex",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"mesh\",\"vertices\":[[0,0,0],[1,0,0],[0,0,1]],\"triangles\":[[0,0,2]]}]"},
     nullptr,
     "scene",
     "colliders[0].triangles[0]",
     "zero area"},
    {"collider_obj_triangle_zero_area",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"mesh\",\"obj\":\"mesh.obj\"}]"},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nv 2 0 0\nf 1 2 3\nf 1 2 4\n",
     "obj",
     "line 6",
     "triangle 1 has zero area"},
    {"collider_obj_scale_tiny",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"mesh\",\"obj\":\"mesh.obj\",\"scale\":1e-300}]"},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n",
     "scene",
     "colliders[0].scale",
     "must be >= 1e-06"},
    // A run shorter than one frame is refused, not rounded up to one.
    {"duration_denormal",
     nullptr,
     {"--set", "duration=5e-324"},
     nullptr,
     "scene",
     "duration",
     "at least one frame"},
    {"duration_below_one_frame",
     nullptr,
     {"--set", "duration=0.01"},
     nullptr,
     "scene",
     "duration",
     "duration >= 1/fps"},
    // --set PATH: malformed paths are refused by position, never read as a nearby path.
    {"set_empty_segment",
     nullptr,
     {"--set", "solver..method=x"},
     nullptr,
     "scene",
     "--set solver..method=x",
     "empty key"},
    {"set_unclosed_bracket",
     nullptr,
     {"--set", "cloths[0.mass=1"},
     nullptr,
     "scene",
     "--set cloths[0.mass=1",
     "not closed"},
    {"set_word_index",
     nullptr,
     {"--set", "cloths[x].mass=1"},
     nullptr,
     "scene",
     "--set cloths[x].mass=1",
     "not an array index"},
    {"set_trailing_dot",
     nullptr,
     {"--set", "duration.=1"},
     nullptr,
     "scene",
     "--set duration.=1",
     "ends with"},
    {"set_leading_dot",
     nullptr,
     {"--set", ".duration=1"},
     nullptr,
     "scene",
     "--set .duration=1",
     "starts with"},
    {"set_stray_close",
     nullptr,
     {"--set", "cloths]0=1"},
     nullptr,
     "scene",
     "--set cloths]0=1",
     "without '['"},
    {"set_index_into_object",
     nullptr,
     {"--set", "solver[0]=1"},
     nullptr,
     "scene",
     "--set solver[0]=1",
     "not an array"},
    // OBJ errors quote the faulty line with its number, whatever the line endings.
    {"obj_error_quotes_its_line",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\nf 1 2 x\n",
     "obj",
     "line 5 ('f 1 2 x')",
     "bad vertex index 'x'"},
    {"obj_old_mac_line_endings",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\rv 1 0 0\rv 0 0 1\rv 1 nan 0\rf 1 2 3\r",
     "obj",
     "line 4 ('v 1 nan 0')",
     "not finite"},
    {"collider_obj_error_quotes_its_line",
     nullptr,
     {"--set", "colliders=[{\"shape\":\"mesh\",\"obj\":\"mesh.obj\"}]"},
     "v 0 0 0\r\nv 1 0 0\r\nv 0 0 1\r\nf 1 2 9\r\n",
     "obj",
     "line 4 ('f 1 2 9')",
     "out of range"},
    // Coefficients and accelerations that would overflow the forces: refused by name, not left to the guard.
    {"gravity_huge", nullptr, {"--set", "gravity=[0,-1e300,0]"}, nullptr, "scene", "gravity", "m/s^2"},
    {"stretch_huge",
     nullptr,
     {"--set", "cloths[0].material={\"preset\":\"cotton\",\"stretch\":1e300}"},
     nullptr,
     "scene",
     "cloths[0].material.stretch",
     "must be <= 1e+12"},
    {"damping_huge",
     nullptr,
     {"--set", "cloths[0].material={\"preset\":\"cotton\",\"damping\":1e300}"},
     nullptr,
     "scene",
     "cloths[0].material.damping",
     "must be <= 1e+12"},
    {"material_thickness_huge",
     nullptr,
     {"--set", "cloths[0].material={\"preset\":\"cotton\",\"thickness\":1e300}"},
     nullptr,
     "scene",
     "cloths[0].material.thickness",
     "must be <= 1000000 m"},
    {"drag_huge",
     nullptr,
     {"--set", "effects={\"drag\":{\"isotropic\":1e300}}"},
     nullptr,
     "scene",
     "effects.drag.isotropic",
     "must be <= 1e+12"},
    {"wind_huge",
     nullptr,
     {"--set", "effects={\"drag\":{\"normal\":1,\"wind\":[1e300,0,0]}}"},
     nullptr,
     "scene",
     "effects.drag.wind",
     "m/s"},
    {"collision_thickness_huge",
     nullptr,
     {"--set", "collision={\"thickness\":1e300}"},
     nullptr,
     "scene",
     "collision.thickness",
     "must be <= 1000000 m"},
    {"collider_spin_rate_huge",
     nullptr,
     {"--set",
      "colliders=[{\"shape\":\"sphere\",\"radius\":0.1,\"motion\":{\"spin\":{\"axis\":[0,1,0],\"rate\":1e300}"
      "}}]"},
     nullptr,
     "scene",
     "colliders[0].motion.spin.rate",
     "rad/s"},
    {"body_radius_huge",
     nullptr,
     {"--set", "bodies=[{\"shape\":\"sphere\",\"radius\":1e300,\"mass\":1}]"},
     nullptr,
     "scene",
     "bodies[0].radius",
     "must be <= 1000000 m"},
    // Character fields that would make a garment degenerate or non-finite: blamed on the field, not on a
    // garment vertex or triangle.
    {"character_height_huge",
     nullptr,
     {"@BVH:100000", "--set", "character.height=1e300"},
     nullptr,
     "scene",
     "character.height",
     "must be <= 1000000 m"},
    {"character_scale_huge",
     nullptr,
     {"@BVH:100000", "--set", "character.scale=1e300"},
     nullptr,
     "scene",
     "character.scale",
     "in (0, 1000000]"},
    {"garment_length_tiny",
     nullptr,
     {"@BVH:100000", "--set", "character.garments=[{\"type\":\"cape\",\"length\":1e-300}]"},
     nullptr,
     "scene",
     "character.garments[0].length",
     "must be in [0.01, 100] m"},
    // The field at fault and its own limit, never a quantity derived from it.
    {"grid_size_denormal",
     nullptr,
     {"--set", "cloths[0].mesh.size=[5e-324,1]"},
     nullptr,
     "scene",
     "cloths[0].mesh.size",
     "must be in [0.001, 1000000] m"},
    {"detail_levels_past_32_bits",
     nullptr,
     {"--set", "cloths[0].detail={\"levels\":4294967296}"},
     nullptr,
     "scene",
     "cloths[0].detail.levels",
     "must be <= 5 (got 4294967296)"},
    {"substeps_past_32_bits",
     nullptr,
     {"--set", "solver.substeps=4294967296"},
     nullptr,
     "scene",
     "solver.substeps",
     "must be <= 1000000 (got"},
    {"obj_scale_tiny",
     nullptr,
     {"@OBJ", "--set", "cloths[0].mesh.scale=1e-300"},
     "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n",
     "scene",
     "cloths[0].mesh.scale",
     "must be in [1e-06"},
    {"obj_mesh_tiny_after_scale",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1e-5 0 0\nv 0 0 1e-5\nf 1 2 3\n",
     "scene",
     "cloths[0].mesh.scale",
     "m across; at least 0.001 m"},
    {"wrinkle_wavelength_denormal",
     nullptr,
     {"--set", "cloths[0].detail={\"wrinkles\":{\"wavelength\":1e-320}}"},
     nullptr,
     "scene",
     "cloths[0].detail.wrinkles.wavelength",
     "must be in [0.0001, 1] m"},
};

class BadInputCli : public ::testing::TestWithParam<BadInput> {};

TEST_P(BadInputCli, NonZeroExitNamedMessageNoCompleteOutput) {
  const BadInput& c = GetParam();
  const fs::path dir = loom::test::test_dir();
  const fs::path scene = dir / "scene.json", obj = dir / "mesh.obj", out = dir / "out";
  fs::remove_all(out);
  std::ofstream(scene) << (c.scene ? c.scene : kValid);
  if (c.obj && (c.args.empty() || c.args[0] != std::string("@BVHTEXT"))) std::ofstream(obj) << c.obj;
  std::vector<std::string> argv = {"run"};
  fs::path out_used = out;
  bool resume = false, has_out = false;
  for (size_t i = 0; i < c.args.size(); ++i) {
    const std::string a = c.args[i];
    if (a == "@OBJ") {
      argv.insert(argv.end(), {"--set", "cloths[0].mesh={\"type\":\"obj\",\"path\":\"mesh.obj\"}", "--set",
                               "cloths[0].pins=[]"});
    } else if (a.rfind("@BVH:", 0) == 0) {
      // The first N lines of a CMU clip (tests/data/mocap/01_01.bvh: MOTION at line 185); 0: no file at all.
      const int n = std::stoi(a.substr(5));
      fs::remove(dir / "motion.bvh");
      if (n > 0) {
        std::ifstream in(std::string(LOOM_TEST_DATA) + "/mocap/01_01.bvh");
        std::ofstream cut(dir / "motion.bvh");
        std::string line;
        for (int k = 0; k < n && std::getline(in, line); ++k) cut << line << "\n";
      }
      argv.insert(argv.end(), {"--set", "character={\"bvh\":\"motion.bvh\"}"});
    } else if (a == "@BVHTEXT") {  // the case's `obj` text as the motion file
      std::ofstream(dir / "motion.bvh") << c.obj;
      argv.insert(argv.end(), {"--set", "character={\"bvh\":\"motion.bvh\"}"});
    } else if (a == "@FILE") {
      out_used = dir / "a_file";
      std::ofstream(out_used) << "not a folder";
      argv.push_back(out_used.string());
    } else if (a == "@EMPTY" || a == "@BROKEN") {
      out_used = dir / "resume";
      fs::remove_all(out_used);
      fs::create_directories(out_used / "checkpoint");
      if (a == "@BROKEN") std::ofstream(out_used / "checkpoint" / "checkpoint.bin") << "LOOMCKPT1\n\x05";
      argv.push_back(out_used.string());
      resume = true;
    } else {
      if (a == "--out") {
        has_out = true;
        out_used = c.args[i + 1];
      }
      argv.push_back(a);
    }
  }
  if (!resume) argv.push_back(scene.string());
  if (!has_out && !resume) argv.insert(argv.end(), {"--out", out.string()});
  std::string args;
  for (const std::string& a : argv) args += "'" + a + "' ";  // no case has a single quote
  const loom::test::CliResult r = loom::test::run_loom(args);
  if (r.err.find("this build has no loom::characters") != std::string::npos)
    GTEST_SKIP() << "no loom::characters";
  EXPECT_EQ(r.code, 1) << args << "\n" << r.err;
  std::string file = c.file;
  if (file == "scene") file = scene.string();
  if (file == "obj") file = obj.string();
  if (file == "out") file = out_used.string();
  EXPECT_NE(r.err.find(file), std::string::npos) << "file '" << file << "' not named in: " << r.err;
  EXPECT_NE(r.err.find(c.where), std::string::npos) << "'" << c.where << "' not named in: " << r.err;
  EXPECT_NE(r.err.find(c.problem), std::string::npos) << "'" << c.problem << "' not named in: " << r.err;
  // Nothing passes for a finished run.
  for (const fs::path& o : {out, out_used}) {
    if (o.empty() || !fs::is_directory(o)) continue;
    if (fs::exists(o / "summary.json")) {
      const auto j = nlohmann::json::parse(loom::test::slurp(o / "summary.json"));
      EXPECT_FALSE(j.value("completed", true)) << o;
    }
    EXPECT_FALSE(fs::exists(o / "stats.csv")) << o;
  }
}

INSTANTIATE_TEST_SUITE_P(Table, BadInputCli, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<BadInput>& info) {
                           return std::string(info.param.name);
                         });

TEST(BadInputCli, TableHasAtLeastSeventyCases) { EXPECT_GE(sizeof(kCases) / sizeof(kCases[0]), 75u); }

// Every numeric command-line option: the whole text one finite number in the option's range. nan, inf,
// 1e999, trailing text and fractions of counts exit non-zero naming the option (2, a bad command line;
// fabric-test reports its option errors with 1, as it always has).
TEST(BadInputCli, NumericOptionsRefuseNonFiniteAndMalformedNumbersByName) {
  const fs::path dir = loom::test::test_dir();
  const std::string scene = (dir / "scene.json").string();
  std::ofstream(scene) << kValid;
  const std::string csv =
      std::string(LOOM_TEST_DATA) + "/ccd-sample-queries/erleben-spikes/vertex-face/data_0_0.csv";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"ccd-eval " + csv + " --translate nan", "--translate"},
      {"ccd-eval " + csv + " --translate 1e999", "--translate"},
      {"ccd-eval " + csv + " --tolerance inf", "--tolerance"},
      {"ccd-eval " + csv + " --min-separation -inf", "--min-separation"},
      {"ccd-eval " + csv + " --min-separation nan", "--min-separation"},
      {"ccd-eval " + csv + " --scale-exp 3.5", "--scale-exp"},
      {"fabric-test catenary --span nan", "--span"},
      {"fabric-test cantilever --overhang-ratio inf", "--overhang-ratio"},
      {"fabric-test cantilever --solver verlet --settle-speed nan", "--settle-speed"},
      {"run " + scene + " --frames 5x", "--frames"},
      {"run " + scene + " --threads 1e3", "--threads"},
      {"run " + scene + " --checkpoint-every -1", "--checkpoint-every"},
      {"run " + scene + " --frames 0", "--frames"},
      {"compare " + scene + " --frames 1.5", "--frames"},
      {"bench realtime --seconds nan", "--seconds"},
      {"bench realtime --sheet 12x", "--sheet"},
      {"bench accuracy --duration nan", "--duration"},
      {"bench accuracy --perturbation inf", "--perturbation"},
  };
  for (const auto& [args, option] : cases) {
    const loom::test::CliResult r = loom::test::run_loom(args);
    if (r.err.find("unknown command") != std::string::npos) continue;  // a build without Bullet
    EXPECT_EQ(r.code, args.rfind("fabric-test", 0) == 0 ? 1 : 2) << args << ": " << r.err;
    EXPECT_NE(r.err.find(option), std::string::npos) << args << ": " << r.err;
    EXPECT_EQ(r.out.find("queries="), std::string::npos) << args;
  }
}

// Every file Loom reads is a regular file of bounded size, however it is reached: a link to /dev/zero, a
// folder or a pipe is refused by name before a byte is read (no hang, no unbounded read).
TEST(BadInputCli, InputFilesThatAreNotRegularFilesAreRefusedBeforeReading) {
  const fs::path dir = loom::test::test_dir();
  for (const char* name : {"vertex-face-zero.csv", "scene-zero.json", "mesh-zero.obj", "fifo.obj"})
    fs::remove(dir / name);
  fs::create_symlink("/dev/zero", dir / "vertex-face-zero.csv");
  fs::create_symlink("/dev/zero", dir / "scene-zero.json");
  fs::create_symlink("/dev/zero", dir / "mesh-zero.obj");
  ASSERT_EQ(std::system(("mkfifo " + (dir / "fifo.obj").string()).c_str()), 0);
  fs::create_directories(dir / "vertex-face-dir.csv");
  const std::string scene = (dir / "scene.json").string();
  std::ofstream(scene) << kValid;
  auto mesh = [&](const char* file) {
    return "run " + scene + " --out " + (dir / "out").string() +
           " --set 'cloths[0].mesh={\"type\":\"obj\",\"path\":\"" + file + "\"}' --set 'cloths[0].pins=[]'";
  };
  auto collider = [&](const char* file) {
    return "run " + scene + " --out " + (dir / "out").string() +
           " --set 'colliders=[{\"shape\":\"mesh\",\"obj\":\"" + file + "\"}]'";
  };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"ccd-eval " + (dir / "vertex-face-zero.csv").string(), "vertex-face-zero.csv"},
      {"ccd-eval " + (dir / "vertex-face-dir.csv").string(), "vertex-face-dir.csv"},
      {"run " + (dir / "scene-zero.json").string() + " --out " + (dir / "out").string(), "scene-zero.json"},
      {mesh("mesh-zero.obj"), "mesh-zero.obj"},
      {mesh("fifo.obj"), "fifo.obj"},
      {collider("mesh-zero.obj"), "mesh-zero.obj"},
      {collider("fifo.obj"), "fifo.obj"},
  };
  for (const auto& [args, file] : cases) {
    fs::remove_all(dir / "out");
    const loom::test::CliResult r = loom::test::run_loom(args);
    EXPECT_EQ(r.code, 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(file), std::string::npos) << args << ": " << r.err;
    EXPECT_TRUE(r.err.find("not a regular file") != std::string::npos ||
                r.err.find("is a folder") != std::string::npos)
        << args << ": " << r.err;
  }
}

// Two grid_edge sides share their corner, and two grid nodes that coincide (a grid made smaller with --set)
// reach one vertex the same way: it is pinned once, not refused as pinned twice.
TEST(BadInputCli, EntriesReachingAVertexTheSameWayPinItOnce) {
  const fs::path dir = loom::test::test_dir();
  const std::string scene = (dir / "scene.json").string();
  std::ofstream(scene) << kValid;
  const loom::test::CliResult r = loom::test::run_loom(
      "run " + scene + " --out " + (dir / "out").string() +
      " --set 'cloths[0].pins=[{\"grid_edge\":\"u0\"},{\"grid_edge\":\"v0\"},{\"grid_edge\":\"u1\"}]'");
  EXPECT_EQ(r.code, 0) << r.err;
  const loom::test::CliResult small =
      loom::test::run_loom("run " + scene + " --out " + (dir / "out2").string() +
                           " --set 'cloths[0].pins=[{\"grid\":[-1,4]},{\"grid\":[-1,-1]}]'");
  EXPECT_EQ(small.code, 0) << small.err;
}

}  // namespace
