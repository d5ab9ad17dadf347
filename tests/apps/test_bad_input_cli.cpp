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

#include "BadInputCli.h"
#include "CliRunner.h"

namespace {

namespace fs = std::filesystem;
using loom::test::bad_input_name;
using loom::test::BadInput;
using loom::test::BadInputCli;

const char* kValid = R"({
  "duration": 0.05, "fps": 60,
  "solver": {"method": "symplectic_euler", "substeps": 20},
  "cloths": [{"name": "sheet",
              "mesh": {"type": "grid", "size": [1, 1], "nodes": [5, 5]},
              "material": {"preset": "cotton"},
              "mass": 0.2,
              "pins": [{"grid": [0, 0]}, {"grid": [-1, 0]}]}]
})";

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
    // A number whose text is not zero but underflows a double is refused as written, by its path.
    {"duration_underflows",
     nullptr,
     {"--set", "duration=1e-400"},
     nullptr,
     "scene",
     "duration",
     "1e-400 is below the smallest double"},
    {"mass_underflows_negative",
     nullptr,
     {"--set", "cloths[0].mass=-1e-400"},
     nullptr,
     "scene",
     "cloths[0].mass",
     "-1e-400 is below the smallest double (4.9e-324): it would read as -0"},
    // A fraction given to an integer field is shown as written; a whole number written 4.0 is the integer 4.
    {"substeps_fraction_shown",
     nullptr,
     {"--set", "solver.substeps=4.5"},
     nullptr,
     "scene",
     "solver.substeps",
     "expected an integer, got 4.5"},
    // A value quoted in a message shows the shortest text that reads back to it: not 0.3 for 0.30000001.
    {"number_shown_to_its_digits",
     nullptr,
     {"--set", "cloths[0].mass=-0.30000001"},
     nullptr,
     "scene",
     "cloths[0].mass",
     "(got -0.30000001)"},
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
    {"wind_negative_density",
     nullptr,
     {"--set", "effects={\"wind\":{\"velocity\":[5,0,0],\"density\":-1}}"},
     nullptr,
     "scene",
     "effects.wind.density",
     "must be >= 0 (got -1"},
    {"wind_missing_velocity",
     nullptr,
     {"--set", "effects={\"wind\":{\"density\":1.2}}"},
     nullptr,
     "scene",
     "effects.wind.velocity",
     "is required"},
    {"wind_too_fast",
     nullptr,
     {"--set", "effects={\"wind\":{\"velocity\":[1e300,1e300,0]}}"},
     nullptr,
     "scene",
     "effects.wind.velocity",
     "at most 1000 m/s"},
    {"wind_drag_out_of_range",
     nullptr,
     {"--set", "effects={\"wind\":{\"velocity\":[5,0,0],\"drag\":20}}"},
     nullptr,
     "scene",
     "effects.wind.drag",
     "must be in [0, 10]"},
    {"wind_negative_lift",
     nullptr,
     {"--set", "effects={\"wind\":{\"velocity\":[5,0,0],\"lift\":-0.5}}"},
     nullptr,
     "scene",
     "effects.wind.lift",
     "must be >= 0 (got -"},
    {"wind_gust_amplitude",
     nullptr,
     {"--set", "effects={\"wind\":{\"velocity\":[5,0,0],\"gusts\":[{\"amplitude\":1.5,\"frequency\":1}]}}"},
     nullptr,
     "scene",
     "effects.wind.gusts[0].amplitude",
     "must be in [0, 1]"},
    {"wind_gust_no_frequency",
     nullptr,
     {"--set", "effects={\"wind\":{\"velocity\":[5,0,0],\"gusts\":[{\"amplitude\":0.5}]}}"},
     nullptr,
     "scene",
     "effects.wind.gusts[0].frequency",
     "is required"},
    {"wind_swing_angle",
     nullptr,
     {"--set", "effects={\"wind\":{\"velocity\":[5,0,0],\"swing\":{\"angle\":200,\"frequency\":1}}}"},
     nullptr,
     "scene",
     "effects.wind.swing.angle",
     "must be in [0, 180] degrees"},
    {"wind_swing_zero_axis",
     nullptr,
     {"--set",
      "effects={\"wind\":{\"velocity\":[5,0,0],\"swing\":{\"angle\":10,\"frequency\":1,\"axis\":[0,0,0]}}}"},
     nullptr,
     "scene",
     "effects.wind.swing.axis",
     "non-zero"},
    {"wind_unknown_key",
     nullptr,
     {"--set", "effects={\"wind\":{\"velocity\":[5,0,0],\"lifft\":1}}"},
     nullptr,
     "scene",
     "effects.wind.lifft",
     "unknown key"},
    {"pressure_open_mesh",
     nullptr,
     {"--set", "cloths[0].pressure={\"overpressure\":100}"},
     nullptr,
     "scene",
     "cloths[0].pressure",
     "closed mesh"},
    {"pressure_missing_overpressure",
     nullptr,
     {"--set", "cloths[0].pressure={\"model\":\"constant\"}"},
     nullptr,
     "scene",
     "cloths[0].pressure.overpressure",
     "is required"},
    {"pressure_unknown_model",
     nullptr,
     {"--set", "cloths[0].pressure={\"model\":\"van_der_waals\",\"overpressure\":100}"},
     nullptr,
     "scene",
     "cloths[0].pressure.model",
     "unknown value 'van_der_waals'"},
    {"pressure_negative_ambient",
     nullptr,
     {"--set", "cloths[0].pressure={\"model\":\"ideal_gas\",\"overpressure\":100,\"ambient\":-5}"},
     nullptr,
     "scene",
     "cloths[0].pressure.ambient",
     "must be >= 0 (got -"},
    {"pressure_vacuum_gas",
     nullptr,
     {"--set", "cloths[0].pressure={\"model\":\"ideal_gas\",\"overpressure\":-200000}"},
     nullptr,
     "scene",
     "cloths[0].pressure.overpressure",
     "positive absolute pressure"},
    {"pressure_ambient_constant",
     nullptr,
     {"--set", "cloths[0].pressure={\"overpressure\":100,\"ambient\":1000}"},
     nullptr,
     "scene",
     "cloths[0].pressure.ambient",
     "only the ideal_gas model"},
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
    {"fps_too_high", nullptr, {"--set", "fps=1e6"}, nullptr, "scene", "fps", "must be in [1e-06, 100000] Hz"},
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
    {"obj_text_after_vertex",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0 junk\nv 0 1 0\nf 1 2 3\n",
     "obj",
     "line 2",
     "unexpected 'junk' after the vertex's coordinates"},
    {"obj_hexadecimal_coordinate",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 0x1 0 0\nv 0 1 0\nf 1 2 3\n",
     "obj",
     "line 2",
     "three numbers (decimal)"},
    {"obj_face_given_twice_reversed",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 3 2 1\n",
     "obj",
     "line 5 ('f 3 2 1')",
     "same three vertices as line 4 ('f 1 2 3')"},
    {"obj_non_manifold",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n",
     "obj",
     "edge (vertex 1 (line 1), vertex 2 (line 2))",
     "non-manifold edge"},
    {"obj_zero_area",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
     "obj",
     "line 4 ('f 1 2 3')",
     "zero area"},
    {"obj_repeated_vertex",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2\n",
     "obj",
     "line 4 ('f 1 2 2')",
     "repeats a vertex"},
    {"obj_unused_vertex",
     nullptr,
     {"@OBJ"},
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nf 1 2 3\n",
     "obj",
     "vertex 4 (line 4)",
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
     "Frames",
     "says 2752 frames but the MOTION section holds"},
    {"bvh_cut_after_motion",
     nullptr,
     {"@BVH:187"},
     nullptr,
     "motion.bvh",
     "Frames",
     "says 2752 frames but the MOTION section holds 0 frame lines (of 96 numbers each)"},
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
     "line 20",
     "value 1 of the line, '1e999', is past the 3.4e38"},
    // Old Mac line ends (CR alone): the frames would read as one line; the first lone CR is named.
    {"bvh_cr_line_ends",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n"
     " JOINT Spine\n {\n  OFFSET 0 10 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   "
     "OFFSET 0 5 0\n  }\n }\n}\n"
     "MOTION\nFrames: 2\nFrame Time: 0.0333333\r0 90 0 0 0 0 0 0 0\r1 90 0 0 0 0 0 0 0\r",
     "motion.bvh",
     "line 18",
     "a carriage return without a line feed"},
    // A garment resolution that would allocate without bound: estimated and refused before it is made.
    {"garment_resolution_tiny",
     nullptr,
     {"@BVH:100000", "--set", "character.garments=[{\"type\":\"cape\",\"resolution\":0.0001}]"},
     nullptr,
     "scene",
     "character.garments[0].resolution",
     "of memory"},
    // An estimate past double range shows a finite figure, never "inf".
    {"garment_resolution_denormal",
     nullptr,
     {"@BVH:100000", "--set", "character.garments=[{\"type\":\"cape\",\"resolution\":5e-324}]"},
     nullptr,
     "scene",
     "character.garments[0].resolution",
     "have more than 1e15 vertices, which need more than 1e6 GB"},
    // An OBJ garment is held to an OBJ cloth's bounds, by its scale: every vertex within +-1e6 m after
    // scale and translate, and at least 1 mm across.
    {"garment_obj_scale_huge",
     nullptr,
     {"@BVH:100000", "--set",
      "character.garments=[{\"type\":\"obj\",\"path\":\"mesh.obj\",\"attach\":{\"top\":\"Neck\"},"
      "\"scale\":1e6}]"},
     "v -0.5 1.5 -0.5\nv 0.5 1.5 -0.5\nv -0.5 1.5 0.5\nv 0.5 1.5 0.5\ng top\nf 1 2 3\ng rest\nf 2 4 3\n",
     "scene",
     "character.garments[0].scale",
     "puts vertex 1 (line 1 of mesh.obj) at (-5e+05, 1.5e+06, -5e+05) m"},
    {"garment_obj_scale_tiny",
     nullptr,
     {"@BVH:100000", "--set",
      "character.garments=[{\"type\":\"obj\",\"path\":\"mesh.obj\",\"attach\":{\"top\":\"Neck\"},"
      "\"scale\":1e-6}]"},
     "v -0.5 1.5 -0.5\nv 0.5 1.5 -0.5\nv -0.5 1.5 0.5\nv 0.5 1.5 0.5\ng top\nf 1 2 3\ng rest\nf 2 4 3\n",
     "scene",
     "character.garments[0].scale",
     "m across; at least 0.001 m"},
    // A friction pair's name that stands for two garments names the fields the scene wrote.
    {"friction_pair_names_two_garments",
     nullptr,
     {"@BVH:100000", "--set",
      "character.garments=[{\"type\":\"cape\",\"name\":\"g\",\"resolution\":0.1},"
      "{\"type\":\"cape\",\"name\":\"g\",\"resolution\":0.1}]",
      "--set", "collision={\"friction_pairs\":[{\"a\":\"g\",\"b\":\"g\",\"friction\":0.5}]}"},
     nullptr,
     "scene",
     "collision.friction_pairs[0].a",
     "'g' names character.garments[0] and character.garments[1]"},
    // A BVH whose frame time or frame count makes no motion.
    {"bvh_frame_time_zero",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n"
     " End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0\n0 90 0 0 0 0\n1 90 0 0 0 0\n",
     "motion.bvh",
     "Frame Time",
     "must be in [1e-06, 3600] seconds"},
    {"bvh_frame_time_negative",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n"
     " End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: -0.03\n0 90 0 0 0 0\n1 90 0 0 0 "
     "0\n",
     "motion.bvh",
     "Frame Time",
     "must be in [1e-06, 3600] seconds"},
    {"bvh_frame_time_huge",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n"
     " End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: 1e300\n0 90 0 0 0 0\n1 90 0 0 0 "
     "0\n",
     "motion.bvh",
     "Frame Time",
     "must be in [1e-06, 3600] seconds"},
    // A frame count the file does not hold: refused before the reader reserves memory for it.
    {"bvh_frame_count_past_file",
     nullptr,
     {"@BVHTEXT"},
     "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
     "Yrotation\n"
     " End Site\n {\n  OFFSET 0 5 0\n }\n}\nMOTION\nFrames: 2000000000\nFrame Time: 0.03\n0 90 0 0 0 0\n",
     "motion.bvh",
     "Frames",
     "says 2000000000 frames but the MOTION section holds 1 frame lines (of 6 numbers each)"},
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
     "no checkpoint here (a run writes one with --checkpoint-every N; a scene with rigid bodies cannot write "
     "one"},
    {"resume_broken_checkpoint",
     nullptr,
     {"--resume", "@BROKEN"},
     nullptr,
     "checkpoint.bin",
     "checkpoint.bin",
     "not a valid checkpoint"},
};

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

