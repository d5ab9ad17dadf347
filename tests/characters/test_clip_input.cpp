// What a clip's keys may hold beyond finite numbers: each node scale is applied (uniform, positive, constant,
// at or above the skeleton's root) or refused by joint and key; a BVH channel given twice is refused by line
// and joint; a file without an animated skeleton is refused as such; a jump between two keys is refused past
// 1e4 m/s and named by the scene's regime report (file, joint, frame) past the validated speed.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "CharacterTestUtil.h"
#include "loom/characters/Character.h"
#include "loom/characters/Motion.h"
#include "loom/scene/Scene.h"
#include "loom/scene/SceneRegime.h"

namespace {

using loom::characters::Motion;
using loom::characters::MotionSettings;
using loom::test::error_of;
using loom::test::write_test_file;

std::string base64(const std::vector<float>& values) {
  static const char* kDigits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string bytes(values.size() * 4, '\0');
  std::memcpy(&bytes[0], values.data(), bytes.size());  // little-endian floats (glTF's byte order)
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 2]);
    out += kDigits[(v >> 18) & 63];
    out += kDigits[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kDigits[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kDigits[v & 63] : '=';
  }
  return out;
}

struct GltfClip {
  int scale_node = -1;  // the node whose scale is animated (-1: none)
  float s0[3] = {1, 1, 1}, s1[3] = {1, 1, 1};
  std::string node_scale;  // a "scale" for node 2 ("Chest"), e.g. "[0,0,0]" ("": none)
  std::string mesh_scale;  // a "scale" for node 4 ("Mesh", beside the skeleton)
  bool animated = true;
  float t0 = 0, t1 = 1;  // the two key times (s)
};

// Four nodes in a chain, Root > Hips > Chest > Head, 1 unit apart on y, and a node "Mesh" under Root beside
// the skeleton; Hips turns about y over 1 s.
std::string gltf(const GltfClip& c) {
  const float h = std::sqrt(0.5f);
  const std::vector<float> data = {c.t0, c.t1, 0,       0,       0,       1,       0,       h,
                                   0,    h,    c.s0[0], c.s0[1], c.s0[2], c.s1[0], c.s1[1], c.s1[2]};
  std::ostringstream j;
  j << R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [)"
    << R"({"name": "Root", "children": [1, 4]}, {"name": "Hips", "translation": [0, 1, 0], "children": [2]},)"
    << R"({"name": "Chest", "translation": [0, 1, 0], "children": [3])"
    << (c.node_scale.empty() ? "" : ", \"scale\": " + c.node_scale) << "},"
    << R"({"name": "Head", "translation": [0, 1, 0]}, {"name": "Mesh", "translation": [0, 1, 0])"
    << (c.mesh_scale.empty() ? "" : ", \"scale\": " + c.mesh_scale) << "}]";
  if (c.animated) {
    j << R"(, "animations": [{"samplers": [{"input": 0, "output": 1}, {"input": 0, "output": 2}],)"
      << R"( "channels": [{"sampler": 0, "target": {"node": 1, "path": "rotation"}})";
    if (c.scale_node >= 0)
      j << R"(, {"sampler": 1, "target": {"node": )" << c.scale_node << R"(, "path": "scale"}})";
    j << "]}]";
  }
  j << R"(, "buffers": [{"byteLength": 64, "uri": "data:application/octet-stream;base64,)" << base64(data)
    << R"("}], "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 8},)"
    << R"( {"buffer": 0, "byteOffset": 8, "byteLength": 32},)"
    << R"( {"buffer": 0, "byteOffset": 40, "byteLength": 24}],)"
    << R"( "accessors": [{"bufferView": 0, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [)"
    << c.t0 << R"(],)"
    << R"( "max": [)" << c.t1
    << R"(]}, {"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC4"},)"
    << R"( {"bufferView": 2, "componentType": 5126, "count": 2, "type": "VEC3"}]})";
  return j.str();
}

std::string load_error(const GltfClip& c, const std::string& name) {
  MotionSettings ms;
  ms.scale = 1.0;
  return error_of([&] { Motion::load(write_test_file(name, gltf(c)), ms); });
}

