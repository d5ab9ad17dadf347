#pragma once
// Baraff & Witkin 1998 §4: triangle stretch and shear as condition functions.
// Per triangle, with rest (u, v) from TriangleFrame::rest_uv (metres; u = weft, v = warp):
//   w_u = sum_m a_m x_m, w_v = sum_m b_m x_m  (the deformation gradient's columns; a, b from the rest uv)
//   stretch: C = α (|w_u| - 1, |w_v| - 1),  E = k_u/2 C_u² + k_v/2 C_v²   (k_u = stretch_weft, k_v =
//   stretch_warp) shear:   C = α w_u·w_v,                   E = k_s/2 C²                 (k_s = shear)
// α = sqrt(rest area), so E = k/2 A ε²: k is a 2D modulus in N/m and refinement does not change the
// material (Baraff & Witkin 1998 §4). Damping is stiffness-proportional: d = -k_d (∂C/∂x)ᵀ Ċ with
// k_d = material.damping * k (docs/references.md, "Fabric measurement").
// Jacobians: exact by default (what the finite-difference tests check). JacobianOptions:
//   clamp_compression:      stretch: (|w| - 1)/|w| in the transverse term clamped to >= 0 (as for springs);
//                           shear: the C ∂²C term, indefinite for any C, is dropped (Gauss-Newton).
//                           Both make K negative semi-definite, so M - h D - h² K is positive definite.
//   damping_position_terms: include d(damping force)/dx (exact, non-symmetric).
#include <memory>
#include <vector>

#include "loom/cloth/BlockGather.h"
#include "loom/cloth/BlockScatter.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/ElementGather.h"
#include "loom/cloth/Material.h"
#include "loom/cloth/Term.h"

namespace loom::cloth {

// Precomputed rest data of one triangle.
struct BwTriangle {
  Tri v{};                         // vertex indices
  std::array<double, 3> a{}, b{};  // 1/m, ∂w_u/∂x_m = a_m I, ∂w_v/∂x_m = b_m I
  double alpha = 0.0;              // m, sqrt(rest uv area)
};

std::vector<BwTriangle> make_bw_triangles(const ClothMesh& mesh);

class BaraffWitkinTerm final : public Term {
 public:
  enum class Kind { kStretch, kShear };
  // Stiffnesses in N/m; damping in s (k_d = damping * k).
  BaraffWitkinTerm(Kind kind, int num_vertices, std::vector<BwTriangle> triangles, double k_u, double k_v,
                   double k_shear, double damping);
  const char* name() const override { return kind_ == Kind::kStretch ? "bw_stretch" : "bw_shear"; }
  double energy(const EvalContext& c) const override;
  void add_forces(const EvalContext& c, Vec3s& f) const override;
  void add_pattern(std::vector<std::pair<int, int>>& pairs) const override;
  void add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                     BlockMatrix* dfdv) const override;
  long work_items() const override { return static_cast<long>(tris_.size()); }

 private:
  // The 3x3 df/dx and df/dv blocks of triangle k (row m, column n at 3 m + n).
  void triangle_blocks(int k, const EvalContext& c, const JacobianOptions& o, Mat3* kx, Mat3* kv) const;

  Kind kind_;
  int n_;
  std::vector<BwTriangle> tris_;
  double k_u_, k_v_, k_s_;  // N/m
  double damping_;          // s
  ElementGather gather_;
  mutable Vec3s corner_force_;                       // scratch: 3 per triangle
  mutable std::vector<Mat3> dx_blocks_, dv_blocks_;  // scratch: 9 per triangle (row m, column n)
  mutable BlockScatter scatter_;
  mutable BlockGather gather_x_, gather_v_;  // slot lists of the df/dx and df/dv matrices (threads > 1)
};

// The stretch and shear terms of a cloth's mesh and material.
std::unique_ptr<Term> make_bw_stretch_term(const ClothMesh& mesh, const Material& m);
std::unique_ptr<Term> make_bw_shear_term(const ClothMesh& mesh, const Material& m);

}  // namespace loom::cloth