INSTANTIATE_TEST_SUITE_P(Table, BadInputCli, ::testing::ValuesIn(kCases), bad_input_name);

TEST(BadInputCli, TableHasAtLeastSeventyCases) {
  EXPECT_GE(sizeof(kCases) / sizeof(kCases[0]) + loom::test::bad_input_limit_rows(), 75u);
}

// A UTF-8 byte order mark at the start of an OBJ file (written by some editors) is not a directive.
TEST(BadInputCli, ObjWithByteOrderMarkAndColoursLoads) {
  const fs::path dir = loom::test::test_dir();
  std::ofstream(dir / "scene.json") << kValid;
  std::ofstream(dir / "bom.obj") << "\xef\xbb\xbfv 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  fs::remove_all(dir / "out");
  const loom::test::CliResult r = loom::test::run_loom(
      "run '" + (dir / "scene.json").string() + "' --out '" + (dir / "out").string() +
      "' --set 'cloths[0].mesh={\"type\":\"obj\",\"path\":\"bom.obj\"}' --set 'cloths[0].pins=[]'");
  EXPECT_EQ(r.code, 0) << r.err;
}

// --resume continues the checkpoint's run: an option that would change it is refused by name (exit 2), not
// dropped in silence.
TEST(BadInputCli, ResumeRefusesOptionsItWouldIgnore) {
  const std::string dir = loom::test::test_dir().string();
  for (const std::string& extra : std::vector<std::string>{
           "--set duration=1", "--out '" + dir + "/elsewhere'", "--render", "--census"}) {
    const loom::test::CliResult r = loom::test::run_loom("run --resume '" + dir + "' " + extra);
    EXPECT_EQ(r.code, 2) << extra << ": " << r.err;
    EXPECT_NE(r.err.find(extra.substr(0, extra.find(' ')) + ": not with --resume"), std::string::npos)
        << r.err;
  }
}