TEST(ClipInput, AConstantUniformScaleAtTheRootIsAppliedToTheJointsBelowIt) {
  MotionSettings ms;
  ms.scale = 1.0;
  GltfClip plain;
  plain.scale_node = 1;
  const Motion a = Motion::load(write_test_file("plain.gltf", gltf(plain)), ms);
  GltfClip doubled = plain;
  for (float& v : doubled.s0) v = 2;
  for (float& v : doubled.s1) v = 2;
  const Motion b = Motion::load(write_test_file("doubled.gltf", gltf(doubled)), ms);
  const int head = b.find("Head");
  ASSERT_GE(head, 0);
  std::vector<loom::characters::Transform> pa, pb;
  a.clip_pose(0.0, pa);
  b.clip_pose(0.0, pb);
  // Hips at y = 1 in both; Chest and Head twice as far above it with the Hips' scale 2.
  EXPECT_NEAR(pa[head].translation().y(), 3.0, 1e-6);
  EXPECT_NEAR(pb[head].translation().y(), 5.0, 1e-6);
  EXPECT_NEAR(b.rest_height(), 5.0, 1e-6);
}

// A clip's time line starts at 0 (glTF 2.0: animation inputs are >= 0) and its length is its last key
// time: a key before 0 is refused by joint and key, so that every reader of the clip sees one length.
TEST(ClipInput, AKeyTimeBeforeZeroIsRefusedByJointAndKey) {
  GltfClip early;
  early.t0 = -5;
  early.t1 = -4;
  EXPECT_NE(load_error(early, "early.gltf").find("joint 'Hips': rotation key 0: its time -5 s is negative"),
            std::string::npos)
      << load_error(early, "early.gltf");
  GltfClip straddling;
  straddling.t0 = -0.5;
  EXPECT_NE(load_error(straddling, "straddling.gltf").find("rotation key 0: its time -0.5 s is negative"),
            std::string::npos);
  GltfClip late;  // starting after 0 is allowed: the clip holds its first pose until then
  late.t0 = 0.5;
  late.t1 = 2;
  EXPECT_EQ(load_error(late, "late.gltf"), "");
}

