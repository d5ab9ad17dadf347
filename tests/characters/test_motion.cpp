// Skeleton and animation loading: sampling against assimp's own data, evaluated independently.
#include <assimp/scene.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <sstream>

#include "CharacterTestUtil.h"
#include "TestDir.h"
#include "loom/characters/Motion.h"
#include "loom/cloth/Error.h"

namespace {

using loom::characters::Motion;
using loom::characters::MotionSettings;
using loom::characters::Transform;
using Vec3 = Eigen::Vector3d;
using Mat4 = Eigen::Matrix4d;

// Rotation matrix of a unit quaternion, written out (not Eigen's conversion): the reference path.
Mat4 quat_matrix(double w, double x, double y, double z) {
  const double n = std::sqrt(w * w + x * x + y * y + z * z);
  w /= n, x /= n, y /= n, z /= n;
  Mat4 m = Mat4::Identity();
  m(0, 0) = 1 - 2 * (y * y + z * z), m(0, 1) = 2 * (x * y - w * z), m(0, 2) = 2 * (x * z + w * y);
  m(1, 0) = 2 * (x * y + w * z), m(1, 1) = 1 - 2 * (x * x + z * z), m(1, 2) = 2 * (y * z - w * x);
  m(2, 0) = 2 * (x * z - w * y), m(2, 1) = 2 * (y * z + w * x), m(2, 2) = 1 - 2 * (x * x + y * y);
  return m;
}

// Joint positions (file units) at key k: assimp's node tree with each channel's k-th keys, in double.
// Also the same product in assimp's own float matrices (aiMatrix4x4, aiQuaternion::GetMatrix).
void reference_positions(const aiScene* scene, unsigned k, std::map<std::string, Vec3>& exact,
                         std::map<std::string, Vec3>& assimp_float) {
  std::map<std::string, const aiNodeAnim*> ch;
  const aiAnimation* a = scene->mAnimations[0];
  for (unsigned c = 0; c < a->mNumChannels; ++c) ch[a->mChannels[c]->mNodeName.C_Str()] = a->mChannels[c];
  std::function<void(const aiNode*, const Mat4&, const aiMatrix4x4&)> walk =
      [&](const aiNode* n, const Mat4& parent, const aiMatrix4x4& parent_f) {
        Mat4 local = Mat4::Identity();
        aiMatrix4x4 local_f = n->mTransformation;
        auto it = ch.find(n->mName.C_Str());
        if (it != ch.end()) {
          const aiNodeAnim* c = it->second;
          const aiVectorKey& p = c->mPositionKeys[std::min(k, c->mNumPositionKeys - 1)];
          const aiQuatKey& q = c->mRotationKeys[std::min(k, c->mNumRotationKeys - 1)];
          local = quat_matrix(q.mValue.w, q.mValue.x, q.mValue.y, q.mValue.z);
          local(0, 3) = p.mValue.x, local(1, 3) = p.mValue.y, local(2, 3) = p.mValue.z;
          local_f = aiMatrix4x4(q.mValue.GetMatrix());
          local_f.a4 = p.mValue.x, local_f.b4 = p.mValue.y, local_f.c4 = p.mValue.z;
        } else {
          for (int r = 0; r < 4; ++r)
            for (int cc = 0; cc < 4; ++cc) local(r, cc) = n->mTransformation[r][cc];
        }
        const Mat4 g = parent * local;
        const aiMatrix4x4 gf = parent_f * local_f;
        exact[n->mName.C_Str()] = g.block<3, 1>(0, 3);
        assimp_float[n->mName.C_Str()] = Vec3(gf.a4, gf.b4, gf.c4);
        for (unsigned i = 0; i < n->mNumChildren; ++i) walk(n->mChildren[i], g, gf);
      };
  walk(scene->mRootNode, Mat4::Identity(), aiMatrix4x4());
}

void expect_matches_assimp(const std::string& file) {
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(file, 0);
  ASSERT_TRUE(scene && scene->mNumAnimations == 1);
  MotionSettings ms;
  ms.place = false;  // the clip's own coordinates, scaled
  const Motion m = Motion::load(file, ms);
  const double tps = scene->mAnimations[0]->mTicksPerSecond;
  const unsigned keys = scene->mAnimations[0]->mChannels[0]->mNumRotationKeys;
  ASSERT_GT(keys, 1000u);
  EXPECT_NEAR(m.duration(), (keys - 1) / tps, 1e-12);
  std::vector<Transform> pose;
  double worst = 0.0, worst_float = 0.0;
  for (unsigned k : {0u, 1u, 2u, 100u, keys / 3, keys / 2, keys - 2, keys - 1}) {
    std::map<std::string, Vec3> exact, fl;
    reference_positions(scene, k, exact, fl);
    m.clip_pose(scene->mAnimations[0]->mChannels[0]->mRotationKeys[k].mTime / tps, pose);
    for (int j = 0; j < m.num_joints(); ++j) {
      const Vec3 ref = exact.at(m.joints()[j].name) * m.scale();
      worst = std::max(worst, (pose[j].translation() - ref).norm());
      worst_float =
          std::max(worst_float, (pose[j].translation() - fl.at(m.joints()[j].name) * m.scale()).norm());
    }
  }
  const double height = m.rest_height();
  EXPECT_LE(worst, 1e-9 * height) << file;        // independent double evaluation of assimp's keys
  EXPECT_LE(worst_float, 1e-5 * height) << file;  // assimp's own float matrices (float rounding)
}

TEST(Motion, SamplingAtKeysReproducesAssimpJointPositions_01_01) {
  expect_matches_assimp(loom::test::mocap("01_01.bvh"));
}
TEST(Motion, SamplingAtKeysReproducesAssimpJointPositions_Boxing) {
  expect_matches_assimp(loom::test::mocap("Boxing_Toes.bvh"));
}

// The root's first frame as written in the BVH text (its first three channels), scaled to metres.
TEST(Motion, RootPositionMatchesTheBvhText) {
  const std::string file = loom::test::mocap("01_01.bvh");
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line) && line.rfind("Frame Time", 0) != 0) {
  }
  std::getline(in, line);
  std::istringstream ls(line);
  Vec3 first;
  ls >> first.x() >> first.y() >> first.z();
  MotionSettings ms;
  ms.place = false;
  const Motion m = Motion::load(file, ms);
  std::vector<Transform> pose;
  m.clip_pose(0.0, pose);
  EXPECT_LE((pose[m.find("Hips")].translation() - first * m.scale()).norm(), 1e-6 * m.rest_height());
}

