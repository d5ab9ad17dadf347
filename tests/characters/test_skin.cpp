// Skin (linear blend skinning, validation, automatic weights) and SkinnedMesh (glTF 2.0, FBX, Collada through
// assimp). The assimp test models come from the Debian package assimp-testmodels (./loom.sh installs it).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "loom/characters/SkinnedMesh.h"
#include "loom/cloth/Error.h"

using namespace loom::characters;
using loom::cloth::Vec3;
using loom::cloth::Vec3s;

namespace {

const char* kSimpleSkin = "/usr/share/assimp/models/glTF2/simple_skin/simple_skin.gltf";
const char* kFbxSkin = "/usr/share/assimp/models/FBX/animation_with_skeleton.fbx";

#define SKIP_WITHOUT(path) \
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " missing (Debian package assimp-testmodels)"

// Expects `f` to throw loom::Error whose message contains `field` and `problem`.
template <class F>
void expect_error(F f, const std::string& field, const std::string& problem) {
  try {
    f();
    FAIL() << "no error for " << field;
  } catch (const loom::Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(field), std::string::npos) << m;
    EXPECT_NE(m.find(problem), std::string::npos) << m;
  }
}

Skin two_bone_skin(std::vector<std::vector<BoneInfluence>> inf) {
  return Skin({"a", "b"}, {Affine::Identity(), Affine::Identity()}, inf, "test.skin");
}

}  // namespace

TEST(Skin, LinearBlendOfTwoBones) {
  // Bone a stays, bone b is translated by (1, 0, 0) and turned 90 degrees about z around the origin.
  Affine ib = Affine::Identity();
  ib.translation() = Vec3(0, -1, 0);  // bone b's joint at (0, 1, 0) in bind space
  Skin skin({"a", "b"}, {Affine::Identity(), ib}, {{{0, 1.0}}, {{0, 0.5}, {1, 0.5}}, {{1, 1.0}}}, "t");
  Affine gb = Affine::Identity();
  gb.rotate(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()));
  gb.pretranslate(Vec3(0, 1, 0));  // joint stays at (0, 1, 0), bone turned
  std::vector<Affine> m;
  skin.skinning_matrices({Affine::Identity(), gb}, m);
  Vec3s out;
  skin.apply(m, {Vec3(1, 0, 0), Vec3(1, 2, 0), Vec3(0, 2, 0)}, out);
  EXPECT_NEAR((out[0] - Vec3(1, 0, 0)).norm(), 0.0, 1e-12);
  // Vertex 2 fully on b: (0, 2, 0) is (0, 1, 0) above the joint, turned to (-1, 0, 0) from it.
  EXPECT_NEAR((out[2] - Vec3(-1, 1, 0)).norm(), 0.0, 1e-12);
  // Vertex 1 half-half: mean of (1, 2, 0) and the joint + R (1, 1, 0) = (-1, 2, 0).
  EXPECT_NEAR((out[1] - Vec3(0, 2, 0)).norm(), 0.0, 1e-12);
}

TEST(Skin, RejectsBadSkinsNamingTheField) {
  expect_error([] { two_bone_skin({{{0, 0.5}, {1, 0.4}}}); }, "vertices[0].weights", "sum to 0.9");
  expect_error(
      [] {
        two_bone_skin({{{0, 0.5}, {2, 0.5}}});
      },
      "vertices[0].bones[1]", "bone 2 does not exist");
  expect_error([] { two_bone_skin({{{0, 1.0}}, {}}); }, "vertices[1].weights", "sum to 0");
  expect_error([] { two_bone_skin({{{0, 1.5}, {1, -0.5}}}); }, "vertices[0].weights[0]", "not in [0, 1]");
  expect_error([] { two_bone_skin({{{0, NAN}, {1, 1.0}}}); }, "vertices[0].weights[0]", "not in [0, 1]");
  expect_error(
      [] {
        two_bone_skin({{{0, 0.2}, {1, 0.2}, {0, 0.2}, {1, 0.2}, {0, 0.2}}});
      },
      "vertices[0]", "5 bone influences (at most 4)");
  Skin ok = two_bone_skin({{{0, 0.25}, {1, 0.75}}});
  std::vector<Affine> m;
  Affine nan_pose = Affine::Identity();
  nan_pose.translation().x() = NAN;
  expect_error(
      [&] {
        ok.skinning_matrices({Affine::Identity(), nan_pose}, m, "game");
      },
      "pose[1]", "not finite");
  expect_error([&] { ok.skinning_matrices({Affine::Identity()}, m, "game"); }, "pose", "1 bone transforms");
}