// Every offset and length of a glTF's data is checked before assimp reads it (glTF 2.0, section 5): a view
// past its buffer, an accessor past its view, sparse indices or values past theirs (a byteOffset of 2^32 - 1
// made the reader copy from far outside the file), numbers that are not whole or reach 2^53, and an
// animation sampler whose values do not match its key times and path (CUBICSPLINE keys are three values)
// or are not floats, a mesh primitive with fewer vertices than its mode needs, and a buffer file outside
// the clip's folder.
// Each is refused naming the file and the field; the unchanged clip, as .gltf and as .glb, loads.
TEST(ClipInput, GltfDataOutsideItsBuffersIsRefusedByField) {
  using Json = nlohmann::json;
  MotionSettings ms;
  ms.scale = 1.0;
  const Json base = Json::parse(gltf(GltfClip{}));
  EXPECT_EQ(error_of([&] { Motion::load(write_test_file("base.gltf", base.dump()), ms); }), "");
  const Json sparse = {{"count", 1},
                       {"indices", {{"bufferView", 0}, {"componentType", 5125}, {"byteOffset", 0}}},
                       {"values", {{"bufferView", 1}, {"byteOffset", 0}}}};
  struct Case {
    const char* pointer;
    Json value;
    const char* problem;
  };
  const std::vector<Case> cases = {
      {"/bufferViews/1/byteLength", 64,
       "bufferViews[1].byteLength: reaches byte 72 of buffers[0], which has 64"},
      {"/bufferViews/1/byteOffset", -8, "bufferViews[1].byteOffset: must be a whole number in [0, 2^53)"},
      {"/bufferViews/1/byteOffset", 8.5, "bufferViews[1].byteOffset: must be a whole number"},
      {"/bufferViews/1/byteStride", 2, "bufferViews[1].byteStride: must be a multiple of 4 in [4, 252]"},
      {"/accessors/1/count", 3, "accessors[1].count: reaches byte 48 of bufferViews[1], which has 32"},
      {"/accessors/1/count", 0, "accessors[1].count: must be a whole number in [1, 2^53)"},
      {"/accessors/1/byteOffset", 9007199254740992.0, "accessors[1].byteOffset: must be a whole number"},
      {"/accessors/1/componentType", 5124, "accessors[1].componentType: must be 5120, 5121"},
      {"/accessors/1/bufferView", 7, "accessors[1].bufferView: names buffer view 7 of 3"},
      {"/buffers/0/byteLength", 65, "buffers[0].byteLength: reaches byte 65 of its data URI, which has 64"},
      {"/accessors/1/sparse", sparse, ""},
      {"/accessors/1/sparse/indices/byteOffset", 4294967295u,
       "accessors[1].sparse.indices.byteOffset: reaches byte 4294967299 of bufferViews[0], which has 8"},
      {"/accessors/1/sparse/values/byteOffset", 1000,
       "accessors[1].sparse.values.byteOffset: reaches byte 1016 of bufferViews[1], which has 32"},
      {"/accessors/1/sparse/count", 3, "accessors[1].sparse.count: 3 is more than the accessor's count 2"},
      {"/accessors/1/sparse/indices/componentType", 5126, "accessors[1].sparse.indices.componentType"},
      {"/animations/0/samplers/0/interpolation", "CUBICSPLINE",
       "animations[0].samplers[0].output: has 2 values for 2 key times (3 per key for CUBICSPLINE)"},
      {"/animations/0/samplers/0/output", 2,
       "animations[0].samplers[0].output: must be a VEC4 accessor for a rotation channel (got VEC3)"},
      {"/animations/0/samplers/0/input", 1, "animations[0].samplers[0].input: must be a SCALAR FLOAT"},
      {"/animations/0/channels/0/sampler", 5, "animations[0].channels[0].sampler: names sampler 5 of 2"},
      {"/accessors/0/componentType", 5121, "animations[0].samplers[0].input: must be a SCALAR FLOAT (5126)"},
      {"/meshes", Json::parse(R"([{"primitives": [{"attributes": {"POSITION": 2}, "mode": 5}]}])"),
       "meshes[0].primitives[0]: has 2 vertices (indices, or POSITION values); its mode 5 needs at least 3"},
      {"/meshes", Json::parse(R"([{"primitives": [{"attributes": {"POSITION": 2}, "indices": 0}]}])"),
       "meshes[0].primitives[0].indices: must be a SCALAR accessor of unsigned integers"},
      {"/meshes", Json::parse(R"([{"primitives": [{"attributes": {"POSITION": 2}, "mode": 7}]}])"),
       "meshes[0].primitives[0].mode: must be 0 to 6"},
      {"/buffers/0/uri", "../up.bin", "buffers[0].uri: '../up.bin' is not a file beside the clip"},
      {"/buffers/0/uri", "/etc/hostname", "buffers[0].uri: '/etc/hostname' is not a file beside the clip"},
      {"/buffers/0/uri", "a/%2e%2E/%2E%2e/up.bin", "buffers[0].uri: 'a/%2e%2E/%2E%2e/up.bin' is not a file"},
      {"/buffers/0/uri", "file:///etc/hostname", "buffers[0].uri: 'file:///etc/hostname' is not a file"},
  };
  Json doc = base;
  for (std::size_t k = 0; k < cases.size(); ++k) {
    // The sparse cases build on the valid sparse storage the case before them adds.
    if (std::string(cases[k].pointer).rfind("/accessors/1/sparse/", 0) != 0) doc = base;
    if (std::string(cases[k].pointer) == "/accessors/1/sparse") doc = base;
    Json mutated = doc;
    mutated[Json::json_pointer(cases[k].pointer)] = cases[k].value;
    if (std::string(cases[k].pointer) == "/accessors/1/sparse") doc = mutated;
    const std::string path = write_test_file("data_" + std::to_string(k) + ".gltf", mutated.dump());
    const std::string e = error_of([&] { Motion::load(path, ms); });
    if (*cases[k].problem == '\0') {
      EXPECT_EQ(e, "") << cases[k].pointer;
      continue;
    }
    EXPECT_NE(e.find(path + ": " + cases[k].problem), std::string::npos) << cases[k].pointer << ": " << e;
  }
  // One sampler shared by 110000 channels: 1.1 million key values copied out of a 64-byte buffer.
  Json shared = base;
  const Json channel = shared["animations"][0]["channels"][0];
  for (int k = 0; k < 110000; ++k) shared["animations"][0]["channels"].push_back(channel);
  const std::string shared_path = write_test_file("shared.gltf", shared.dump());
  const std::string s = error_of([&] { Motion::load(shared_path, ms); });
  EXPECT_NE(
      s.find(shared_path + ": animations: their channels read 1100010 key values from 64 bytes of buffers"),
      std::string::npos)
      << s.substr(0, 300);
  // The same clip as a binary glTF: buffers[0] without a uri is the BIN chunk, which must hold its length.
  auto glb = [&](std::uint32_t bin_length) {
    Json j = base;
    const std::string uri = j["buffers"][0]["uri"];
    j["buffers"][0].erase("uri");
    std::string json = j.dump();
    json.resize((json.size() + 3) / 4 * 4, ' ');
    // The 64 data bytes, decoded from the data URI's base64.
    std::string bin;
    const std::string digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    unsigned acc = 0;
    int bits = 0;
    for (const char c : uri.substr(uri.find(',') + 1)) {
      if (c == '=') break;
      acc = acc << 6 | static_cast<unsigned>(digits.find(c));
      if ((bits += 6) >= 8) bin += static_cast<char>((acc >> (bits -= 8)) & 0xff);
    }
    bin.resize(std::min<std::size_t>(bin.size(), bin_length));
    auto u32 = [](std::uint32_t v) {
      return std::string{char(v & 0xff), char(v >> 8 & 0xff), char(v >> 16 & 0xff), char(v >> 24 & 0xff)};
    };
    const std::string body =
        u32(std::uint32_t(json.size())) + "JSON" + json + u32(bin_length) + std::string("BIN\0", 4) + bin;
    return "glTF" + u32(2) + u32(std::uint32_t(12 + body.size())) + body;
  };
  EXPECT_EQ(error_of([&] { Motion::load(write_test_file("base.glb", glb(64)), ms); }), "");
  const std::string short_bin = write_test_file("short.glb", glb(60));
  const std::string e = error_of([&] { Motion::load(short_bin, ms); });
  EXPECT_NE(e.find(short_bin + ": buffers[0].byteLength: reaches byte 64 of the BIN chunk, which has 60"),
            std::string::npos)
      << e;
}