// Between keys: positions lerp, rotations slerp; at the midpoint the slerp is the normalised quaternion sum.
TEST(Motion, InterpolatesBetweenKeys) {
  MotionSettings ms;
  ms.place = false;
  const Motion m = Motion::load(loom::test::mocap("01_01.bvh"), ms);
  const int arm = m.find("LeftForeArm"), hips = m.find("Hips");
  const auto& tr = m.track(arm);
  const size_t k = 700;
  const double tm = 0.5 * (tr.rotation_times[k] + tr.rotation_times[k + 1]);
  Eigen::Quaterniond q0 = tr.rotations[k], q1 = tr.rotations[k + 1];
  if (q0.dot(q1) < 0.0) q1.coeffs() = -q1.coeffs();
  const Eigen::Quaterniond mid(Eigen::Vector4d((q0.coeffs() + q1.coeffs()).normalized()));
  EXPECT_LE((m.local(arm, tm).linear() - mid.toRotationMatrix()).norm(), 1e-12);
  const auto& ht = m.track(hips);
  const Vec3 p_mid = 0.5 * (ht.positions[k] + ht.positions[k + 1]);
  EXPECT_LE(
      (m.local(hips, 0.5 * (ht.position_times[k] + ht.position_times[k + 1])).translation() - p_mid).norm(),
      1e-12);
}

