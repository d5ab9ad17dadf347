#pragma once
// SkinnedMesh: a triangle mesh and its Skin read with assimp from any format assimp reads with skins
// (glTF 2.0, FBX, Collada), or a mesh without bones skinned to a Motion's skeleton with automatic weights
// (Skin.h). Vertices with more than four influences keep the four largest, renormalised (assimp's
// aiProcess_LimitBoneWeights), and each vertex's weights are divided by their sum (exporters such as
// Blender's FBX writer do not normalise them); identical vertices are welded and polygons triangulated.
#include <string>
#include <vector>

#include "loom/characters/Motion.h"
#include "loom/characters/Skin.h"

namespace loom::characters {

struct SkinnedMesh {
  std::string source;
  std::vector<std::string> files;  // every file read: the file itself and any it references (.bin buffers)
  cloth::Vec3s positions;          // m, bind space (file units times the scale)
  std::vector<cloth::Tri> triangles;
  Skin skin;
  std::vector<int> bone_parent;   // per skin bone: the nearest ancestor among the skin's bones (-1: none)
  std::vector<Affine> rest_pose;  // per skin bone: global transform at the file's node rest pose (m)
};

// Reads mesh `mesh` of the file (-1: the first mesh with bones) and its skin; lengths times `scale` (m per
// file unit). Throws loom::Error naming the file for a read failure, a file without a skinned mesh (or an
// out-of-range `mesh`), or an invalid skin (Skin's fields, e.g. "vertices[12].weights").
SkinnedMesh load_skinned_mesh(const std::string& path, int mesh = -1, double scale = 1.0);

// Reads mesh `mesh` (-1: the first) of a file as a static mesh (positions times `scale`, then `transform`),
// for automatic skinning. Throws loom::Error naming the file.
SkinnedMesh load_static_mesh(const std::string& path, int mesh = -1, double scale = 1.0,
                             const Affine& transform = Affine::Identity());

// Skins `mesh` (its positions and triangles; any skin it has is replaced) to every joint of `motion` with
// automatic weights at the motion's pose at simulated time `t` (Skin::automatic). Bone b is joint b.
void skin_to_motion(SkinnedMesh& mesh, const Motion& motion, double t = 0.0,
                    int influences = Skin::kMaxInfluences);

// Joint of `motion` for each bone of `skin`, matched by name. Throws loom::Error(source, "bones[b]", ...) for
// a bone that is not a joint of the motion.
std::vector<int> match_bones(const Skin& skin, const Motion& motion, const std::string& source = "");
// Pose of the skin's bones from the motion's global joint transforms (`joint_of_bone` from match_bones).
void pose_from_motion(const std::vector<int>& joint_of_bone, const std::vector<Transform>& joints,
                      std::vector<Affine>& pose);

}  // namespace loom::characters