TEST(ClipInput, AScaleThatChangesTheBonesIsRefusedByJointAndKey) {
  const float nan = std::nanf("");
  struct Case {
    int node;
    float s0[3], s1[3];
    const char* expect;
  };
  const Case cases[] = {
      {1, {nan, 1, 1}, {1, 1, 1}, "joint 'Hips': scale key 0 (nan, 1, 1) is not finite"},
      {1, {1, 1, 1}, {1, 1, INFINITY}, "joint 'Hips': scale key 1 (1, 1, inf) is not finite"},
      {1, {0, 0, 0}, {0, 0, 0}, "joint 'Hips': scale key 0 (0, 0, 0) is not positive"},
      {1, {-1, 1, 1}, {-1, 1, 1}, "scale key 0 (-1, 1, 1) is not positive"},
      {1, {1e30f, 1e30f, 1e30f}, {1e30f, 1e30f, 1e30f}, "scale key 0 (1e+30, 1e+30, 1e+30) is outside"},
      {1, {1, 2, 1}, {1, 2, 1}, "scale key 0 (1, 2, 1) is uneven over the axes"},
      {1, {1, 1, 1}, {2, 2, 2}, "scale key 1 (2, 2, 2) differs from key 0 (1, 1, 1)"},
      {2, {3, 3, 3}, {3, 3, 3}, "joint 'Chest': its scale keys scale it by 3.000000 inside the skeleton"},
  };
  for (const Case& c : cases) {
    GltfClip g;
    g.scale_node = c.node;
    std::copy(c.s0, c.s0 + 3, g.s0);
    std::copy(c.s1, c.s1 + 3, g.s1);
    const std::string e = load_error(g, "scaled.gltf");
    EXPECT_NE(e.find("scaled.gltf"), std::string::npos) << e;
    EXPECT_NE(e.find(c.expect), std::string::npos) << c.expect << "\n" << e;
  }
  // A node's rest scale (no scaling keys): singular, mirroring, or inside the skeleton.
  const std::pair<const char*, const char*> rest[] = {
      {"[0, 0, 0]", "joint 'Chest': the rest transform's scale (0, 0, 0) is not positive"},
      {"[-1, 1, 1]", "joint 'Chest': the rest transform's scale (1, 1, 1) mirrors"},
      {"[1, 1, 4]", "is uneven over the axes"},
      {"[5, 5, 5]", "joint 'Chest': its rest transform scale it by 5.000000 inside the skeleton"},
  };
  // A node beside the skeleton (a mesh) neither moves nor carries a joint: its scale is not read.
  GltfClip beside;
  beside.mesh_scale = "[1, 2, -3]";
  EXPECT_EQ(load_error(beside, "beside.gltf"), "");
  for (const auto& [scale, expect] : rest) {
    GltfClip g;
    g.node_scale = scale;
    const std::string e = load_error(g, "rest.gltf");
    EXPECT_NE(e.find(expect), std::string::npos) << expect << "\n" << e;
  }
}