// Units: the CMU clip (inch-like units) and the Biovision clip (cm) both become ~1.7 m figures.
TEST(Motion, AutomaticScaleGivesHumanHeight) {
  const Motion cmu = Motion::load(loom::test::mocap("01_01.bvh"));
  const Motion box = Motion::load(loom::test::mocap("Boxing_Toes.bvh"));
  std::cout << "scale: 01_01 " << cmu.scale() << " m/unit, Boxing_Toes " << box.scale() << " m/unit\n";
  EXPECT_NEAR(box.scale(), 0.01, 0.001);  // the file is in centimetres
  EXPECT_GT(cmu.scale(), 0.04);
  EXPECT_LT(cmu.scale(), 0.09);
  for (const Motion* m : {&cmu, &box}) {
    std::vector<Transform> pose;
    m->pose(0.0, pose);
    double lo = 1e9, hi = -1e9;
    for (const Transform& t : pose)
      lo = std::min(lo, t.translation().y()), hi = std::max(hi, t.translation().y());
    EXPECT_NEAR(lo, 0.0, 1e-12);  // placed on the floor
    EXPECT_GT(hi - lo, 1.4);
    EXPECT_LT(hi - lo, 1.8);
    EXPECT_NEAR(pose[m->root()].translation().x(), 0.0, 1e-12);
    EXPECT_NEAR(pose[m->root()].translation().z(), 0.0, 1e-12);
  }
  MotionSettings fixed;
  fixed.scale = 0.02;
  EXPECT_DOUBLE_EQ(Motion::load(loom::test::mocap("Boxing_Toes.bvh"), fixed).scale(), 0.02);
}

TEST(Motion, RootMotionOffKeepsTheRootInPlace) {
  MotionSettings off;
  off.root_motion = false;
  const Motion m = Motion::load(loom::test::mocap("Boxing_Toes.bvh"), off);
  const Motion on = Motion::load(loom::test::mocap("Boxing_Toes.bvh"));
  std::vector<Transform> pose, pose_on;
  double travelled = 0.0;
  for (double t = 0.0; t < 20.0; t += 0.5) {
    m.pose(t, pose);
    on.pose(t, pose_on);
    EXPECT_NEAR(pose[m.root()].translation().x(), 0.0, 1e-12);
    EXPECT_NEAR(pose[m.root()].translation().z(), 0.0, 1e-12);
    EXPECT_NEAR(pose[m.root()].translation().y(), pose_on[on.root()].translation().y(), 1e-12);
    const Vec3 d = pose_on[on.root()].translation();
    travelled = std::max(travelled, std::hypot(d.x(), d.z()));
  }
  EXPECT_GT(travelled, 0.2);  // the clip itself does move (footwork)
}

TEST(Motion, SpeedLoopAndStart) {
  const std::string file = loom::test::mocap("01_01.bvh");
  MotionSettings base;
  base.place = false;
  MotionSettings fast = base;
  fast.speed = 2.0;
  MotionSettings looped = base;
  looped.loop = true;
  MotionSettings late = base;
  late.start = 3.0;
  const Motion m = Motion::load(file, base), mf = Motion::load(file, fast), ml = Motion::load(file, looped),
               ms = Motion::load(file, late);
  std::vector<Transform> a, b;
  m.pose(2.5, a);
  mf.pose(1.25, b);
  for (size_t j = 0; j < a.size(); ++j) EXPECT_LE((a[j].translation() - b[j].translation()).norm(), 1e-12);
  m.pose(4.0, a);
  ms.pose(1.0, b);
  for (size_t j = 0; j < a.size(); ++j) EXPECT_LE((a[j].translation() - b[j].translation()).norm(), 1e-12);
  // Past the end: held (no loop) or wrapped with the cycle's root displacement added (loop).
  m.pose(m.duration() + 5.0, a);
  m.pose(m.duration(), b);
  for (size_t j = 0; j < a.size(); ++j) EXPECT_LE((a[j].translation() - b[j].translation()).norm(), 1e-12);
  ml.pose(1.0, a);
  ml.pose(1.0 + m.duration(), b);
  Vec3 shift = (m.local(m.root(), m.duration()).translation() - m.local(m.root(), 0.0).translation());
  shift.y() = 0.0;
  for (size_t j = 0; j < a.size(); ++j)
    EXPECT_LE((b[j].translation() - a[j].translation() - shift).norm(), 1e-9);
}

TEST(Motion, ErrorsNameTheFile) {
  try {
    Motion::load("/nonexistent/clip.bvh");
    FAIL();
  } catch (const loom::Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/clip.bvh"), std::string::npos);
  }
  MotionSettings bad;
  bad.speed = 0.0;
  EXPECT_THROW(Motion::load(loom::test::mocap("01_01.bvh"), bad), loom::Error);
}

}  // namespace