TEST(Skin, AutomaticWeightsFollowTheNearestBone) {
  // A chain of two bones along y: root at 0 to joint at 1, child from 1 to its end at 2.
  std::vector<Affine> bind(3, Affine::Identity());
  bind[1].translation() = Vec3(0, 1, 0);
  bind[2].translation() = Vec3(0, 2, 0);
  const Vec3s pts = {Vec3(0.1, 0.2, 0), Vec3(0.1, 1.8, 0), Vec3(0.1, 1.0, 0)};
  Skin skin = Skin::automatic(pts, {"root", "mid", "end"}, bind, {-1, 0, 1}, 2, "auto");
  auto weight_of = [&](int i, int bone) {
    double w = 0;
    for (int k = 0; k < Skin::kMaxInfluences; ++k)
      if (skin.bones(i)[k] == bone) w += skin.weights(i)[k];
    return w;
  };
  EXPECT_GT(weight_of(0, 0), 0.95);
  EXPECT_GT(weight_of(1, 1) + weight_of(1, 2), 0.95);
  // At the joint both bones are 0.1 m away: equal weights.
  EXPECT_NEAR(weight_of(2, 0), weight_of(2, 1), 1e-9);
  // Turning the whole skeleton rigidly turns the mesh rigidly.
  Affine turn = Affine::Identity();
  turn.rotate(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  turn.pretranslate(Vec3(3, -1, 2));
  std::vector<Affine> pose = {turn * bind[0], turn * bind[1], turn * bind[2]}, m;
  skin.skinning_matrices(pose, m);
  Vec3s out;
  skin.apply(m, pts, out);
  for (size_t i = 0; i < pts.size(); ++i) EXPECT_NEAR((out[i] - turn * pts[i]).norm(), 0.0, 1e-12);
  expect_error([&] { Skin::automatic(pts, {"a"}, {Affine::Identity()}, {-1}, 5, "auto"); }, "influences",
               "[1, 4]");
}

TEST(SkinnedMesh, ReadsTheGltfSimpleSkinAndFollowsItsAnimation) {
  SKIP_WITHOUT(kSimpleSkin);
  SkinnedMesh mesh = load_skinned_mesh(kSimpleSkin);
  ASSERT_EQ(mesh.positions.size(), 10u);
  EXPECT_EQ(mesh.triangles.size(), 8u);
  ASSERT_EQ(mesh.skin.num_bones(), 2);
  EXPECT_EQ(mesh.bone_parent[1], mesh.skin.find(mesh.skin.bone_names()[0]));
  // The file's weights: rows y = 0, 0.5, 1, 1.5, 2 have (w0, w1) = (1, 0), (0.75, 0.25), (0.5, 0.5),
  // (0.25, 0.75), (0, 1).
  for (int i = 0; i < 10; ++i) {
    const double y = mesh.positions[i].y();
    double w1 = 0;
    for (int k = 0; k < Skin::kMaxInfluences; ++k)
      if (mesh.skin.bones(i)[k] == 1) w1 += mesh.skin.weights(i)[k];
    EXPECT_NEAR(w1, y / 2.0, 1e-6) << "vertex " << i;
  }
  // Animated by the file's own clip (Motion): at 1 s the second joint has turned 90 degrees about z. The
  // inverse bind matrices put both joints at (0.5, 1, 0) while the nodes place them at (0, 1, 0): a vertex at
  // (x, 2, 0) fully on joint 2 goes to (0, 1, 0) + Rz(90)(x - 0.5, 1, 0) = (-1, 0.5 + x, 0).
  MotionSettings ms;
  ms.scale = 1.0;
  ms.place = false;
  Motion motion = Motion::load(kSimpleSkin, ms);
  const std::vector<int> joints = match_bones(mesh.skin, motion, kSimpleSkin);
  std::vector<Transform> g;
  motion.pose(1.0, g);
  std::vector<Affine> pose, m;
  pose_from_motion(joints, g, pose);
  mesh.skin.skinning_matrices(pose, m);
  Vec3s out;
  mesh.skin.apply(m, mesh.positions, out);
  int checked = 0;
  for (int i = 0; i < 10; ++i) {
    if (mesh.positions[i].y() != 2.0) continue;
    const double x = mesh.positions[i].x();
    EXPECT_NEAR((out[i] - Vec3(-1.0, 0.5 + x, 0.0)).norm(), 0.0, 1e-6)
        << "vertex " << i << ": " << out[i].transpose();
    ++checked;
  }
  EXPECT_EQ(checked, 2);
}

TEST(SkinnedMesh, ReadsAnFbxSkinAndNormalisesItsWeights) {
  SKIP_WITHOUT(kFbxSkin);
  SkinnedMesh mesh = load_skinned_mesh(kFbxSkin);
  EXPECT_EQ(mesh.skin.num_bones(), 13);
  EXPECT_EQ(mesh.skin.num_vertices(), static_cast<int>(mesh.positions.size()));
  EXPECT_GT(mesh.triangles.size(), 1000u);
  for (int i = 0; i < mesh.skin.num_vertices(); ++i) {
    double sum = 0;
    int used = 0;
    for (int k = 0; k < Skin::kMaxInfluences; ++k) {
      sum += mesh.skin.weights(i)[k];
      used += mesh.skin.bones(i)[k] >= 0;
    }
    ASSERT_NEAR(sum, 1.0, 1e-6);
    ASSERT_GE(used, 1);
  }
  // Two bone chains under the armature (Bone..., Bone.007...): two roots.
  int roots = 0;
  for (int p : mesh.bone_parent) roots += p < 0;
  EXPECT_EQ(roots, 2);
  // At the bind pose (every bone at B_b) the normalised weights give back the mesh itself.
  std::vector<Affine> bind(mesh.skin.num_bones()), m;
  for (int b = 0; b < mesh.skin.num_bones(); ++b) bind[b] = mesh.skin.inverse_bind()[b].inverse();
  mesh.skin.skinning_matrices(bind, m);
  Vec3s out;
  mesh.skin.apply(m, mesh.positions, out);
  for (size_t i = 0; i < out.size(); ++i) ASSERT_NEAR((out[i] - mesh.positions[i]).norm(), 0.0, 1e-9) << i;
}

TEST(SkinnedMesh, ReadsAColladaSkin) {
  const char* dae = "/usr/share/assimp/models/Collada/box_nested_animation.dae";
  SKIP_WITHOUT(dae);
  SkinnedMesh mesh = load_skinned_mesh(dae, -1, 0.5);
  ASSERT_EQ(mesh.skin.num_bones(), 1);
  EXPECT_EQ(mesh.skin.bone_names()[0], "Armature_Bone");
  EXPECT_EQ(mesh.triangles.size(), 12u);
  for (int i = 0; i < mesh.skin.num_vertices(); ++i) {
    EXPECT_EQ(mesh.skin.bones(i)[0], 0);
    EXPECT_DOUBLE_EQ(mesh.skin.weights(i)[0], 1.0);
  }
  // Moving the one bone by d moves every vertex by d (the scale applies to lengths only).
  Affine moved = mesh.skin.inverse_bind()[0].inverse();
  moved.pretranslate(Vec3(0.1, -0.2, 0.3));
  std::vector<Affine> m;
  mesh.skin.skinning_matrices({moved}, m);
  Vec3s out;
  mesh.skin.apply(m, mesh.positions, out);
  for (size_t i = 0; i < out.size(); ++i)
    EXPECT_NEAR((out[i] - mesh.positions[i] - Vec3(0.1, -0.2, 0.3)).norm(), 0, 1e-9);
}

TEST(SkinnedMesh, RejectsFilesWithoutSkinNamingThem) {
  const char* box = "/usr/share/assimp/models/FBX/box.fbx";
  SKIP_WITHOUT(box);
  expect_error([&] { load_skinned_mesh(box); }, box, "no skinned mesh");
  expect_error([&] { load_skinned_mesh(box, 7); }, "mesh", "out of range");
  expect_error([&] { load_skinned_mesh("/nonexistent.gltf"); }, "/nonexistent.gltf", "cannot read");
}