TEST(ClipInput, AFileWithoutAnAnimatedSkeletonIsRefusedAsSuch) {
  GltfClip still;
  still.animated = false;
  const std::string e = load_error(still, "still.gltf");
  EXPECT_NE(e.find("still.gltf: holds no animated skeleton (no animation)"), std::string::npos) << e;
  // In a scene the message names character.bvh (not the garment or scale fields a rest pose would fail).
  const std::string clip = write_test_file("no_anim.gltf", gltf(still));
  const std::string s = error_of([&] {
    loom::scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/character_cape.json",
                            {"character.bvh=" + clip});
  });
  EXPECT_NE(s.find("character.bvh: " + clip + ": holds no animated skeleton"), std::string::npos) << s;
}

const char* kBvh = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT Chest
  {
    OFFSET 0 1 0
    CHANNELS 3 Zrotation %s Xrotation
    End Site
    {
      OFFSET 0 1 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.01
0 1 0 0 0 0 0 0 0
0 1 0 0 0 0 0 0 0
%s 1 0 0 0 0 0 0 0
)";

std::string bvh(const char* second_channel, const char* third_x) {
  char text[1024];
  std::snprintf(text, sizeof text, kBvh, second_channel, third_x);
  return text;
}

TEST(ClipInput, ABvhChannelGivenTwiceIsRefusedByLineAndJoint) {
  const std::string ok = write_test_file("ok.bvh", bvh("Yrotation", "0"));
  EXPECT_EQ(error_of([&] { Motion::load(ok); }), "");
  const std::string twice = write_test_file("twice.bvh", bvh("Zrotation", "0"));
  const std::string e = error_of([&] { Motion::load(twice); });
  EXPECT_NE(e.find("twice.bvh: line 9: joint 'Chest': channel 'Zrotation' is given twice"), std::string::npos)
      << e;
}

// Every number of a BVH is checked before the reader parses it, so a value its parser stops on (or reads as
// non-finite) is named by line: a frame value, an OFFSET (two numbers before CHANNELS) and the frame time.
TEST(ClipInput, BvhNumbersTheReaderCannotParseAreNamedByLine) {
  for (const char* bad : {"1e", "--1", "nan", "inf", "0x10", "1.2.3"}) {
    const std::string path = write_test_file("bad_value.bvh", bvh("Yrotation", bad));
    const std::string e = error_of([&] { Motion::load(path); });
    EXPECT_NE(
        e.find(path + ": line 21: value 1 of the line, '" + std::string(bad) + "', is not a decimal number"),
        std::string::npos)
        << e;
  }
  const std::string huge = write_test_file("huge_value.bvh", bvh("Yrotation", "1e300"));
  const std::string h = error_of([&] { Motion::load(huge); });
  EXPECT_NE(
      h.find(huge + ": line 21: value 1 of the line, '1e300', is past the 3.4e38 the reader's 32-bit floats"),
      std::string::npos)
      << h;
  for (const char* good : {"+1", "-.5", "2.", "1e-3", "1E+2"})
    EXPECT_EQ(error_of([&] { Motion::load(write_test_file("good_value.bvh", bvh("Yrotation", good))); }), "")
        << good;
  std::string offset = bvh("Yrotation", "0");
  offset.replace(offset.find("OFFSET 0 1 0\n    CHANNELS"), 12, "OFFSET 0 1");
  const std::string offset_path = write_test_file("offset.bvh", offset);
  std::string e = error_of([&] { Motion::load(offset_path); });
  EXPECT_NE(
      e.find(offset_path + ": line 9: joint 'Chest': OFFSET needs three decimal numbers (got 'CHANNELS')"),
      std::string::npos)
      << e;
  std::string hex = bvh("Yrotation", "0");
  hex.replace(hex.find("Frame Time: 0.01"), 16, "Frame Time: 0x1p-7");
  const std::string hex_path = write_test_file("hex.bvh", hex);
  e = error_of([&] { Motion::load(hex_path); });
  EXPECT_NE(e.find(hex_path + ": Frame Time: expected a decimal number of seconds (got '0x1p-7')"),
            std::string::npos)
      << e;
}

// The poses sampled over a played clip (garment fitting, capsule radii) are bounded by its keys, not by its
// times: three frames an hour apart give at most Motion::kSamplesPerKeyInterval per interval, whatever the
// rate or the playback speed; an ordinary clip is sampled at the rate asked for.
TEST(ClipInput, PlayedSamplesAreBoundedByTheKeysNotByTheClipsSeconds) {
  std::string hour = bvh("Yrotation", "0");
  hour.replace(hour.find("Frame Time: 0.01"), 16, "Frame Time: 3600");
  const std::string path = write_test_file("hour.bvh", hour);
  for (const double speed : {1.0, 1e-6}) {
    MotionSettings ms;
    ms.speed = speed;
    const Motion m = Motion::load(path, ms);
    ASSERT_DOUBLE_EQ(m.duration(), 7200.0);
    const std::vector<double> t = m.played_samples(120.0);
    EXPECT_EQ(t.size(), static_cast<std::size_t>(2 * Motion::kSamplesPerKeyInterval + 1)) << speed;
    EXPECT_EQ(t.front(), 0.0);
    EXPECT_DOUBLE_EQ(t.back(), 7200.0 / speed);
    for (std::size_t k = 1; k < t.size(); ++k) EXPECT_GT(t[k], t[k - 1]);
  }
  const Motion brief = Motion::load(write_test_file("brief.bvh", bvh("Yrotation", "0")));
  const std::vector<double> t = brief.played_samples(1000.0);  // 0.02 s of clip at 1 kHz: 20 intervals
  EXPECT_EQ(t.size(), 17u);                           // ... capped by the two key intervals at 8 each
  EXPECT_EQ(brief.played_samples(100.0).size(), 3u);  // 0.02 s at 100 Hz: 2 intervals
}

TEST(ClipInput, AJumpPastTheKeySpeedBoundIsRefusedByJointAndFrame) {
  MotionSettings ms;
  ms.scale = 1.0;
  // 99 m in 0.01 s: 9900 m/s, read; 101 m: 10100 m/s, refused.
  EXPECT_EQ(error_of([&] { Motion::load(write_test_file("fast.bvh", bvh("Yrotation", "99")), ms); }), "");
  const std::string e =
      error_of([&] { Motion::load(write_test_file("jump.bvh", bvh("Yrotation", "101")), ms); });
  EXPECT_NE(e.find("jump.bvh: joint 'Hips' position: frame 3 jumps 101 m in 0.01 s (10100 m/s"),
            std::string::npos)
      << e;
}

// arm_swing.bvh with `shift` file units added to the root's Xposition from the 0-based frame `from` on.
std::string shifted_clip(double shift, int from) {
  std::ifstream in(std::string(LOOM_SOURCE_DIR) + "/tests/data/mocap/arm_swing.bvh");
  std::string line, out;
  int frame = -1;
  while (std::getline(in, line)) {
    if (frame >= 0) {
      std::istringstream words(line);
      double x = 0.0;
      words >> x;
      if (frame++ >= from) {
        std::string rest;
        std::getline(words, rest);
        line = std::to_string(x + shift) + rest;
      }
    }
    if (line.rfind("Frame Time:", 0) == 0) frame = 0;
    out += line + "\n";
  }
  return write_test_file("shifted.bvh", out);
}

std::string clip_outlier(const std::string& clip) {
  const loom::scene::Scene scene =
      loom::scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/character_cape.json",
                              {"character.bvh=" + clip, "character.start=0", "duration=0.2"});
  for (const loom::scene::RegimeOutlier& o : loom::scene::regime_outliers(scene))
    if (o.text.rfind("character.bvh", 0) == 0) return o.text;
  return "";
}