// A pin path slow enough for the cloth's stretch waves but long enough to tear it (25 m away from the other
// pin of a 1 m sheet) ends in the guard's strain stop, exit 3, and the message names the moving pin.
TEST(BadInputCli, StrainStopNamesTheMovingPin) {
  const fs::path dir = loom::test::test_dir();
  std::ofstream(dir / "scene.json") << kValid;
  fs::remove_all(dir / "out");
  const loom::test::CliResult r = loom::test::run_loom(
      "run '" + (dir / "scene.json").string() + "' --out '" + (dir / "out").string() +
      "' --set 'cloths[0].pins=[{\"grid\":[0,0]},{\"grid\":[-1,0],\"path\":{\"times\":[0,0.05],"
      "\"offsets\":[[0,0,0],[25,0,0]]}}]'");
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("the strain exploded"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("the moving pin cloths[0].pins[1] (cloth 'sheet'"), std::string::npos) << r.err;
}

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
      {"bench realtime --scenes toy_box,cloth", "--scenes"},
      {"bench realtime --scenes sheet,", "--scenes"},
      {"bench realtime --toy 2", "--toy"},
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

// Every whole-number option takes exactly its digits (no space before or after, no '+') and states the
// range it really accepts; a number outside it is a bad command line (exit 2; fabric-test 1), never an
// error of the scene file.
TEST(BadInputCli, WholeNumberOptionsTakeExactlyTheDigitsAndStateTheirRealRange) {
  const fs::path dir = loom::test::test_dir();
  const std::string scene = (dir / "scene.json").string();
  std::ofstream(scene) << kValid;
  const std::string csv =
      std::string(LOOM_TEST_DATA) + "/ccd-sample-queries/erleben-spikes/vertex-face/data_0_0.csv";
  struct Row {
    std::string args, option, range;
  };
  const std::vector<Row> rows = {
      {"run " + scene + " --frames ' 2'", "--frames", "[1, 10000000]"},
      {"run " + scene + " --frames '2 '", "--frames", "[1, 10000000]"},
      {"run " + scene + " --frames +2", "--frames", "[1, 10000000]"},
      {"run " + scene + " --frames 50000000", "--frames", "[1, 10000000]"},
      {"run " + scene + " --frames 100000001", "--frames", "[1, 10000000]"},
      {"run " + scene + " --threads ' 1'", "--threads", "[1, 4096]"},
      {"run " + scene + " --threads 0", "--threads", "[1, 4096]"},
      {"run " + scene + " --threads 5000", "--threads", "[1, 4096]"},
      {"run " + scene + " --checkpoint-every ' 1'", "--checkpoint-every", "[0, 10000000]"},
      {"compare " + scene + " --frames ' 2'", "--frames", "[1, 10000000]"},
      {"bench realtime --repeats ' 2'", "--repeats", "[1, 100]"},
      {"bench realtime --sheet ' 12'", "--sheet", "[3, 512]"},
      {"bench accuracy --repeats ' 2'", "--repeats", "[1, 4096]"},
      {"bench accuracy --sizes ' 8'", "--sizes", "[3, 4096]"},
      {"bench accuracy --threads '1 '", "--threads", "[1, 4096]"},
      {"fabric-test cantilever --resolution ' 9'", "--resolution", "[5, 2000]"},
      {"fabric-test cantilever --settle-frames +5", "--settle-frames", "[1, 10000000]"},
      {"ccd-eval " + csv + " --scale-exp ' 3'", "--scale-exp", "[-200, 200]"},
  };
  for (const Row& row : rows) {
    const loom::test::CliResult r = loom::test::run_loom(row.args);
    if (r.err.find("unknown command") != std::string::npos) continue;  // a build without Bullet
    EXPECT_EQ(r.code, row.args.rfind("fabric-test", 0) == 0 ? 1 : 2) << row.args << ": " << r.err;
    EXPECT_NE(r.err.find(row.option), std::string::npos) << row.args << ": " << r.err;
    EXPECT_NE(r.err.find("whole number"), std::string::npos) << row.args << ": " << r.err;
    EXPECT_NE(r.err.find(row.range), std::string::npos) << row.args << ": " << r.err;
    EXPECT_EQ(r.err.find(scene), std::string::npos) << row.args << ": " << r.err;  // not the scene's fault
  }
  // --frames 0 is the same command-line mistake with --resume (a resumed run simulates at least its
  // checkpoint's frame).
  const fs::path out = dir / "ck";
  ASSERT_EQ(
      loom::test::run_loom("run " + scene + " --frames 2 --checkpoint-every 1 --out " + out.string()).code,
      0);
  const loom::test::CliResult r = loom::test::run_loom("run --resume " + out.string() + " --frames 0");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--frames must be >= 1"), std::string::npos) << r.err;
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

// The whole stderr of a refused command: one line of bounded length, however long the value it quotes.
void expect_bounded(const loom::test::CliResult& r, const std::string& what, const std::string& shown) {
  EXPECT_NE(r.code, 0) << what;
  EXPECT_LT(r.err.size(), 1200u) << what << ": " << r.err.substr(0, 2000);
  EXPECT_NE(r.err.find(shown), std::string::npos) << what << ": " << r.err.substr(0, 2000);
}

// Every value echoed back in an error (a cell of a file, a scene string, an option's value, the parser's
// "last read") is cut to its first bytes and its length: a 100,000-digit number makes a line, not 100 KB.
TEST(BadInputCli, ValuesQuotedInErrorsAreBounded) {
  const fs::path dir = loom::test::test_dir();
  const std::string digits(100000, '7');
  fs::create_directories(dir / "vertex-face");
  std::ofstream(dir / "vertex-face" / "long.csv") << digits << ",1,0,1,0,1,0\n";
  expect_bounded(loom::test::run_loom("ccd-eval " + (dir / "vertex-face" / "long.csv").string()), "ccd-eval",
                 "(100000 bytes)/1' is not exactly representable");
  std::ofstream(dir / "scene.json") << kValid;
  const std::string scene = (dir / "scene.json").string(), out = " --out " + (dir / "out").string();
  expect_bounded(loom::test::run_loom("run " + scene + out +
                                      " --set 'cloths[0].material.preset=" + std::string(5000, 'x') + "'"),
                 "preset", "unknown material preset 'xxxx");
  expect_bounded(
      loom::test::run_loom("run " + scene + out + " --set 'solver.method=" + std::string(5000, 'm') + "'"),
      "method", "(5000 bytes)");
  expect_bounded(loom::test::run_loom("run " + scene + out + " --frames " + digits), "--frames",
                 "(100000 bytes)'");
  expect_bounded(loom::test::run_loom("run " + scene + out + " --" + std::string(5000, 'q')),
                 "unknown option", "(5002 bytes)");
  std::ofstream(dir / "open.json") << "{\"name\": \"" << std::string(50000, 'a') << "\n";
  expect_bounded(loom::test::run_loom("run " + (dir / "open.json").string() + out), "last read",
                 "last read: '\"aaaaaaaaaa");
  std::ofstream(dir / "big.json") << "{\"fps\": " << digits << "e9}";
  expect_bounded(loom::test::run_loom("run " + (dir / "big.json").string() + out), "overflow",
                 "(100002 bytes)'");
}

// A list option's entries each run once: an entry given twice (`--sizes 8,8`) is refused naming the option
// and the entry, in every list option of every benchmark (exit 2).
TEST(BadInputCli, ListOptionsRefuseAnEntryGivenTwice) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"bench accuracy --sizes 8,16,8", "--sizes: '8' is listed twice"},
      {"bench accuracy --threads 1,1", "--threads: '1' is listed twice"},
      {"bench accuracy --methods verlet,imex,verlet", "--methods: 'verlet' is listed twice"},
      {"bench accuracy --sizes 8,,16", "--sizes: an empty entry"},
      {"bench realtime --scenes sheet,sheet", "--scenes: 'sheet' is listed twice"},
      {"bench realtime --scenes ,sheet", "--scenes: an empty entry"},
  };
  for (const auto& [args, message] : cases) {
    const loom::test::CliResult r = loom::test::run_loom(args);
    if (r.err.find("unknown command") != std::string::npos) continue;  // a build without Bullet
    EXPECT_EQ(r.code, 2) << args << ": " << r.err;
    EXPECT_NE(r.err.find(message), std::string::npos) << args << ": " << r.err;
  }
}

