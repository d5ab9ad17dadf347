// Node graphs and nesting that assimp's readers would expand or recurse over without bound (COLLADA
// <instance_node> cycles and doubling chains, glTF nodes with two parents, FBX nested deeper than the
// reader's stack): each is refused by a loom::Error naming the file and the line, node or byte, before
// assimp reads the file.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <string>

#include "CharacterTestUtil.h"
#include "HostileFiles.h"
#include "TestDir.h"
#include "loom/characters/Motion.h"
#include "loom/characters/SkinnedMesh.h"
#include "loom/cloth/Error.h"

namespace {

using loom::characters::Motion;
using loom::test::error_of;

std::string write(const std::string& name, const std::string& text) {
  return loom::test::write_test_file(name, text);
}

// A cycle of instanced nodes (and a node instancing itself) would make assimp recurse until the stack
// overflows: refused naming the line of the <instance_node> that closes it and the nodes on it.
TEST(HostileGraphs, ColladaInstanceNodeCyclesAreRefusedByNode) {
  const std::string cycle = write("cycle.dae", loom::test::collada_instances(2, 1, true));
  std::string e = error_of([&] { Motion::load(cycle); });
  EXPECT_NE(e.find(cycle + ": line 6: node 'N2': <instance_node url=\"#N0\"> makes an instance_node cycle "
                           "('N0' -> 'N1' -> 'N2' -> 'N0')"),
            std::string::npos)
      << e;
  const std::string self = write("self.dae", loom::test::collada_instances(0, 1, true));
  e = error_of([&] { Motion::load(self); });
  EXPECT_NE(e.find(self + ": line 4: node 'N0': <instance_node url=\"#N0\"> makes an instance_node cycle "
                          "('N0' -> 'N0')"),
            std::string::npos)
      << e;
  // As a body mesh: the same refusal.
  e = error_of([&] { loom::characters::load_skinned_mesh(cycle); });
  EXPECT_NE(e.find(cycle + ": line 6: node 'N2'"), std::string::npos) << e;
  // A chain that instances each node once is no cycle.
  e = error_of([&] { Motion::load(write("chain.dae", loom::test::collada_instances(6, 1))); });
  EXPECT_EQ(e.find("instance_node"), std::string::npos) << e;
}

// The same graphs packed in a .zae (stored and deflated) are refused naming the archive and the entry.
TEST(HostileGraphs, ColladaInstanceGraphsInsideAnArchiveAreRefusedByEntry) {
  for (const bool deflated : {false, true}) {
    const std::string cycle =
        write(deflated ? "cycle_z.zae" : "cycle_s.zae",
              loom::test::zip({{"model.dae", loom::test::collada_instances(2, 1, true)}}, 0, deflated));
    std::string e = error_of([&] { Motion::load(cycle); });
    EXPECT_NE(e.find(cycle + ": model.dae: line 6: node 'N2'"), std::string::npos) << e;
    EXPECT_NE(e.find("makes an instance_node cycle"), std::string::npos) << e;
    const std::string bomb =
        write(deflated ? "bomb_z.zae" : "bomb_s.zae",
              loom::test::zip({{"model.dae", loom::test::collada_instances(24, 2)}}, 0, deflated));
    e = error_of([&] { Motion::load(bomb); });
    EXPECT_NE(e.find(bomb + ": model.dae: line 29: node 'Hips': with its <instance_node> copies the scene "
                            "expands to more than 1000000 nodes"),
              std::string::npos)
        << e;
  }
}

// Nodes that each instance the next twice expand to 2^levels nodes (24 levels: 16.7 million): the
// expanded count is computed on the instancing graph and refused past a million, naming the scene's root.
TEST(HostileGraphs, ColladaInstanceNodeBombsAreRefusedByExpandedCount) {
  const std::string bomb = write("bomb.dae", loom::test::collada_instances(24, 2));
  const std::string problem =
      bomb +
      ": line 29: node 'Hips': with its <instance_node> copies the scene expands to more than "
      "1000000 nodes";
  std::string e = error_of([&] { Motion::load(bomb); });
  EXPECT_NE(e.find(problem), std::string::npos) << e;
  e = error_of([&] { loom::characters::load_skinned_mesh(bomb); });
  EXPECT_NE(e.find(problem), std::string::npos) << e;
  // 2^19 + ... < 1e6 nodes: not refused by the count (assimp reads it; the names repeat).
  e = error_of([&] { Motion::load(write("small_bomb.dae", loom::test::collada_instances(8, 2))); });
  EXPECT_EQ(e.find("expands to more than"), std::string::npos) << e;
  EXPECT_NE(e.find("the name is given twice"), std::string::npos) << e;
}

// glTF gives every node one parent at most: a node listed by two parents (which assimp copies per parent,
// doubling per level), listed twice by one, or its own ancestor is refused by its nodes[] entry; scenes
// whose roots expand past a million nodes by scenes[k].nodes.
TEST(HostileGraphs, GltfNodesWithTwoParentsOrCyclesAreRefused) {
  const std::string dag = write("dag.gltf", loom::test::gltf_two_parents(25));
  std::string e = error_of([&] { Motion::load(dag); });
  EXPECT_NE(e.find(dag + ": nodes[2].children: nodes[3] is already a child of nodes[1] (a glTF node has at "
                         "most one parent"),
            std::string::npos)
      << e;
  const std::string twice = write(
      "twice.gltf", "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"children\":[1,1]},{\"name\":\"a\"}]}");
  e = error_of([&] { Motion::load(twice); });
  EXPECT_NE(e.find(twice + ": nodes[0].children: lists nodes[1] twice"), std::string::npos) << e;
  const std::string loop = write("loop.gltf",
                                 "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"children\":[1]},{"
                                 "\"children\":[2]},{\"children\":[0]}]}");
  e = error_of([&] { Motion::load(loop); });
  EXPECT_NE(e.find(loop + ": nodes[0]: the node is its own ancestor"), std::string::npos) << e;
  // A 1001-node chain listed 1000 times as a scene root: 1,001,000 nodes once copied.
  std::string nodes;
  for (int k = 0; k < 1001; ++k)
    nodes += std::string(k ? "," : "") + "{" +
             (k < 1000 ? "\"children\":[" + std::to_string(k + 1) + "]" : "") + "}";
  std::string roots;
  for (int k = 0; k < 1000; ++k) roots += std::string(k ? "," : "") + "0";
  const std::string many = write("many.gltf", "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[" +
                                                  roots + "]}],\"nodes\":[" + nodes + "]}");
  e = error_of([&] { Motion::load(many); });
  EXPECT_NE(e.find(many + ": scenes[0].nodes: the scene's root nodes expand to more than 1000000 nodes"),
            std::string::npos)
      << e;
  // A tree (each node one parent) is not refused by these checks.
  e = error_of([&] { Motion::load(write("tree.gltf", loom::test::gltf_two_parents(0))); });
  EXPECT_EQ(e.find("parent"), std::string::npos) << e;
  EXPECT_EQ(e.find("expand"), std::string::npos) << e;
}

// The glTF node check reads the document as assimp's reader does or refuses it: bytes that are not UTF-8
// (assimp's reader passes them, a strict one stops) and a key given twice in one object (readers differ on
// which counts: a bomb under the one the check does not read) are refused before assimp reads the file.
TEST(HostileGraphs, GltfTheNodeCheckCannotReadIsRefused) {
  const std::string dag = loom::test::gltf_two_parents(30);  // refused as it is: nodes with two parents
  std::string e = error_of([&] { Motion::load(write("dag.gltf", dag)); });
  EXPECT_NE(e.find("is already a child of"), std::string::npos) << e;
  std::string utf = dag;
  utf.replace(utf.find("\"2.0\""), 5, "\"2.0\xff\xfe\"");
  const std::string utf_path = write("dag_utf8.gltf", utf);
  e = error_of([&] { Motion::load(utf_path); });
  EXPECT_NE(e.find(utf_path + ": not JSON Loom can check before reading it"), std::string::npos) << e;
  EXPECT_NE(e.find("ill-formed UTF-8"), std::string::npos) << e;
  // The bomb first, a harmless node list last: one reader takes each.
  std::string dup = dag;
  dup.insert(dup.size() - 2, ",\"nodes\":[{\"name\":\"Hips\"}]");
  const std::string dup_path = write("dag_dup.gltf", dup);
  e = error_of([&] { Motion::load(dup_path); });
  EXPECT_NE(e.find(dup_path + ": the key 'nodes' is given twice in one object"), std::string::npos) << e;
  // In a nested object too (a node's children given twice), after objects whose ends the parser's
  // callback is not told.
  std::string nested = loom::test::gltf_two_parents(0);
  nested.replace(nested.find("\"children\":[1,2]"), 16, "\"children\":[1],\"children\":[2]");
  const std::string nested_path = write("nested_dup.gltf", nested);
  e = error_of([&] { Motion::load(nested_path); });
  EXPECT_NE(e.find(nested_path + ": the key 'children' is given twice in one object"), std::string::npos)
      << e;
}

// FBX scopes nested a million deep made assimp's reader overflow its stack: ASCII braces (outside strings
// and comments) are refused by line past 512, binary node records by byte offset; a record whose end
// offset points past the file is refused by its offset.
TEST(HostileGraphs, DeeplyNestedFbxIsRefusedBeforeAssimpReadsIt) {
  const std::string ascii = write("deep.fbx", loom::test::ascii_fbx(100000));
  std::string e = error_of([&] { Motion::load(ascii); });
  EXPECT_NE(e.find(ascii + ": line 515: FBX scopes ('{') nest more than 512 levels deep"), std::string::npos)
      << e;
  e = error_of([&] { loom::characters::load_skinned_mesh(ascii); });
  EXPECT_NE(e.find(ascii + ": line 515: FBX scopes"), std::string::npos) << e;
  e = error_of([&] { Motion::load(write("shallow.fbx", loom::test::ascii_fbx(512))); });
  EXPECT_EQ(e.find("nest more than"), std::string::npos) << e;
  // A comment ends where assimp's tokenizer ends it (CR, LF, FF, NUL): a file of CR line ends, or a first
  // comment ended by a form feed, is scanned all the same.
  for (const char end : {'\r', '\f'}) {
    std::string text = loom::test::ascii_fbx(100000);
    if (end == '\r')
      std::replace(text.begin(), text.end(), '\n', '\r');
    else
      text[text.find('\n')] = '\f';
    const std::string path = write(end == '\r' ? "deep_cr.fbx" : "deep_ff.fbx", text);
    e = error_of([&] { Motion::load(path); });
    EXPECT_NE(e.find(path + ": line "), std::string::npos) << e;
    EXPECT_NE(e.find("FBX scopes ('{') nest more than 512 levels deep"), std::string::npos) << e;
  }

  const std::string binary = write("deep_binary.fbx", loom::test::binary_fbx(100000));
  e = error_of([&] { Motion::load(binary); });
  EXPECT_NE(e.find(binary + ": byte 7195: FBX node records nest more than 512 levels deep"),
            std::string::npos)
      << e;
  // Assimp reads a file as binary FBX by its first 18 bytes: the check does too.
  std::string magic = loom::test::binary_fbx(100000);
  magic.replace(18, 2, "XY");
  const std::string magic_path = write("deep_magic.fbx", magic);
  e = error_of([&] { Motion::load(magic_path); });
  EXPECT_NE(e.find(magic_path + ": byte 7195: FBX node records nest more than 512 levels deep"),
            std::string::npos)
      << e;
  const std::string shallow = write("shallow_binary.FBX", loom::test::binary_fbx(100));
  e = error_of([&] { Motion::load(shallow); });
  EXPECT_EQ(e.find("nest more than"), std::string::npos) << e;
  EXPECT_EQ(e.find("FBX node record"), std::string::npos) << e;
  const std::string past = write("past_end.fbx", loom::test::binary_fbx(3, true));
  e = error_of([&] { Motion::load(past); });
  EXPECT_NE(e.find(past + ": byte 27: FBX node record: end offset 4294967280 is out of range"),
            std::string::npos)
      << e;
}

}  // namespace
