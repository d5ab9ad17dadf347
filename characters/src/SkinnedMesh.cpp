#include "loom/characters/SkinnedMesh.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>

#include "AssimpInput.h"
#include "loom/cloth/Error.h"

namespace loom::characters {

namespace {

Affine to_affine(const aiMatrix4x4& m) {
  Affine a = Affine::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) a.matrix()(r, c) = static_cast<double>(m[r][c]);
  return a;
}

// x -> S x S⁻¹ with S = scale I: the translation scales, the linear part stays.
Affine rescale(Affine a, double scale) {
  a.translation() *= scale;
  return a;
}

const aiScene* read(Assimp::Importer& importer, const std::string& path, SkinnedMesh& out) {
  const unsigned flags = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                         aiProcess_LimitBoneWeights | aiProcess_SortByPType;
  out.source = path;
  return read_with_assimp(importer, path, flags, "the mesh", out.files);
}

void read_geometry(const aiMesh* m, double scale, const Affine& transform, const std::string& path,
                   SkinnedMesh& out) {
  out.positions.resize(m->mNumVertices);
  for (unsigned i = 0; i < m->mNumVertices; ++i) {
    const aiVector3D& v = m->mVertices[i];
    out.positions[i] = transform * (scale * cloth::Vec3(v.x, v.y, v.z));
    if (!out.positions[i].allFinite())
      throw Error(path, "vertices[" + std::to_string(i) + "]", "position is not finite");
    // The coordinate bound of scenes and clips: past it no distance or pose fit is meaningful.
    constexpr double kMaxPosition = 1e6;  // m
    if (!(out.positions[i].cwiseAbs().maxCoeff() <= kMaxPosition)) {
      char where[96];
      std::snprintf(where, sizeof where, "(%g, %g, %g) m", out.positions[i].x(), out.positions[i].y(),
                    out.positions[i].z());
      throw Error(
          path, "vertices[" + std::to_string(i) + "]",
          std::string("position ") + where + " lies beyond +-1e6 m (after the file's node transform)");
    }
  }
  for (unsigned f = 0; f < m->mNumFaces; ++f) {
    const aiFace& face = m->mFaces[f];
    if (face.mNumIndices != 3) continue;  // points and lines (SortByPType leaves them out of triangle meshes)
    out.triangles.push_back({static_cast<int>(face.mIndices[0]), static_cast<int>(face.mIndices[1]),
                             static_cast<int>(face.mIndices[2])});
  }
  if (out.triangles.empty()) throw Error(path, "", "the mesh has no triangles");
}

const aiMesh* pick(const aiScene* scene, int mesh, bool need_bones, const std::string& path) {
  if (mesh >= 0) {
    if (mesh >= static_cast<int>(scene->mNumMeshes))
      throw Error(path, "mesh",
                  std::to_string(mesh) + " is out of range (the file has " +
                      std::to_string(scene->mNumMeshes) + " meshes)");
    if (need_bones && scene->mMeshes[mesh]->mNumBones == 0)
      throw Error(path, "mesh", "mesh " + std::to_string(mesh) + " has no skin (no bones)");
    return scene->mMeshes[mesh];
  }
  for (unsigned k = 0; k < scene->mNumMeshes; ++k)
    if (!need_bones || scene->mMeshes[k]->mNumBones > 0) return scene->mMeshes[k];
  throw Error(path, "", need_bones ? "the file has no skinned mesh" : "the file has no mesh");
}

}  // namespace