// A benchmark simulates whole frames of 1/60 s: a duration below one frame is refused naming the option
// (exit 2); another duration runs the nearest whole frames, says so, and the tables quote what ran.
TEST(BadInputCli, BenchmarkDurationsAreWholeFrames) {
  const fs::path dir = loom::test::test_dir();
  for (const std::string args : {"bench accuracy --duration 1e-9", "bench accuracy --quick --duration 0.01",
                                 "bench realtime --seconds 0.001"}) {
    const loom::test::CliResult r = loom::test::run_loom(args);
    if (r.err.find("unknown command") != std::string::npos) return;  // a build without Bullet
    EXPECT_EQ(r.code, 2) << args << ": " << r.err;
    EXPECT_NE(r.err.find(args.find("seconds") != std::string::npos ? "--seconds" : "--duration"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("shorter than one frame of 1/60 s"), std::string::npos) << args << ": " << r.err;
  }
  fs::remove_all(dir / "acc");
  const loom::test::CliResult r = loom::test::run_loom(
      "bench accuracy --quick --methods verlet --threads 1 --duration 0.02 --out " + (dir / "acc").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("--duration 0.02 s is 1.2 frames of 1/60 s: runs 1 whole frames"), std::string::npos)
      << r.err;
  EXPECT_NE(r.out.find("1 frames of 1/60 s"), std::string::npos) << r.out;
}

// An option's value is never the next option nor "-": `--out --frames 5` and `--out -` are refused naming
// the option (exit 2) in every command, and no folder named "--frames" or "-" is made.
TEST(BadInputCli, AnOptionIsNeverTakenAsTheValueOfTheOptionBefore) {
  const fs::path dir = loom::test::test_dir();
  std::ofstream(dir / "scene.json") << kValid;
  const std::string scene = (dir / "scene.json").string();
  const std::string csv =
      std::string(LOOM_TEST_DATA) + "/ccd-sample-queries/erleben-spikes/vertex-face/data_0_0.csv";
  const std::vector<std::pair<std::string, std::vector<std::string>>> commands = {
      {"run " + scene, {"--out", "--frames", "--threads", "--checkpoint-every", "--resume", "--set"}},
      {"compare " + scene, {"--out", "--frames", "--set"}},
      {"bench accuracy",
       {"--sizes", "--out", "--duration", "--threads", "--perturbation", "--methods", "--configs",
        "--repeats"}},
      {"bench realtime", {"--out", "--seconds", "--sheet", "--toy", "--scenes", "--repeats"}},
      {"fabric-test tensile",
       {"--material", "--model", "--resolution", "--overhang-ratio", "--span", "--solver", "--settle-frames",
        "--settle-speed", "--out"}},
      {"ccd-eval " + csv, {"--scale-exp", "--translate", "--min-separation", "--tolerance"}},
      {"body a.zae b.bvh", {"--seconds", "--image"}},
  };
  for (const auto& [command, options] : commands)
    for (const std::string& option : options) {
      const std::string args = command + " " + option + " --overwrite";
      const loom::test::CliResult r = loom::test::run_loom(args);
      if (r.err.find("unknown command") != std::string::npos) break;  // a build without it
      EXPECT_EQ(r.code, 2) << args << ": " << r.err;
      EXPECT_NE(r.err.find(option + ": needs a value; the next argument '--overwrite' is an option"),
                std::string::npos)
          << args << ": " << r.err;
    }
  for (const std::string& args : std::vector<std::string>{
           "run " + scene + " --out -", "run --resume -", "compare " + scene + " --out -",
           "bench accuracy --out -", "bench realtime --out -", "fabric-test tensile --out -",
           "body a.zae b.bvh --image -", "ccd-eval -"}) {
    const loom::test::CliResult r = loom::test::run_loom(args);
    if (r.err.find("unknown command") != std::string::npos) continue;
    EXPECT_EQ(r.code, 2) << args << ": " << r.err;
    EXPECT_NE(r.err.find("'-' (standard input/output) is not a path"), std::string::npos)
        << args << ": " << r.err;
  }
  EXPECT_FALSE(fs::exists("-"));
  EXPECT_FALSE(fs::exists("--overwrite"));
}

// `--opt=value` is `--opt value` for every option of every command; an option that takes no value given one
// is refused; `--` ends the options (a scene named -x.json); options before the benchmark's name are a
// mistake named as such.
TEST(BadInputCli, OptionsTakeValuesAfterEqualsAndDoubleDashEndsThem) {
  const fs::path dir = loom::test::test_dir();
  std::ofstream(dir / "-x.json") << kValid;
  fs::remove_all(dir / "o");
  const std::string cd = "cd '" + dir.string() + "' && " + LOOM_BINARY;
  ASSERT_EQ(std::system((cd + " run --frames=2 --out=o -- -x.json >/dev/null 2>&1").c_str()), 0);
  const auto summary = nlohmann::json::parse(loom::test::slurp(dir / "o" / "summary.json"));
  EXPECT_EQ(summary["frames"].get<int>(), 2);
  EXPECT_NE(std::system((cd + " run -x.json --out=o2 >/dev/null 2>&1").c_str()), 0);  // an unknown option
  EXPECT_FALSE(fs::exists(dir / "o2"));
  const std::string csv =
      std::string(LOOM_TEST_DATA) + "/ccd-sample-queries/erleben-spikes/vertex-face/data_0_0.csv";
  const std::string scene = (dir / "-x.json").string();
  // Every value option in its '=' form, then --help: parsed, accepted, nothing run (exit 0).
  for (const std::string args :
       {"run --out=d --frames=3 --threads=1 --checkpoint-every=2 --set=fps=60 --help",
        "compare --out=d --frames=2 --set=fps=60 --help",
        "bench accuracy --sizes=8 --out=d --duration=0.25 --threads=1 --perturbation=0 --methods=verlet "
        "--configs=x --repeats=1 --help",
        "bench realtime --out=d --seconds=1 --sheet=8 --toy=9 --scenes=sheet --repeats=1 --help",
        "fabric-test --material=cotton --model=springs --resolution=9 --overhang-ratio=2 --span=0.5 "
        "--solver=static --settle-frames=9 --settle-speed=1e-6 --out=d --help",
        "ccd-eval --scale-exp=1 --translate=0 --min-separation=0 --tolerance=1e-6 --help",
        "body --seconds=1 --image=x.png --help"}) {
    const loom::test::CliResult r = loom::test::run_loom(args);
    if (r.err.find("unknown command") != std::string::npos) continue;
    EXPECT_EQ(r.code, 0) << args << ": " << r.err;
  }
  const loom::test::CliResult ccd = loom::test::run_loom("ccd-eval --scale-exp=2 " + csv);
  EXPECT_EQ(ccd.code, 0) << ccd.err;
  EXPECT_NE(ccd.out.find("queries="), std::string::npos);
  for (const auto& [args, message] : std::vector<std::pair<std::string, std::string>>{
           {"run " + scene + " --overwrite=yes", "--overwrite: takes no value (got '--overwrite=yes')"},
           {"fabric-test tensile --json=1", "--json: takes no value"},
           {"run " + scene + " --frames=2 --frames=3", "--frames given twice"},
           {"run " + scene + " --out=", "--out: is an empty string"},
           {"bench --out x accuracy", "name the benchmark before its options"},
           {"bench nosuch", "unknown benchmark 'nosuch'"}}) {
    const loom::test::CliResult r = loom::test::run_loom(args);
    if (r.err.find("unknown command") != std::string::npos) continue;
    EXPECT_EQ(r.code, 2) << args << ": " << r.err;
    EXPECT_NE(r.err.find(message), std::string::npos) << args << ": " << r.err;
  }
}

// A run resumed with another thread count is the run it continues: results are bit-identical for any
// thread count, so --threads is allowed on --resume, and the frames equal an uninterrupted run's byte for
// byte. --census is refused (it counts from frame 0; the checkpoint holds no count).
TEST(BadInputCli, ResumeOnOtherThreadsIsBitIdenticalAndCensusIsRefused) {
  const fs::path dir = loom::test::test_dir();
  std::ofstream(dir / "scene.json") << kValid;
  const std::string run = "run " + (dir / "scene.json").string() +
                          " --set 'cloths[0].mesh.nodes=[24,24]' --set solver.substeps=8 --set duration=0.2";
  for (const char* d : {"straight", "resumed"}) fs::remove_all(dir / d);
  ASSERT_EQ(loom::test::run_loom(run + " --threads 1 --frames 12 --out " + (dir / "straight").string()).code,
            0);
  ASSERT_EQ(loom::test::run_loom(run + " --threads 1 --frames 8 --checkpoint-every 5 --out " +
                                 (dir / "resumed").string())
                .code,
            0);
  const loom::test::CliResult census =
      loom::test::run_loom("run --resume " + (dir / "resumed").string() + " --census");
  EXPECT_EQ(census.code, 2) << census.err;
  EXPECT_NE(census.err.find("--census: not with --resume"), std::string::npos) << census.err;
  const loom::test::CliResult r =
      loom::test::run_loom("run --resume " + (dir / "resumed").string() + " --threads 2 --frames 12");
  ASSERT_EQ(r.code, 0) << r.err;
  for (int f = 6; f <= 12; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", f);
    const std::string a = loom::test::slurp(dir / "straight" / "frames" / name);
    EXPECT_FALSE(a.empty()) << name;
    EXPECT_EQ(a, loom::test::slurp(dir / "resumed" / "frames" / name)) << name;
  }
}

// `loom body` names an operand too many, and MESH and CLIP.bvh given the other way round.
TEST(BadInputCli, BodyNamesTheExtraOperandAndSwappedOperands) {
  const loom::test::CliResult extra = loom::test::run_loom("body a.zae b.bvh c.bvh");
  if (extra.err.find("unknown command") != std::string::npos) GTEST_SKIP() << "no loom::characters";
  EXPECT_EQ(extra.code, 2) << extra.err;
  EXPECT_NE(extra.err.find("a third file 'c.bvh'"), std::string::npos) << extra.err;
  const std::string mesh = std::string(LOOM_TEST_DATA) + "/body/human.zae";
  const std::string clip = std::string(LOOM_TEST_DATA) + "/mocap/01_01.bvh";
  const loom::test::CliResult swapped = loom::test::run_loom("body " + clip + " " + mesh);
  EXPECT_EQ(swapped.code, 2) << swapped.err;
  EXPECT_NE(swapped.err.find("the operands are swapped"), std::string::npos) << swapped.err;
  EXPECT_EQ(swapped.err.find("scale"), std::string::npos) << swapped.err;
}

// The static solver does not settle: fabric-test reports its solves and whether they converged, never
// "0 frames, NOT settled" for a good solve. `loom --help` lists every fabric test of the one table.
TEST(BadInputCli, FabricTestStaticSolveIsReportedAsConverged) {
  const fs::path dir = loom::test::test_dir();
  fs::remove_all(dir / "t");
  const loom::test::CliResult r =
      loom::test::run_loom("fabric-test tensile --resolution 9 --json --out " + (dir / "t").string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["settled"].is_null());
  EXPECT_TRUE(j["settle_frames"].is_null());
  EXPECT_TRUE(j["converged"].get<bool>());
  EXPECT_GE(j["static_solves"].get<int>(), 3);  // one per pull at least
  const loom::test::CliResult text =
      loom::test::run_loom("fabric-test tensile --resolution 9 --overwrite --out " + (dir / "t").string());
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_EQ(text.out.find("NOT"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("solver static: converged in"), std::string::npos) << text.out;
  const std::string help = loom::test::run_loom("--help").out;
  for (const char* test : {"cantilever", "tensile", "shear", "catenary", "drape"})
    EXPECT_NE(help.find(test), std::string::npos) << test;
  EXPECT_NE(loom::test::run_loom("fabric-test --help").out.find("{cantilever,tensile,shear,catenary,drape}"),
            std::string::npos);
}

}  // namespace

// --set without PATH= is a malformed option like any other: exit 2, naming --set, before the scene is read.
TEST(BadInputCli, ASetWithoutPathIsAMalformedOption) {
  const fs::path dir = loom::test::test_dir();
  std::ofstream(dir / "scene.json") << kValid;
  for (const std::string set : {"--set=", "--set=x", "--set '=1'", "--set 'a b'"}) {
    fs::remove_all(dir / "o9");
    const loom::test::CliResult r = loom::test::run_loom("run '" + (dir / "scene.json").string() + "' " +
                                                         set + " --out '" + (dir / "o9").string() + "'");
    EXPECT_EQ(r.code, 2) << set << ": " << r.err;
    EXPECT_NE(r.err.find("--set: expected PATH=VALUE"), std::string::npos) << set << ": " << r.err;
    EXPECT_FALSE(fs::exists(dir / "o9")) << set;
  }
}

// A collider that starts through the cloth is warned about in every tier, also when it is thinner than the
// cloth's edges (a 4 cm cylinder across a sheet with 6 cm between its rows passes between its vertices).
TEST(BadInputCli, AColliderStartingThroughTheClothIsWarnedAboutInEveryTier) {
  const fs::path dir = loom::test::test_dir();
  for (const std::string tier : {"balanced", "realtime", "reference"}) {
    std::ofstream(dir / "scene.json") << R"({"name": "bt", "duration": 0.02, "fps": 60, "quality": ")" << tier
                                      << R"(", "cloths": [{"name": "sheet", "mesh": {"type": "grid",
      "size": [1, 1], "nodes": [17, 17], "plane": "xz", "origin": [-0.5, 0.5, -0.5]},
      "material": {"preset": "cotton"}, "mass": 0.2, "pins": [{"grid": [0, 0]}, {"grid": [-1, -1]}]}],
      "colliders": [{"shape": "cylinder", "radius": 0.02, "half_height": 0.6, "position": [0, 0.5, 0.03],
                     "rotation": {"axis": [0, 0, 1], "degrees": 90}, "thickness": 0.001, "name": "c"}]})";
    fs::remove_all(dir / "o");
    const loom::test::CliResult r = loom::test::run_loom("run '" + (dir / "scene.json").string() +
                                                         "' --frames 1 --out '" + (dir / "o").string() + "'");
    EXPECT_NE(r.err.find("warning: " + (dir / "scene.json").string() +
                         ": cloths[0] starts inside colliders[0] 'c' or its thickness (its edge between "
                         "vertices"),
              std::string::npos)
        << tier << ": " << r.err;
  }
}
