// Hostile files handed to assimp (a clip or a body mesh): each is refused by a loom::Error naming the file
// and what is wrong, before or after assimp reads it, never by a crash, a hang or unbounded memory.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

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

std::string write(const std::string& name, const std::string& text) {
  const std::string path = (loom::test::test_dir() / name).string();
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// A zip archive (PKWARE APPNOTE 6.3: local headers, central directory, end record) storing `files`
// uncompressed; `claimed` (if not 0) is the unpacked size the central directory gives for each entry.
std::string zip(const std::vector<std::pair<std::string, std::string>>& files, std::uint32_t claimed = 0) {
  auto crc32 = [](const std::string& s) {
    std::uint32_t c = 0xffffffffu;
    for (unsigned char b : s) {
      c ^= b;
      for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return ~c;
  };
  auto u16 = [](std::string& o, std::uint32_t v) { o += {char(v & 0xff), char((v >> 8) & 0xff)}; };
  auto u32 = [&](std::string& o, std::uint32_t v) {
    u16(o, v & 0xffff);
    u16(o, v >> 16);
  };
  std::string out, dir;
  for (const auto& [name, data] : files) {
    const std::uint32_t offset = static_cast<std::uint32_t>(out.size()), crc = crc32(data);
    const std::uint32_t size = static_cast<std::uint32_t>(data.size());
    out += "PK\x03\x04";
    for (std::uint32_t v : {20u, 0u, 0u, 0u, 0u}) u16(out, v);  // version, flags, stored, time, date
    u32(out, crc);
    u32(out, size);
    u32(out, size);
    u16(out, static_cast<std::uint32_t>(name.size()));
    u16(out, 0);
    out += name + data;
    dir += "PK\x01\x02";
    for (std::uint32_t v : {20u, 20u, 0u, 0u, 0u, 0u}) u16(dir, v);
    u32(dir, crc);
    u32(dir, size);
    u32(dir, claimed ? claimed : size);
    u16(dir, static_cast<std::uint32_t>(name.size()));
    for (std::uint32_t v : {0u, 0u, 0u, 0u}) u16(dir, v);
    u32(dir, 0);
    u32(dir, offset);
    dir += name;
  }
  const std::uint32_t at = static_cast<std::uint32_t>(out.size());
  out += dir + "PK\x05\x06";
  for (std::uint32_t v : {0u, 0u}) u16(out, v);
  u16(out, static_cast<std::uint32_t>(files.size()));
  u16(out, static_cast<std::uint32_t>(files.size()));
  u32(out, static_cast<std::uint32_t>(dir.size()));
  u32(out, at);
  u16(out, 0);
  return out;
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

// An OBJ names at most 16 material libraries (assimp reads a library again for each directive); a few
// still load.
TEST(HostileFiles, ObjMaterialLibrariesAreBounded) {
  write("m.mtl", "newmtl a\nKd 1 0 0\n");
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  std::string many;
  for (int k = 0; k < 17; ++k) many += "mtllib m.mtl\n";
  const std::string obj = write("many.obj", many + tri);
  const std::string e = error_of([&] { loom::characters::load_static_mesh(obj); });
  EXPECT_NE(e.find(obj + ": line 17: more than 16 'mtllib' directives"), std::string::npos) << e;
  EXPECT_EQ(loom::characters::load_static_mesh(write("two.obj", "mtllib m.mtl\nmtllib m.mtl\n" + tri))
                .triangles.size(),
            1u);
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

// Nesting the pre-scan does not see (XML inside an archive) is read on the reader's large stack and refused
// by the node depth, not by a crash.
TEST(HostileFiles, DeepNestingInsideAnArchiveIsRefusedNotACrash) {
  const std::string zae = write("deep.zae", zip({{"deep.dae", deep_collada(20000)}}));
  const std::string e = error_of([&] { Motion::load(zae); });
  EXPECT_NE(e.find(zae + ": "), std::string::npos) << e;
  EXPECT_NE(e.find("nest more than"), std::string::npos) << e;
}

}  // namespace