namespace {

// A crafted BVH whose joints nest 10,000 deep is refused by name before any reader recurses into it (it
// crashed the reader's stack before); a skeleton within the limit still loads.
TEST(Motion, DeeplyNestedJointsAreRefusedNamingTheHierarchy) {
  auto write_chain = [](const std::string& name, int depth) {
    const std::string path = (loom::test::test_dir() / name).string();
    std::ofstream f(path);
    f << "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation "
         "Xrotation "
         "Yrotation\n";
    for (int i = 0; i < depth; ++i)
      f << "JOINT j" << i << "\n{\nOFFSET 0 0.01 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n";
    f << "End Site\n{\nOFFSET 0 0.01 0\n}\n";
    for (int i = 0; i <= depth; ++i) f << "}\n";
    f << "MOTION\nFrames: 1\nFrame Time: 0.0083333\n";
    for (int i = 0; i < 6 + 3 * depth; ++i) f << "0 ";
    f << "\n";
    return path;
  };
  MotionSettings ms;
  try {
    Motion::load(write_chain("deep.bvh", 10000), ms);
    FAIL() << "a 10,000-deep skeleton was accepted";
  } catch (const loom::Error& e) {
    EXPECT_NE(std::string(e.what()).find("HIERARCHY"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("deep.bvh"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(Motion::load(write_chain("chain.bvh", 40), ms));
}

}  // namespace

namespace {

using loom::test::error_of;

// A one-joint BVH (6 channels) with `frames` declared and `body` as the MOTION numbers.
std::string write_bvh(const std::string& name, const std::string& frames, const std::string& body) {
  const std::string path = (loom::test::test_dir() / name).string();
  std::ofstream(path) << "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition "
                         "Zrotation Xrotation Yrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: "
                      << frames << "\nFrame Time: 0.1\n"
                      << body;
  return path;
}

// A BVH's MOTION section is one frame per line, each line exactly the joints' CHANNELS count, Frames lines
// in all: a count that disagrees with the data (a joint's CHANNELS changed without its numbers, frames
// wrapped or run together, numbers past the last frame) is refused by line, never read misaligned.
TEST(Motion, FrameLinesMustMatchFramesAndChannels) {
  MotionSettings ms;
  ms.scale = 1.0;
  const Motion clip =
      Motion::load(write_bvh("lines.bvh", "3", "0 0 0 0 0 0\n\n1 0 0 0 0 0\r\n2 0 0 0 0 0\n\n"), ms);
  EXPECT_EQ(clip.track(clip.root()).position_times.size(), 3u);
  EXPECT_NEAR(clip.duration(), 0.2, 1e-6);  // assimp keeps the frame time in single precision
  EXPECT_NEAR(clip.track(clip.root()).positions[2].x(), 2.0, 1e-9);
  // The MOTION section starts on line 13 (the frame time's line).
  std::string e = error_of(
      [&] { Motion::load(write_bvh("one_line.bvh", "3", "0 0 0 0 0 0 1 0 0 0 0 0 2 0 0 0 0 0\n"), ms); });
  EXPECT_NE(e.find("one_line.bvh: line 14: frame 1 holds 18 numbers, but the joints' CHANNELS add up to 6 "
                   "(one frame per line)"),
            std::string::npos)
      << e;
  e = error_of([&] { Motion::load(write_bvh("split.bvh", "2", "0 0 0\n0 0 0\n1 0\n0\n0 0 0\n"), ms); });
  EXPECT_NE(e.find("split.bvh: line 14: frame 1 holds 3 numbers, but the joints' CHANNELS add up to 6"),
            std::string::npos)
      << e;
  e = error_of(
      [&] { Motion::load(write_bvh("short.bvh", "4", "0 0 0 0 0 0\n1 0 0 0 0 0\n2 0 0 0 0 0\n"), ms); });
  EXPECT_NE(
      e.find("short.bvh: Frames: says 4 frames but the MOTION section holds 3 frame lines (of 6 numbers "
             "each)"),
      std::string::npos)
      << e;
  // One frame line past the count (an exporter's off-by-one) is not read; two are refused.
  const Motion extra = Motion::load(write_bvh("extra.bvh", "1", "0 0 0 0 0 0\n1 0 0 0 0 0\n"), ms);
  EXPECT_EQ(extra.track(extra.root()).position_times.size(), 1u);
  e = error_of(
      [&] { Motion::load(write_bvh("long.bvh", "1", "0 0 0 0 0 0\n1 0 0 0 0 0\n2 0 0 0 0 0\n"), ms); });
  EXPECT_NE(e.find("long.bvh: line 16: frame line 3, but Frames says 1"), std::string::npos) << e;
  const std::string after = (loom::test::test_dir() / "after.bvh").string();
  std::ofstream(after)
      << "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition "
         "Zrotation Xrotation Yrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 1\n"
         "Frame Time: 0.1 0 0 0 0 0 0\n";
  e = error_of([&] { Motion::load(after, ms); });
  EXPECT_NE(e.find("after.bvh: line 13: numbers after the frame time"), std::string::npos) << e;
  for (const char* count : {"-1", "2x", "1e3", "99999999999999999999"}) {
    e = error_of([&] { Motion::load(write_bvh("count.bvh", count, "0 0 0 0 0 0\n"), ms); });
    EXPECT_NE(
        e.find("count.bvh: Frames: expected a whole number of frames (got '" + std::string(count) + "')"),
        std::string::npos)
        << e;
  }
}

// A glTF clip whose buffers are separate files: every file assimp opens is recorded (a checkpoint hashes
// them) and each passes the input-file checks (a buffer that is a device is refused by name).
TEST(Motion, GltfExternalBuffersAreRecordedAndChecked) {
  const char* kSimpleSkin = "/usr/share/assimp/models/glTF2/simple_skin/simple_skin.gltf";
  if (!std::ifstream(kSimpleSkin)) GTEST_SKIP() << kSimpleSkin << " not installed (assimp-testmodels)";
  std::stringstream ss;
  ss << std::ifstream(kSimpleSkin).rdbuf();
  std::string text = ss.str();
  // Each embedded base64 buffer becomes its own file buf<k>.bin.
  auto decode = [](const std::string& b64) {
    std::string out;
    int bits = 0;
    unsigned acc = 0;  // the undecoded bits (at most 14 of them), kept small
    for (char c : b64) {
      const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
      const char* at = std::strchr(abc, c);
      if (c == '=' || !at || !c) break;
      acc = ((acc << 6) | static_cast<unsigned>(at - abc)) & 0xffffu;
      bits += 6;
      if (bits >= 8) {
        bits -= 8;
        out.push_back(static_cast<char>((acc >> bits) & 0xff));
      }
    }
    return out;
  };
  namespace fs = std::filesystem;
  const fs::path dir = loom::test::test_dir();
  const std::string prefix = "data:application/gltf-buffer;base64,";
  std::vector<std::string> bins;
  for (size_t at = text.find(prefix); at != std::string::npos; at = text.find(prefix)) {
    const size_t end = text.find('"', at);
    const std::string name = "buf" + std::to_string(bins.size()) + ".bin";
    std::ofstream(dir / name, std::ios::binary)
        << decode(text.substr(at + prefix.size(), end - at - prefix.size()));
    text.replace(at, end - at, name);
    bins.push_back((dir / name).string());
  }
  ASSERT_FALSE(bins.empty());
  std::ofstream(dir / "clip.gltf") << text;
  MotionSettings ms;
  ms.scale = 1.0;
  const Motion m = Motion::load((dir / "clip.gltf").string(), ms);
  EXPECT_GT(m.duration(), 0.0);
  for (const std::string& b : bins)
    EXPECT_NE(std::find(m.files().begin(), m.files().end(), b), m.files().end()) << b << " not recorded";
  EXPECT_EQ(m.files().front(), (dir / "clip.gltf").string());
  // A buffer that is a pipe (opening it would block for ever, even to test that it exists) or a folder is
  // refused, naming the buffer and the clip.
  ASSERT_EQ(mkfifo((dir / "pipe.bin").c_str(), 0600), 0);
  fs::create_directories(dir / "folder.bin");
  for (const char* buffer : {"pipe.bin", "folder.bin"}) {
    std::string bad = text;
    bad.replace(bad.find("buf0.bin"), 8, buffer);
    std::ofstream(dir / "bad.gltf") << bad;
    const std::string e = error_of([&] { Motion::load((dir / "bad.gltf").string(), ms); });
    EXPECT_NE(e.find("bad.gltf: cannot read motion: a file it references is refused: "), std::string::npos)
        << e;
    EXPECT_NE(e.find((dir / buffer).string()), std::string::npos) << e;
  }
}

}  // namespace
