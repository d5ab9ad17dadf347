// COLLADA counts assimp's reader trusts (array counts, accessor count/stride/offset, <input> offsets, the
// <vcount>, <p> and <v> index lists, a skin's joints and weights): a file that breaks one is refused by a
// loom::Error naming the file, the line and the element before assimp reads it, where assimp would read
// out of bounds (SIGSEGV), fail an assertion (SIGABRT) or, for an index that is not a number, allocate
// without end. Each row mutates a small skinned, animated box that loads.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "CharacterTestUtil.h"
#include "HostileFiles.h"
#include "loom/characters/Motion.h"
#include "loom/characters/SkinnedMesh.h"
#include "loom/cloth/Error.h"

namespace {

using loom::test::error_of;

// A box of 8 vertices skinned to two joints (root, tip) and a two-key animation of the tip.
const std::string kBox = R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset><unit name="meter" meter="1"/><up_axis>Y_UP</up_axis></asset>
<library_geometries><geometry id="box" name="box"><mesh>
<source id="box-pos">
<float_array id="box-pos-array" count="24">-1 -1 -1 1 -1 -1 1 1 -1 -1 1 -1 -1 -1 1 1 -1 1 1 1 1 -1 1
1</float_array>
<technique_common><accessor source="#box-pos-array" count="8" stride="3">
<param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
</accessor></technique_common></source>
<source id="box-nrm">
<float_array id="box-nrm-array" count="18">0 0 -1 0 0 1 0 -1 0 0 1 0 -1 0 0 1 0 0</float_array>
<technique_common><accessor source="#box-nrm-array" count="6" stride="3">
<param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
</accessor></technique_common></source>
<vertices id="box-vtx"><input semantic="POSITION" source="#box-pos"/></vertices>
<polylist count="6"><input semantic="VERTEX" source="#box-vtx" offset="0"/>
<input semantic="NORMAL" source="#box-nrm" offset="1"/>
<vcount>4 4 4 4 4 4</vcount>
<p>0 0 3 0 2 0 1 0 4 1 5 1 6 1 7 1 0 2 1 2 5 2 4 2 3 3 7 3 6 3 2 3 0 4 4 4 7 4 3 4
1 5 2 5 6 5 5 5</p></polylist>
</mesh></geometry></library_geometries>
<library_controllers><controller id="skin"><skin source="#box">
<bind_shape_matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</bind_shape_matrix>
<source id="skin-joints"><Name_array id="skin-joints-array" count="2">root tip</Name_array>
<technique_common><accessor source="#skin-joints-array" count="2" stride="1">
<param name="JOINT" type="name"/></accessor></technique_common></source>
<source id="skin-poses">
<float_array id="skin-poses-array" count="32">1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1
1 0 0 0 0 1 0 -1 0 0 1 0 0 0 0 1</float_array>
<technique_common><accessor source="#skin-poses-array" count="2" stride="16">
<param name="TRANSFORM" type="float4x4"/></accessor></technique_common></source>
<source id="skin-weights"><float_array id="skin-weights-array" count="2">1 0.5</float_array>
<technique_common><accessor source="#skin-weights-array" count="2" stride="1">
<param name="WEIGHT" type="float"/></accessor></technique_common></source>
<joints><input semantic="JOINT" source="#skin-joints"/>
<input semantic="INV_BIND_MATRIX" source="#skin-poses"/></joints>
<vertex_weights count="8"><input semantic="JOINT" source="#skin-joints" offset="0"/>
<input semantic="WEIGHT" source="#skin-weights" offset="1"/>
<vcount>1 1 1 1 2 2 1 1</vcount>
<v>0 0 0 0 0 0 0 0 0 0 1 1 0 1 1 1 1 0 1 0</v></vertex_weights>
</skin></controller></library_controllers>
<library_animations><animation id="anim">
<source id="anim-t"><float_array id="anim-t-array" count="2">0 1</float_array><technique_common>
<accessor source="#anim-t-array" count="2" stride="1"><param name="TIME" type="float"/></accessor>
</technique_common></source>
<source id="anim-m"><float_array id="anim-m-array" count="32">1 0 0 0 0 1 0 1 0 0 1 0 0 0 0 1 1 0 0
0 0 1 0 1.5 0 0 1 0 0 0 0 1</float_array><technique_common>
<accessor source="#anim-m-array" count="2" stride="16"><param name="TRANSFORM" type="float4x4"/>
</accessor></technique_common></source>
<sampler id="anim-s"><input semantic="INPUT" source="#anim-t"/>
<input semantic="OUTPUT" source="#anim-m"/></sampler>
<channel source="#anim-s" target="tip/transform"/>
</animation></library_animations>
<library_visual_scenes><visual_scene id="scene">
<node id="root" sid="root" name="root" type="JOINT">
<matrix sid="transform">1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</matrix>
<node id="tip" sid="tip" name="tip" type="JOINT">
<matrix sid="transform">1 0 0 0 0 1 0 1 0 0 1 0 0 0 0 1</matrix></node></node>
<node id="body" name="body"><instance_controller url="#skin"><skeleton>#root</skeleton>
</instance_controller></node>
</visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
)";