TEST(ClipInput, AClipFasterThanTheValidatedSpeedIsNamedByFileJointAndFrame) {
  // The clip as shipped stays inside the regime.
  EXPECT_EQ(clip_outlier(std::string(LOOM_SOURCE_DIR) + "/tests/data/mocap/arm_swing.bvh"), "");
  // 100 units (6.6 m at the clip's automatic scale) between frames 5 and 6 (1/120 s): 795 m/s.
  const std::string clip = shifted_clip(100.0, 5);
  const std::string text = clip_outlier(clip);
  EXPECT_NE(text.find("character.bvh (" + clip + ": joint 'Hips' moves at 795 m/s"), std::string::npos)
      << text;
  EXPECT_NE(text.find("near clip frame 6,"), std::string::npos) << text;
  const loom::scene::Scene scene =
      loom::scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/character_cape.json",
                              {"character.bvh=" + clip, "character.start=0", "duration=0.2"});
  const std::string advice = loom::scene::divergence_suspects(scene);
  EXPECT_NE(advice.find("character.bvh ("), std::string::npos) << advice;
  EXPECT_EQ(advice.find("more solver.substeps"), std::string::npos) << advice;
}

// A garment's values outside the regime are named by the garment's field (the scene has no `cloths`).
TEST(ClipInput, AGarmentOutsideTheRegimeIsNamedByItsGarmentField) {
  const loom::scene::Scene scene = loom::scene::load_scene(
      std::string(LOOM_SOURCE_DIR) + "/scenes/character_cape.json",
      {"character.garments[0].material={\"preset\":\"cotton\",\"stretch\":1e12}", "duration=0.2"});
  const std::string advice = loom::scene::divergence_suspects(scene);
  EXPECT_NE(advice.find("character.garments[0].material stretch with its areal density"), std::string::npos)
      << advice;
  EXPECT_EQ(advice.find("cloths["), std::string::npos) << advice;
}

