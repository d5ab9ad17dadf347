// Hostile files handed to assimp (a clip or a body mesh): each is refused by a loom::Error naming the file
// and what is wrong, before or after assimp reads it, never by a crash, a hang or unbounded memory.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "../../characters/src/AssimpInput.h"  // the import's XML depth scan (private header)
#include "CharacterTestUtil.h"
#include "HostileFiles.h"
#include "TestDir.h"
#include "loom/characters/Motion.h"
#include "loom/characters/SkinnedMesh.h"
#include "loom/cloth/Error.h"

namespace {

using loom::characters::Motion;
using loom::characters::MotionSettings;
using loom::test::deep_collada;
using loom::test::error_of;
using loom::test::zip;

std::string write(const std::string& name, const std::string& text) {
  return loom::test::write_test_file(name, text);
}

// assimp reads a RAW file as a mesh scene (no skeleton): as a clip it is refused by its extension, and as
// a mesh the scene it makes (a root whose children are null) is refused instead of followed.
TEST(HostileFiles, OnlyMotionFormatsAreReadAsClipsAndNullNodesAreRefused) {
  const std::string raw = write("t.raw", "A\n0 0 0 1 0 0 0 1 0\nB\n0 0 0 1 0 0 0 1 0\n");
  std::string e = error_of([&] { Motion::load(raw); });
  EXPECT_NE(e.find(raw + ": cannot read motion: '.raw' is not a motion format Loom reads (.bvh, .fbx, .dae, "
                         ".zae, .gltf, .glb, in any letter case)"),
            std::string::npos)
      << e;
  e = error_of([&] { loom::characters::load_static_mesh(raw); });
  EXPECT_NE(e.find(raw + ": "), std::string::npos) << e;
  EXPECT_NE(e.find("is missing (a null pointer"), std::string::npos) << e;
}

// XML nested deeper than assimp's readers can recurse is refused by file and line before assimp reads it;
// the same depth inside comments and quoted values is text, not elements.
TEST(HostileFiles, DeeplyNestedXmlIsRefusedByLineBeforeAssimpReadsIt) {
  const std::string dae = write("deep.dae", deep_collada(20000));
  const std::string where = dae + ": line 512: XML elements nest more than 512 levels deep";
  std::string e = error_of([&] { Motion::load(dae); });
  EXPECT_NE(e.find(where), std::string::npos) << e;
  e = error_of([&] { loom::characters::load_skinned_mesh(dae); });
  EXPECT_NE(e.find(where), std::string::npos) << e;
  std::string shallow = deep_collada(3);
  std::string noise = "<!--";
  for (int k = 0; k < 1000; ++k) noise += "<node>";
  noise += "--><![CDATA[";
  for (int k = 0; k < 1000; ++k) noise += "<node>";
  noise += "]]>";
  shallow.insert(shallow.find("<library_visual_scenes>"), noise);
  e = error_of([&] { Motion::load(write("shallow.dae", shallow)); });
  EXPECT_EQ(e.find("nest more than"), std::string::npos) << e;
}

// The BVH checks (nesting, frame count) run whatever the extension's letter case.
TEST(HostileFiles, TheBvhChecksRunForAnyLetterCase) {
  std::string text =
      "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition "
      "Zrotation Xrotation Yrotation\n";
  for (int k = 0; k < 50000; ++k) text += "JOINT j\n{\nOFFSET 0 1 0\nCHANNELS 0\n";
  text += "End Site\n{\nOFFSET 0 1 0\n}\n" + std::string(50001, '}') +
          "\nMOTION\nFrames: 1\nFrame Time: 0.1\n"
          "0 0 0 0 0 0\n";
  const std::string deep = write("deep.Bvh", text);
  std::string e = error_of([&] { Motion::load(deep); });
  EXPECT_NE(e.find(deep + ": HIERARCHY: joints nest more than 256 levels deep"), std::string::npos) << e;
  const std::string frames =
      write("frames.bVH",
            "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation "
            "Xrotation Yrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 2000000000\nFrame Time: "
            "0.1\n0 0 0 0 0 0\n");
  e = error_of([&] { Motion::load(frames); });
  EXPECT_NE(e.find(frames + ": Frames: says 2000000000 frames"), std::string::npos) << e;
}

// An OBJ names at most 16 material libraries (assimp reads a library again for each directive), however
// its lines are separated; a few still load.
TEST(HostileFiles, ObjMaterialLibrariesAreBounded) {
  write("m.mtl", "newmtl a\nKd 1 0 0\n");
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  std::string many;
  for (int k = 0; k < 17; ++k) many += "mtllib m.mtl\n";
  const std::string obj = write("many.obj", many + tri);
  const std::string e = error_of([&] { loom::characters::load_static_mesh(obj); });
  EXPECT_NE(e.find(obj + ": line 17: more than 16 'mtllib' directives"), std::string::npos) << e;
  // Directives apart by what else ends a line or starts a word for the reader: a lone CR, a form feed, NUL.
  for (const std::string& sep :
       {std::string("\r"), std::string("\f"), std::string(1, '\0'), std::string("\r\t")}) {
    std::string hidden;
    for (int k = 0; k < 17; ++k) hidden += "mtllib m.mtl" + sep;
    const std::string path = write("hidden.obj", hidden + "\n" + tri);
    const std::string h = error_of([&] { loom::characters::load_static_mesh(path); });
    EXPECT_NE(h.find(path + ": line 1: more than 16 'mtllib' directives"), std::string::npos) << h;
  }
  EXPECT_EQ(loom::characters::load_static_mesh(write("two.obj", "mtllib m.mtl\nmtllib m.mtl\n" + tri))
                .triangles.size(),
            1u);
}

// A body mesh vertex past the coordinate bound (1e6 m) is refused by vertex, not blamed later on the pose
// the fit cannot find.
TEST(HostileFiles, BodyMeshVerticesPastTheCoordinateBoundAreRefusedByVertex) {
  const std::string obj = write("far.obj", "v 0 0 0\nv 1e30 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string e = error_of([&] { loom::characters::load_static_mesh(obj); });
  EXPECT_NE(e.find(obj + ": vertices[1]: position (1e+30, 0, 0) m lies beyond +-1e6 m"), std::string::npos)
      << e;
  EXPECT_EQ(loom::characters::load_static_mesh(write("near.obj", "v 0 0 0\nv 1e5 0 0\nv 0 1 0\nf 1 2 3\n"))
                .triangles.size(),
            1u);
}

// An OBJ holds at most 1024 objects (`o`) and 1024 material switches (`usemtl`): assimp's reader makes and
// searches one object or mesh per directive (65536 took 11-15 s, usemtl 2.2 GB). Lines split at a lone CR
// count too; 1024 of each still load. Group lines (`g`, 1.6 KB each to the reader) at most 16384.
TEST(HostileFiles, ObjObjectsAndMaterialSwitchesAreBounded) {
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  for (const std::string directive : {"o", "usemtl"}) {
    std::string many;
    for (int k = 0; k < 1025; ++k) many += directive + " n" + std::to_string(k) + (k % 2 ? "\r" : "\n");
    const std::string path = write(directive + ".obj", tri + many);
    const std::string e = error_of([&] { loom::characters::load_static_mesh(path); });
    EXPECT_NE(e.find(path + ": line "), std::string::npos) << e;
    EXPECT_NE(e.find("more than 1024 '" + directive + "' directives"), std::string::npos) << e;
    std::string enough;
    for (int k = 0; k < 1024; ++k) enough += directive + " n" + std::to_string(k) + "\n" + tri;
    EXPECT_EQ(error_of([&] { loom::characters::load_static_mesh(write(directive + "_ok.obj", enough)); }), "")
        << directive;
  }
  std::string groups;
  for (int k = 0; k < 16385; ++k) groups += "g n" + std::to_string(k) + "\n";
  const std::string path = write("groups.obj", tri + groups);
  const std::string e = error_of([&] { loom::characters::load_static_mesh(path); });
  EXPECT_NE(e.find(path + ": line 16389: more than 16384 'g' lines"), std::string::npos) << e;
}

// An archive counts what it unpacks to (its directory's sizes) towards the 1 GiB an import may read: a
// small file claiming 2 GiB is refused before anything is unpacked. The body mesh shipped as a .zae loads.
TEST(HostileFiles, ArchivesCountWhatTheyUnpackTo) {
  const std::string bomb = write("bomb.zae", zip({{"a.dae", deep_collada(1)}}, 0x7fffffffu));
  const std::string e = error_of([&] { loom::characters::load_static_mesh(bomb); });
  EXPECT_NE(e.find(bomb + ": the import would read more than 1024 MiB in all"), std::string::npos) << e;
  const auto body = loom::characters::load_static_mesh(std::string(LOOM_TEST_DATA) + "/body/human.zae");
  EXPECT_GT(body.triangles.size(), 1000u);
}

// An entry whose local header and central directory disagree on its compression method is one the unzip
// reader will not open (the importer then called it missing): refused naming the archive and the entry.
TEST(HostileFiles, ArchiveEntriesWhoseHeadersDisagreeAreNamed) {
  std::string archive = zip({{"a.dae", deep_collada(1)}}, 0, true);
  const std::size_t dir = archive.find("PK\x01\x02");
  ASSERT_NE(dir, std::string::npos);
  archive[dir + 10] = 0;  // the directory says stored, the local header deflated
  const std::string path = write("methods.zae", archive);
  const std::string e = error_of([&] { loom::characters::load_static_mesh(path); });
  EXPECT_NE(e.find(path + ": zip entry 'a.dae': its local header says compression method 8, the central "
                          "directory 0"),
            std::string::npos)
      << e;
}

// XML inside an archive is scanned as its entries are inflated (stored or deflated, whatever the entry's
// name if its text starts with '<'): a COLLADA nested 20,000 deep is refused by the archive, the entry and
// the line before assimp reads it. An archive of a shallow one, a PNG-like binary entry full of '<' beside
// it, still reaches assimp, and the body mesh (a deflated .zae with a PNG texture) loads.
TEST(HostileFiles, DeepNestingInsideAnArchiveIsRefusedByEntryAndLine) {
  for (const bool deflated : {false, true}) {
    for (const char* entry : {"deep.dae", "scene/model.bin"}) {
      const std::string zae =
          write(std::string("deep") + (deflated ? "_z" : "") + ".zae",
                zip({{"notes.txt", "no markup here"}, {entry, deep_collada(20000)}}, 0, deflated));
      const std::string e = error_of([&] { Motion::load(zae); });
      EXPECT_NE(e.find(zae + ": " + entry + ", line 512: XML elements nest more than 512 levels deep"),
                std::string::npos)
          << e;
      const std::string mesh_error = error_of([&] { loom::characters::load_static_mesh(zae); });
      EXPECT_NE(mesh_error.find(zae + ": " + entry + ", line 512"), std::string::npos) << mesh_error;
    }
    std::string binary(200000, '<');
    binary[0] = '\x89';
    const std::string shallow =
        write("shallow.zae", zip({{"a.dae", deep_collada(3)}, {"t.png", binary}}, 0, deflated));
    const std::string e = error_of([&] { loom::characters::load_static_mesh(shallow); });
    EXPECT_EQ(e.find("nest more than"), std::string::npos) << e;
  }
  // UTF-16 entries are scanned by their code units' low bytes.
  std::string wide;
  for (char c : deep_collada(600)) wide += {c, '\0'};
  const std::string zae = write("wide.zae", zip({{"w.dae", "\xFF\xFE" + wide}}, 0, true));
  const std::string e = error_of([&] { Motion::load(zae); });
  EXPECT_NE(e.find(zae + ": w.dae, line 512: XML elements nest more than 512 levels deep"), std::string::npos)
      << e;
  const auto body = loom::characters::load_static_mesh(std::string(LOOM_TEST_DATA) + "/body/human.zae");
  EXPECT_GT(body.triangles.size(), 1000u);
}

// The streaming scan finds what the whole-text scan finds, whatever the pieces' sizes: markup cut anywhere
// (a comment's or CDATA's end, a quoted '>', a self-closing tag) is still seen.
TEST(HostileFiles, TheXmlDepthScanIsTheSameInPiecesOfAnySize) {
  std::string text = "<?xml version='1.0'?>\n<!DOCTYPE a [<!ENTITY x '<b>'>]>\n<a>";
  for (int k = 0; k < 40; ++k)
    text += "\n<!-- <c><c> --><![CDATA[<d><d>]]><e attr='>' other=\"<e>\"><f/><g></g>";
  const auto scan_in = [&](std::size_t piece, int max_depth) {
    loom::characters::XmlDepthScan scan(max_depth);
    for (std::size_t at = 0; at < text.size(); at += piece)
      if (!scan.feed(text.data() + at, std::min(piece, text.size() - at))) break;
    if (!scan.too_deep()) scan.finish();
    return std::make_pair(scan.too_deep() ? long(scan.offset()) : -1L, scan.line());
  };
  for (const int max_depth : {8, 41, 42, 100}) {
    const long whole = loom::characters::xml_too_deep(text, max_depth);
    EXPECT_EQ(whole >= 0, max_depth < 42) << max_depth;  // <a>, 40 <e> levels and the last <g>
    for (const std::size_t piece :
         {std::size_t(1), std::size_t(2), std::size_t(3), std::size_t(7), std::size_t(64), text.size()}) {
      const auto [offset, line] = scan_in(piece, max_depth);
      EXPECT_EQ(offset, whole) << max_depth << " " << piece;
      if (whole >= 0) {
        EXPECT_EQ(line, std::uint64_t(1 + std::count(text.begin(), text.begin() + whole, '\n')));
      }
    }
  }
}

}  // namespace