struct Mutation {
  std::vector<std::pair<std::string, std::string>> edits;  // (text of kBox, its replacement), in order
  std::string anchor;   // text of the mutated file on the line the error names
  std::string problem;  // the message after "FILE: line N: "
};

std::string mutate(const Mutation& m) {
  std::string text = kBox;
  for (const auto& [from, to] : m.edits) {
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
  }
  return text;
}

std::string line_of(const std::string& text, const std::string& anchor) {
  const std::size_t at = text.find(anchor);
  EXPECT_NE(at, std::string::npos) << anchor;
  return "line " +
         std::to_string(1 + std::count(text.begin(), text.begin() + long(std::min(at, text.size())), '\n'));
}

const std::vector<Mutation>& mutations() {
  static const std::vector<Mutation> rows = {
      // A document type whose internal subset quotes a bracket would hide the rest of the file from a scan
      // that counts brackets (and what follows it, a broken index list, would reach assimp).
      {{{"?>\n", "?>\n<!DOCTYPE COLLADA [ <!ENTITY e \"[\"> ]>\n"}, {"<p>0 0 3", "<p>x 0 3"}},
       "<!DOCTYPE",
       "'<!DOCTYPE': a markup declaration (a document type or an entity); COLLADA files have none"},
      {{{"<library_geometries>", "<!ENTITY e \"x\"><library_geometries>"}},
       "<!ENTITY",
       "'<!ENTITY': a markup declaration"},
      // Index lists: a token that is not a whole number (assimp's reader would push zeros without end).
      {{{"<p>0 0 3", "<p>x 0 3"}}, "<p>x", "<p>: 'x' is not an index (a whole number >= 0)"},
      {{{"<p>0 0 3", "<p>1e 0 3"}}, "<p>1e", "<p>: '1e' is not an index (a whole number >= 0)"},
      {{{"<p>0 0 3", "<p>-1 0 3"}}, "<p>-1", "<p>: '-1' is not an index (a whole number >= 0)"},
      {{{"<vcount>4 4 4 4 4 4", "<vcount>4 4 4 4 4 n"}},
       "<vcount>4",
       "<vcount>: 'n' is not a face's vertex count, a whole number >= 1"},
      // A face of no vertices (refused before the sum is compared with <p>) made the triangulation assert.
      {{{"<vcount>4 4 4 4 4 4", "<vcount>4 4 4 4 4 0"}},
       "<vcount>4",
       "<vcount>: '0' is not a face's vertex count, a whole number >= 1"},
      {{{"0 1 1 1 1 0 1 0</v>", "0 1 1 1 1 0 1 x</v>"}},
       "<v>",
       "<v>: 'x' is not an index (a whole number >= 0)"},
      // Arrays: count missing, out of range, or not the number of values; values not of the array's type.
      {{{"count=\"24\"", "count=\"0\""}},
       "box-pos-array",
       "<float_array id=\"box-pos-array\" count=\"0\"> holds 24 values"},
      {{{"count=\"32\">1 0 0 0 0 1 0 0", "count=\"16\">1 0 0 0 0 1 0 0"}},
       "skin-poses-array",
       "<float_array id=\"skin-poses-array\" count=\"16\"> holds 32 values"},
      {{{"<float_array id=\"box-nrm-array\" count=\"18\">", "<float_array id=\"box-nrm-array\">"}},
       "box-nrm-array",
       "<float_array>: the count attribute is missing"},
      {{{"count=\"18\"", "count=\"4294967296\""}},
       "box-nrm-array",
       "<float_array> count=\"4294967296\": not a whole number from 0 to 4294967295"},
      {{{"count=\"18\"", "count=\"-1\""}}, "box-nrm-array", "<float_array> count=\"-1\": not a whole number"},
      {{{"1 0.5</float_array>", "1 0.5x</float_array>"}},
       "0.5x",
       "<float_array>: '0.5x' is not a finite number"},
      {{{"1 0.5</float_array>", "1 nan</float_array>"}},
       "1 nan",
       "<float_array>: 'nan' is not a finite number"},
      {{{"count=\"2\">root tip", "count=\"3\">root tip"}},
       "root tip",
       "<Name_array id=\"skin-joints-array\" count=\"3\"> holds 2 values"},
      {{{"count=\"2\">0 1</float_array>", "count=\"2\">0 <!-- a comment --> 1</float_array>"}},
       "anim-t-array",
       "<float_array> holds markup or is not closed"},
      // Accessors: stride, count and offset read within the array (checked by division: no wrap).
      {{{"count=\"8\" stride=\"3\"", "count=\"8\" stride=\"2147483648\""}},
       "#box-pos-array\"",
       "<accessor> stride=\"2147483648\": not a whole number from 0 to 1024"},
      {{{"count=\"8\" stride=\"3\"", "count=\"8\" stride=\"0\""}},
       "#box-pos-array\"",
       "<accessor> stride=\"0\": the stride is at least 1"},
      {{{"count=\"8\" stride=\"3\"", "count=\"9\" stride=\"3\""}},
       "#box-pos-array\"",
       "<accessor source=\"#box-pos-array\" count=\"9\" stride=\"3\" offset=\"0\"> reads past the 24 values"},
      {{{"count=\"8\" stride=\"3\"", "count=\"8\" stride=\"3\" offset=\"4294967295\""}},
       "#box-pos-array\"",
       "<accessor source=\"#box-pos-array\" count=\"8\" stride=\"3\" offset=\"4294967295\"> reads past"},
      {{{"count=\"8\" stride=\"3\"", "count=\"1431655766\" stride=\"3\""}},
       "#box-pos-array\"",
       "<accessor source=\"#box-pos-array\" count=\"1431655766\" stride=\"3\" offset=\"0\"> reads past the "
       "24 "
       "values"},
      {{{"source=\"#box-nrm-array\"", "source=\"#nothing\""}},
       "#nothing",
       "<accessor source=\"#nothing\">: no array"},
      {{{"source=\"#anim-t-array\" count=\"2\" stride=\"1\"",
         "source=\"#anim-t-array\" count=\"2\" stride=\"3\""}},
       "#anim-t-array\"",
       "<accessor source=\"#anim-t-array\" count=\"2\" stride=\"3\" offset=\"0\"> reads past"},
      {{{"<accessor source=\"#anim-m-array\" count=\"2\" stride=\"16\">",
         "<accessor source=\"#anim-m-array\" count=\"4\" stride=\"8\">"}},
       "#anim-m-array\"",
       "<accessor source=\"#anim-m-array\">: its <param>s read 16 values per element but stride is 8"},
      // <input> offsets and sets.
      {{{"source=\"#box-nrm\" offset=\"1\"", "source=\"#box-nrm\" offset=\"4294967295\""}},
       "offset=\"4294967295\"",
       "<input> offset=\"4294967295\": not a whole number from 0 to 255"},
      {{{"source=\"#box-nrm\" offset=\"1\"", "source=\"#box-nrm\" offset=\"1\" set=\"65536\""}},
       "set=\"65536\"",
       "<input> set=\"65536\": not a whole number from 0 to 255"},
      // Primitives: <vcount> and <p> against count and the inputs; indices against the accessors.
      {{{"<polylist count=\"6\">", "<polylist count=\"7\">"}},
       "<vcount>",
       "<vcount> holds 6 values but its <polylist> has count=\"7\""},
      {{{"<vcount>4 4 4 4 4 4", "<vcount>4 4 4 4 4 5"}},
       "<p>0",
       "<p> holds 48 indices; the <vcount> sum 25 x 2 inputs needs 50"},
      {{{"<polylist count=\"6\">", "<triangles count=\"12\">"},
        {"<vcount>4 4 4 4 4 4</vcount>\n", ""},
        {"</polylist>", "</triangles>"}},
       "<p>0",
       "<p> holds 48 indices; count 12 x 3 vertices x 2 inputs needs 72"},
      {{{"6 5 5 5</p>", "6 5 5 6</p>"}},
       "<polylist",
       "index 6 read through <input semantic=\"NORMAL\" offset=\"1\"> is past the 6 elements of source "
       "#box-nrm"},
      {{{"6 5 5 5</p>", "6 5 8 5</p>"}},
       "<polylist",
       "index 8 read through <input semantic=\"VERTEX\" offset=\"0\"> is past the 8 elements of source "
       "#box-pos"},
      {{{"<input semantic=\"VERTEX\" source=\"#box-vtx\" offset=\"0\"/>",
         "<input semantic=\"POSITION\" source=\"#box-pos\" offset=\"0\"/>"}},
       "<polylist",
       "<polylist> has indices but no <input semantic=\"VERTEX\">"},
      {{{"<input semantic=\"VERTEX\" source=\"#box-vtx\"", "<input semantic=\"VERTEX\" source=\"#box-pos\""}},
       "semantic=\"VERTEX\"",
       "<input semantic=\"VERTEX\" source=\"#box-pos\">: not the <vertices> of its <mesh>"},
      // Skins: the bind shape matrix, the inverse bind matrices per joint, the weights per vertex.
      {{{"<bind_shape_matrix>1 0 0 0", "<bind_shape_matrix>0 0 0"}},
       "<bind_shape_matrix>",
       "<bind_shape_matrix> holds 15 numbers (16)"},
      {{{"<accessor source=\"#skin-poses-array\" count=\"2\"",
         "<accessor source=\"#skin-poses-array\" count=\"1\""}},
       "#skin-poses-array\"",
       "<accessor> of the inverse bind matrices (count 1, stride 16) does not hold a 4x4 matrix for each of "
       "the 2 joints"},
      {{{"<vertex_weights count=\"8\">", "<vertex_weights count=\"7\">"},
        {"<vcount>1 1 1 1 2 2 1 1</vcount>", "<vcount>1 1 1 1 2 2 1</vcount>"},
        {"1 1 1 0 1 0</v>", "1 1 1 0</v>"}},
       "<vertex_weights",
       "<vertex_weights count=\"7\">: the skinned mesh #box indexes vertex 7"},
      {{{"<vertex_weights count=\"8\">", "<vertex_weights count=\"7\">"}},
       "<vcount>1",
       "<vcount> holds 8 values but its <vertex_weights> has count=\"7\""},
      {{{"1 1 1 0 1 0</v>", "1 1 1 0 2 0</v>"}}, "<v>", "<v>: joint index 2 is past the 2 joints"},
      {{{"1 1 1 0 1 0</v>", "1 1 1 0 1 2</v>"}},
       "<v>",
       "<v>: weight index 2 is past the 2 weights of source #skin-weights"},
      {{{"1 1 1 0 1 0</v>", "1 1 1 0 1</v>"}},
       "<v>",
       "<v> holds 19 indices; the <vcount> sum 10 x 2 inputs needs 20"},
      // Animation: the values per key fit the transform the channel targets.
      {{{"target=\"tip/transform\"", "target=\"tip/transform(3)(3)\""}},
       "<channel",
       "<channel target=\"tip/transform(3)(3)\">: its OUTPUT source #anim-m holds 16 values per key"},
      // A rotation's ANGLE keys: assimp samples every 90 degrees turned between two keys.
      {{{"<node id=\"tip\" sid=\"tip\" name=\"tip\" type=\"JOINT\">\n",
         "<node id=\"tip\" sid=\"tip\" name=\"tip\" type=\"JOINT\">\n<rotate sid=\"rz\">0 0 1 0</rotate>\n"},
        {"target=\"tip/transform\"", "target=\"tip/rz.ANGLE\""},
        {"<source id=\"anim-m\">",
         "<source id=\"anim-a\"><float_array id=\"anim-a-array\" count=\"2\">0 "
         "1e9</float_array><technique_common>"
         "<accessor source=\"#anim-a-array\" count=\"2\"><param name=\"ANGLE\" type=\"float\"/></accessor>"
         "</technique_common></source>\n<source id=\"anim-m\">"},
        {"<input semantic=\"OUTPUT\" source=\"#anim-m\"/>",
         "<input semantic=\"OUTPUT\" source=\"#anim-a\"/>"}},
       "<channel",
       "<channel target=\"tip/rz.ANGLE\">: its angles turn 1e+09 degrees, sampled every 90 degrees"},
  };
  return rows;
}