// A generated garment's length and width of 0 take the size from the body (the scene format's own
// example), for every garment type; a negative one is refused with the same rule.
TEST(ClipInput, AGarmentSizeOfZeroTakesItFromTheBody) {
  for (const std::string type : {"cape", "skirt", "shirt"}) {
    const std::string garment = "character.garments=[{\"type\":\"" + type + "\",\"length\":0" +
                                (type == "cape" ? ",\"width\":0" : "") + "}]";
    EXPECT_EQ(error_of([&] {
                loom::scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/character_cape.json",
                                        {garment, "duration=0.1"});
              }),
              "")
        << type;
    const std::string negative = "character.garments=[{\"type\":\"" + type + "\",\"length\":-1}]";
    EXPECT_NE(error_of([&] {
                loom::scene::load_scene(std::string(LOOM_SOURCE_DIR) + "/scenes/character_cape.json",
                                        {negative, "duration=0.1"});
              }).find("character.garments[0].length: must be 0 (from the body) or in [0.01, 100] m"),
              std::string::npos)
        << type;
  }
}

// What loading a clip holds is estimated from the file before it is read: a BVH by Frames x its joints and
// their CHANNELS (arm_swing.bvh: 511 frames of 31 joints, 6 + 30 x 3 channels), bounded by what its lines can
// hold; a glTF by its JSON and the byteLength of its buffers; a FIFO is never opened.
TEST(ClipMemory, EstimatedFromTheFileBeforeItIsRead) {
  namespace ch = loom::characters;
  const std::string arm = loom::test::mocap("arm_swing.bvh");
  const ch::MemoryEstimate e = ch::estimate_clip_memory(arm);
  EXPECT_EQ(e.basis, "511 frames of 31 joints and 96 channels");
  EXPECT_DOUBLE_EQ(e.bytes, 511.0 * (31.0 * ch::kBvhBytesPerJointFrame + 96.0 * ch::kBvhBytesPerValue) +
                                static_cast<double>(std::filesystem::file_size(arm)));
  // A header that claims 10^18 frames is bounded by its file: each number takes two bytes at least.
  std::ifstream in(arm);
  std::stringstream text;
  text << in.rdbuf();
  std::string claimed = text.str();
  claimed.replace(claimed.find("Frames: 511"), 11, "Frames: 1000000000000000000");
  const std::string huge = write_test_file("claims_frames.bvh", claimed);
  EXPECT_LE(ch::estimate_clip_memory(huge).bytes,
            static_cast<double>(claimed.size()) *
                (0.5 * (31.0 / 96.0 * ch::kBvhBytesPerJointFrame + ch::kBvhBytesPerValue) + 1.0));
  const std::string gl = write_test_file(
      "buffers.gltf",
      R"({"asset": {"version": "2.0"}, "buffers": [{"uri": "a.bin", "byteLength": 1000000}]})");
  EXPECT_GE(ch::estimate_clip_memory(gl).bytes, 1e6 * ch::kImportBytesPerByte);
  const std::string fifo = (std::filesystem::path(gl).parent_path() / "clip_fifo.bvh").string();
  std::filesystem::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_EQ(ch::estimate_clip_memory(fifo).bytes, 0.0);
}

}  // namespace