SkinnedMesh load_skinned_mesh(const std::string& path, int mesh, double scale) {
  if (!(scale > 0.0) || !std::isfinite(scale)) throw Error(path, "scale", "must be > 0");
  Assimp::Importer importer;
  SkinnedMesh out;
  const aiScene* scene = read(importer, path, out);
  const aiMesh* m = pick(scene, mesh, true, path);
  read_geometry(m, scale, Affine::Identity(), path, out);

  std::vector<std::string> names(m->mNumBones);
  std::vector<Affine> inverse_bind(m->mNumBones);
  std::vector<std::vector<BoneInfluence>> influences(m->mNumVertices);
  std::map<std::string, int> bone_index;
  for (unsigned b = 0; b < m->mNumBones; ++b) {
    const aiBone* bone = m->mBones[b];
    names[b] = bone->mName.C_Str();
    bone_index[names[b]] = static_cast<int>(b);
    inverse_bind[b] = rescale(to_affine(bone->mOffsetMatrix), scale);
    for (unsigned k = 0; k < bone->mNumWeights; ++k) {
      const aiVertexWeight& w = bone->mWeights[k];
      if (w.mVertexId >= m->mNumVertices)
        throw Error(path, "bones[" + std::to_string(b) + "].weights[" + std::to_string(k) + "]",
                    "vertex " + std::to_string(w.mVertexId) + " does not exist");
      if (w.mWeight == 0.0f) continue;  // glTF writes four slots per vertex, unused ones with weight 0
      influences[w.mVertexId].push_back({static_cast<int>(b), static_cast<double>(w.mWeight)});
    }
  }
  // Files store float weights, and some exporters (Blender's FBX) do not normalise them: each vertex's
  // weights are divided by their sum, as renderers do. A vertex without any weight is refused by Skin.
  for (auto& inf : influences) {
    double sum = 0.0;
    for (const auto& x : inf) sum += x.weight;
    if (sum > 0.0 && std::isfinite(sum))
      for (auto& x : inf) x.weight /= sum;
  }
  out.skin = Skin(names, inverse_bind, influences, path);

  // Rest pose and hierarchy from the node tree.
  out.bone_parent.assign(names.size(), -1);
  out.rest_pose.assign(names.size(), Affine::Identity());
  std::function<void(const aiNode*, const Affine&, int)> walk = [&](const aiNode* node, const Affine& parent,
                                                                    int parent_bone) {
    const Affine global = parent * to_affine(node->mTransformation);
    int bone = parent_bone;
    auto it = bone_index.find(node->mName.C_Str());
    if (it != bone_index.end()) {
      out.rest_pose[it->second] = rescale(global, scale);
      out.bone_parent[it->second] = parent_bone;
      bone = it->second;
    }
    for (unsigned c = 0; c < node->mNumChildren; ++c) walk(node->mChildren[c], global, bone);
  };
  walk(scene->mRootNode, Affine::Identity(), -1);
  return out;
}

SkinnedMesh load_static_mesh(const std::string& path, int mesh, double scale, const Affine& transform) {
  if (!(scale > 0.0) || !std::isfinite(scale)) throw Error(path, "scale", "must be > 0");
  Assimp::Importer importer;
  SkinnedMesh out;
  const aiScene* scene = read(importer, path, out);
  read_geometry(pick(scene, mesh, false, path), scale, transform, path, out);
  return out;
}

void skin_to_motion(SkinnedMesh& mesh, const Motion& motion, double t, int influences) {
  std::vector<Transform> joints;
  motion.pose(t, joints);
  std::vector<std::string> names;
  std::vector<Affine> bind;
  std::vector<int> parent;
  for (int j = 0; j < motion.num_joints(); ++j) {
    names.push_back(motion.joints()[j].name);
    bind.emplace_back(joints[j].matrix());
    parent.push_back(motion.joints()[j].parent);
  }
  mesh.skin = Skin::automatic(mesh.positions, names, bind, parent, influences, mesh.source);
  mesh.bone_parent = parent;
  mesh.rest_pose = bind;
}

std::vector<int> match_bones(const Skin& skin, const Motion& motion, const std::string& source) {
  std::vector<int> joint(skin.num_bones());
  for (int b = 0; b < skin.num_bones(); ++b) {
    joint[b] = motion.find(skin.bone_names()[b]);
    if (joint[b] < 0)
      throw Error(source, "bones[" + std::to_string(b) + "]",
                  "bone '" + skin.bone_names()[b] + "' is not a joint of " + motion.source());
  }
  return joint;
}

void pose_from_motion(const std::vector<int>& joint_of_bone, const std::vector<Transform>& joints,
                      std::vector<Affine>& pose) {
  pose.resize(joint_of_bone.size());
  for (size_t b = 0; b < joint_of_bone.size(); ++b) pose[b] = Affine(joints[joint_of_bone[b]].matrix());
}

}  // namespace loom::characters
