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
// normals, so neighbouring patches meet (C0), and it is a smooth function of the coarse positions, so the
// fine surface moves continuously with them (no popping). The fine topology is `levels` 1:4 subdivisions of
// every coarse triangle (4^levels fine triangles each); fine vertices sit at fixed barycentric coordinates of
// one coarse triangle.
//
// Optional geometric wrinkles (in the spirit of Oshita & Makinouchi's wrinkles from shortened edges and of
// wrinkle maps, Hadap et al. 1999): the fine surface is displaced along the interpolated vertex normal by
//   h(X) = A(q1) Σ_k w_k cos(2π d_k·m(X) / λ),   d_k = (cos kπ/4, sin kπ/4), k = 0..3,
// where m is a material coordinate (m, warp/weft) unfolded once from the coarse rest mesh, Q the 2x2
// compression tensor Σ_i max(0, 1 - s_i) e_i e_iᵀ of each coarse triangle (s_i, e_i: principal stretches and
// directions of FᵀF in its warp/weft frame) averaged per vertex by area and interpolated barycentrically,
// q1 ≥ q2 its eigenvalues, θ the angle of its principal direction (mod π); the weights share θ linearly in
// angle between its two nearest d_k (hat functions of width π/4), blended with equal weights 1/4 by the
// isotropy: w_k = a hat_k(θ) + (1 - a)/4, a = (q1 - q2)/q1 (θ is undefined only where a = 0). A wave along
// d_k has its crests perpendicular to d_k, so uniaxial compression along a d_k gives straight crests
// perpendicular to the compression axis. The amplitude keeps the arc length of a compressed line: a sine of
// amplitude A and wavelength λ is longer than its chord by about (πA/λ)², so A(q) = (λ/π) √(q / (1 - q)),
// capped at `amplitude`. Everything is a continuous function of the coarse positions and of per-vertex values
// (continuous across coarse triangles and in time), the phases are fixed in material space (the wrinkles
// do not swim), and there are none where nothing is compressed. Wavelengths shorter than about four fine
// edges are not resolved by the fine mesh (aliasing). Seams of the unfolding (closed tubes) distort the
// phase in the triangles where it closes, without a jump.
#include <memory>
#include <string>
#include <vector>

#include "loom/cloth/ClothMesh.h"

namespace loom::cloth {

struct WrinkleSettings {
  bool enabled = false;
  double amplitude = 0.01;   // m, the largest wrinkle amplitude
  double wavelength = 0.05;  // m
};

// `cloths[i].detail` of a scene.
struct DetailSettings {
  std::string method = "curved_faces";  // the only method
  int levels = 2;                       // 1:4 subdivisions of each coarse triangle (0-5)
  WrinkleSettings wrinkles;             // "wrinkles": {"amplitude", "wavelength"}; off without the key
};

class CurvedFaces {
 public:
  // Throws loom::Error(file, where + ".levels", ...) for levels outside 0-5.
  CurvedFaces(const ClothMesh& coarse, int levels, const std::string& file = "",
              const std::string& where = "detail");

  int levels() const { return levels_; }
  // Turns the geometric wrinkles on (enabled) or off. Throws loom::Error for a non-positive wavelength or a
  // negative amplitude.
  void set_wrinkles(const WrinkleSettings& w, const std::string& file = "",
                    const std::string& where = "detail");
  // The wrinkle height (m, along the normal) of every fine vertex at the last evaluate() (zeros without
  // wrinkles).
  const std::vector<double>& wrinkle_heights() const { return heights_; }
  // Wrinkle height of fine vertex i computed from coarse triangle `tri` at barycentric weights `bary` (for
  // tests: the two triangles on a shared edge give the same value there). Uses the last evaluate()'s
  // per-vertex compression.
  double wrinkle_height(int tri, const Vec3& bary) const;
  // The fine mesh: topology, rest shape (the curved surface of the coarse rest positions) and material
  // frames (the coarse triangle's warp/weft).
  const std::shared_ptr<const ClothMesh>& fine_mesh() const { return fine_; }
  // Fine positions from coarse positions (m).
  void evaluate(const Vec3s& coarse_x, Vec3s& fine_x) const;
  // The fine vertex that coincides with coarse vertex i.
  int fine_vertex_of(int coarse_vertex) const { return coarse_to_fine_[coarse_vertex]; }
  // Where fine vertex i sits: its coarse triangle and the barycentric weights of that triangle's corners (to
  // carry per-vertex data such as skin weights or weight maps from the coarse mesh to the fine one).
  int sample_triangle(int fine_vertex) const { return samples_[fine_vertex].tri; }
  const Vec3& sample_weights(int fine_vertex) const { return samples_[fine_vertex].bary; }
  const std::vector<Tri>& coarse_triangles() const { return coarse_tris_; }

 private:
  struct Sample {
    int tri = 0;  // coarse triangle
    Vec3 bary{};  // weights of its corners
  };
  void vertex_normals(const Vec3s& x, Vec3s& normals) const;
  void vertex_compression(const Vec3s& x) const;  // fills compression_

  std::vector<Tri> coarse_tris_;
  int coarse_n_ = 0;
  int levels_;
  std::vector<Sample> samples_;  // per fine vertex
  std::vector<int> coarse_to_fine_;
  std::shared_ptr<const ClothMesh> fine_;
  mutable Vec3s normals_;  // scratch
  // Wrinkles.
  WrinkleSettings wrinkles_;
  std::vector<Vec2> material_;               // per coarse vertex, m (unfolded warp/weft coordinates)
  std::vector<std::array<Vec2, 3>> tri_uv_;  // per coarse triangle: its rest_uv (m)
  std::vector<double> vertex_area_;          // per coarse vertex: sum of its triangles' rest areas (m²)
  mutable std::vector<Eigen::Matrix2d> compression_;  // per coarse vertex, 1 (2x2 tensor in warp/weft)
  mutable std::vector<double> heights_;               // per fine vertex, m
};

}  // namespace loom::cloth