// The box loads; every mutation is refused naming the file, the line and the element (as a body mesh and
// as a motion clip) before assimp reads it.
TEST(HostileCollada, BrokenCountsAreRefusedByLineAndElement) {
  const std::string base = loom::test::write_test_file("box.dae", kBox);
  EXPECT_EQ(error_of([&] { loom::characters::load_skinned_mesh(base); }), "");
  EXPECT_EQ(error_of([&] { loom::characters::Motion::load(base); }), "");
  const auto& rows = mutations();
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const std::string text = mutate(rows[k]);
    const std::string path = loom::test::write_test_file("box_" + std::to_string(k) + ".dae", text);
    const std::string want = path + ": " + line_of(text, rows[k].anchor) + ": " + rows[k].problem;
    std::string e = error_of([&] { loom::characters::load_skinned_mesh(path); });
    EXPECT_NE(e.find(want), std::string::npos) << "row " << k << "\n  got:  " << e << "\n  want: " << want;
    e = error_of([&] { loom::characters::Motion::load(path); });
    EXPECT_NE(e.find(want), std::string::npos) << "row " << k << "\n  got:  " << e << "\n  want: " << want;
  }
}

// Inside a .zae (stored and deflated) the same refusals name the archive and the entry.
TEST(HostileCollada, BrokenCountsInsideAnArchiveAreRefusedByEntry) {
  const auto& rows = mutations();
  for (bool deflated : {false, true})
    for (std::size_t k : {std::size_t(0), std::size_t(5), std::size_t(33)}) {
      const std::string text = mutate(rows[k]);
      const std::string path =
          loom::test::write_test_file("box_" + std::to_string(k) + (deflated ? "_d" : "_s") + ".zae",
                                      loom::test::zip({{"model.dae", text}}, 0, deflated));
      const std::string want =
          path + ": model.dae: " + line_of(text, rows[k].anchor) + ": " + rows[k].problem;
      const std::string e = error_of([&] { loom::characters::load_skinned_mesh(path); });
      EXPECT_NE(e.find(want), std::string::npos) << "row " << k << "\n  got:  " << e << "\n  want: " << want;
    }
}

