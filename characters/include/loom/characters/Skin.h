#pragma once
// Skin: linear blend skinning of a mesh to a skeleton's bones, up to four bone influences per vertex.
//   x_i = Σ_k w_ik (G_b · B_b⁻¹) r_i,   b = bone of influence k,
// r_i the vertex in the mesh's bind space, G_b the bone's global transform in the current pose (world, m),
// B_b⁻¹ its inverse bind matrix (bind space to the bone's frame) and Σ_k w_ik = 1 (Magnenat-Thalmann,
// Laperrière, Thalmann 1988, "Joint-dependent local deformations"; the glTF 2.0 specification, "Skins").
// Transforms are general affine maps (the bind matrices of FBX files carry the exporter's scale).
#include <Eigen/Geometry>
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::characters {

using Affine = Eigen::Affine3d;

// One bone influence on one vertex.
struct BoneInfluence {
  int bone = 0;         // index into Skin::bone_names()
  double weight = 0.0;  // 1, in [0, 1]; the influences of a vertex sum to 1
};

class Skin {
 public:
  static constexpr int kMaxInfluences = 4;
  static constexpr double kWeightTolerance = 1e-6;  // |Σ w - 1| allowed

  Skin() = default;
  // Validates and stores the skin. Throws loom::Error(source, field, problem) naming the field:
  //   bones[b].inverse_bind   not finite
  //   vertices[i]             more than four influences
  //   vertices[i].bones[k]    a bone that does not exist
  //   vertices[i].weights[k]  a weight outside [0, 1] or not finite
  //   vertices[i].weights     weights that do not sum to 1 within kWeightTolerance (none at all included)
  Skin(std::vector<std::string> bone_names, std::vector<Affine> inverse_bind,
       const std::vector<std::vector<BoneInfluence>>& influences, const std::string& source = "");

  // Weights from the nearest bones, for a mesh that comes without a skin. Bone b is the segment from its
  // joint to the mean of its children's joints at the bind pose (a point when it has none); each vertex takes
  // the `influences` (1 to 4) bones nearest to it, weighted by w ∝ 1 / (d + ε)⁴ with d the distance to the
  // segment and ε = 1 mm, normalised to sum 1. `bind_global` are the bones' global transforms at the pose the
  // positions are in (inverse bind = their inverses); `parent[b]` is -1 or a bone before b.
  static Skin automatic(const cloth::Vec3s& positions, std::vector<std::string> bone_names,
                        const std::vector<Affine>& bind_global, const std::vector<int>& parent,
                        int influences = kMaxInfluences, const std::string& source = "");

  int num_vertices() const { return static_cast<int>(bones_.size()); }
  int num_bones() const { return static_cast<int>(bone_names_.size()); }
  const std::vector<std::string>& bone_names() const { return bone_names_; }
  const std::vector<Affine>& inverse_bind() const { return inverse_bind_; }
  // Influences of vertex i: slots with weight 0 have bone -1.
  const std::array<int, kMaxInfluences>& bones(int i) const { return bones_[i]; }
  const std::array<double, kMaxInfluences>& weights(int i) const { return weights_[i]; }
  // Index of the bone named `name` (-1 if absent).
  int find(const std::string& name) const;

  // Skinning matrices G_b B_b⁻¹ of a pose (one global transform per bone). Throws loom::Error(source,
  // "pose", ...) when the pose has the wrong number of bones, and (source, "pose[b]", ...) for a transform
  // that is not finite.
  void skinning_matrices(const std::vector<Affine>& pose, std::vector<Affine>& out,
                         const std::string& source = "") const;
  // x_i = Σ w (G B⁻¹) r_i for every vertex; `rest` has num_vertices() entries (bind space).
  void apply(const std::vector<Affine>& matrices, const cloth::Vec3s& rest, cloth::Vec3s& out) const;

 private:
  std::vector<std::string> bone_names_;
  std::vector<Affine> inverse_bind_;
  std::vector<std::array<int, kMaxInfluences>> bones_;
  std::vector<std::array<double, kMaxInfluences>> weights_;
};

}  // namespace loom::characters
