#pragma once
// Hybrid detail (Oshita & Makinouchi 2001, "Real-time cloth simulation with sparse particles and curved
// faces"): the coarse mesh is simulated, and the surface that is shown (OBJ frames, exports, renders) is a
// smooth refined mesh rebuilt from the coarse positions every frame.
// Curved faces: PN triangles (Vlachos, Peters, Boyd & Mitchell 2001, "Curved PN triangles") — per coarse
// triangle a cubic Bézier patch from the three corner positions P_i and area-weighted vertex normals N_i:
//   b300 = P1, b030 = P2, b003 = P3,  w_ij = (P_j - P_i)·N_i,
//   b210 = (2 P1 + P2 - w12 N1)/3, b120 = (2 P2 + P1 - w21 N2)/3, b021 = (2 P2 + P3 - w23 N2)/3,
//   b012 = (2 P3 + P2 - w32 N3)/3, b102 = (2 P3 + P1 - w31 N3)/3, b201 = (2 P1 + P3 - w13 N1)/3,
//   E = (b210 + b120 + b021 + b012 + b102 + b201)/6, V = (P1 + P2 + P3)/3, b111 = E + (E - V)/2,
//   b(w, u, v) = Σ b_ijk 3!/(i! j! k!) wⁱ uʲ vᵏ   (w, u, v: barycentric weights of P1, P2, P3).
// The patch interpolates the corners; along an edge it depends only on that edge's two corners and their
// normals, so neighbouring patches meet (C0), and it is a smooth function of the coarse positions, so the fine
// surface moves continuously with them (no popping). The fine topology is `levels` 1:4 subdivisions of every
// coarse triangle (4^levels fine triangles each); fine vertices sit at fixed barycentric coordinates of one
// coarse triangle.
#include <memory>
#include <string>
#include <vector>

#include "loom/cloth/ClothMesh.h"

namespace loom::cloth {

// `cloths[i].detail` of a scene.
struct DetailSettings {
  std::string method = "curved_faces";  // the only method
  int levels = 2;                       // 1:4 subdivisions of each coarse triangle (0-5)
};

class CurvedFaces {
 public:
  // Throws loom::Error(file, where + ".levels", ...) for levels outside 0-5.
  CurvedFaces(const ClothMesh& coarse, int levels, const std::string& file = "", const std::string& where = "detail");

  int levels() const { return levels_; }
  // The fine mesh: topology, rest shape (the curved surface of the coarse rest positions) and material
  // frames (the coarse triangle's warp/weft).
  const std::shared_ptr<const ClothMesh>& fine_mesh() const { return fine_; }
  // Fine positions from coarse positions (m).
  void evaluate(const Vec3s& coarse_x, Vec3s& fine_x) const;
  // The fine vertex that coincides with coarse vertex i.
  int fine_vertex_of(int coarse_vertex) const { return coarse_to_fine_[coarse_vertex]; }

 private:
  struct Sample {
    int tri = 0;     // coarse triangle
    Vec3 bary{};     // weights of its corners
  };
  void vertex_normals(const Vec3s& x, Vec3s& normals) const;

  std::vector<Tri> coarse_tris_;
  int coarse_n_ = 0;
  int levels_;
  std::vector<Sample> samples_;  // per fine vertex
  std::vector<int> coarse_to_fine_;
  std::shared_ptr<const ClothMesh> fine_;
  mutable Vec3s normals_;  // scratch
};

}  // namespace loom::cloth