// Counts that agree with each other can still ask for far more than the file holds: a skin of many joints
// over a mesh of many primitives (assimp keeps a weight list per joint for each primitive's mesh).
TEST(HostileCollada, CountsImplyingFarMoreThanTheFileAreRefused) {
  std::string text = kBox;
  std::string names, poses;
  const int joints = 20000, primitives = 2000;
  for (int j = 0; j < joints; ++j) {
    names += (j ? " j" : "j") + std::to_string(j);
    poses += j ? " 1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1" : "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1";
  }
  auto replace = [&](const std::string& from, const std::string& to) {
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  };
  replace("count=\"2\">root tip", "count=\"" + std::to_string(joints) + "\">" + names);
  replace("<accessor source=\"#skin-joints-array\" count=\"2\"",
          "<accessor source=\"#skin-joints-array\" count=\"" + std::to_string(joints) + "\"");
  replace("count=\"32\">1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n1 0 0 0 0 1 0 -1 0 0 1 0 0 0 0 1",
          "count=\"" + std::to_string(16 * joints) + "\">" + poses);
  replace("<accessor source=\"#skin-poses-array\" count=\"2\"",
          "<accessor source=\"#skin-poses-array\" count=\"" + std::to_string(joints) + "\"");
  std::string triangles;
  for (int p = 0; p < primitives; ++p)
    triangles +=
        "<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#box-vtx\" offset=\"0\"/><p>0 1 2</p>"
        "</triangles>\n";
  replace("</mesh>", triangles + "</mesh>");
  const std::string path = loom::test::write_test_file("many_joints.dae", text);
  const std::string e = error_of([&] { loom::characters::load_skinned_mesh(path); });
  EXPECT_NE(e.find(path + ": its counts imply "), std::string::npos) << e;
  EXPECT_NE(e.find("values, indices and joint lists, more than "), std::string::npos) << e;
}

}  // namespace
