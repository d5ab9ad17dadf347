#pragma once
// Dihedral-angle bending on the hinges of a triangle mesh (Bridson, Marino & Fedkiw 2003).
// Hinge stencil (x1, x2 opposite vertices; x3 -> x4 the shared edge):
//
//          x1
//         /  \          θ: signed angle between the triangle normals n1, n2 about ê = (x4 - x3)/|x4 - x3|,
//       x3 ---- x4         sin θ = (n1 × n2)·ê, cos θ = n1·n2 (0 when flat)
//         \  /
//          x2
//
//   E_e = (B(φ)/2) |e|²/(A1 + A2) (θ - θ̄)²   (|e|, A1, A2, θ̄ at rest)
// which reproduces 1/2 B κ² per unit area for axis-aligned bends on grids and for any bend on equilateral
// meshes. B(φ) = bend_weft d_u² + bend_warp d_v², d the in-plane unit direction across the edge in material
// space (curvature along the weft costs bend_weft). The gradient of θ is Bridson, Marino & Fedkiw 2003
// (eq. 2-5, their u_1..u_4, with ∂θ/∂x_i = -u_i for our sign of θ). Damping: d = -k_d ∇θ θ̇ with
// k_d = material.damping * B(φ)|e|²/(A1 + A2).
// Jacobians: JacobianOptions::clamp_compression = true gives the Gauss-Newton (projected) Hessian
// K = -2 k_b ∇θ∇θᵀ, negative semi-definite, for implicit solvers; false gives the exact Hessian of θ
// (forward-mode automatic differentiation of the analytic gradient, Eigen AutoDiff; slower), which is what
// the finite-difference test checks. damping_position_terms adds -k_d (H θ̇ + ∇θ (H v)ᵀ) (exact mode only).
#include <memory>
#include <vector>

#include "loom/cloth/BlockGather.h"
#include "loom/cloth/BlockScatter.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/ElementGather.h"
#include "loom/cloth/Material.h"
#include "loom/cloth/Term.h"

namespace loom::cloth {

struct BendHinge {
  std::array<int, 4> v{};   // x1 = o0, x2 = o1, x3 = e0, x4 = e1
  double k = 0.0;           // N·m, k_b = B(φ)/2 |e|²/(A1 + A2): E = k_b (θ - θ̄)²
  double rest_angle = 0.0;  // rad, θ̄
};

// Signed dihedral angle of the stencil (rad).
double dihedral_angle(const Vec3& x1, const Vec3& x2, const Vec3& x3, const Vec3& x4);

class DihedralBendingTerm final : public Term {
 public:
  DihedralBendingTerm(int num_vertices, std::vector<BendHinge> hinges, double damping);
  const char* name() const override { return "dihedral_bending"; }
  double energy(const EvalContext& c) const override;
  void add_forces(const EvalContext& c, Vec3s& f) const override;
  void add_pattern(std::vector<std::pair<int, int>>& pairs) const override;
  void add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                     BlockMatrix* dfdv) const override;
  long work_items() const override { return static_cast<long>(hinges_.size()); }
  const std::vector<BendHinge>& hinges() const { return hinges_; }

 private:
  // The 4x4 df/dx blocks of hinge k (row i, column j at 4 i + j) and, if kv, its df/dv blocks.
  void hinge_blocks(int k, const EvalContext& c, const JacobianOptions& o, Mat3* kx, Mat3* kv) const;

  int n_;
  std::vector<BendHinge> hinges_;
  double damping_;  // s
  ElementGather gather_;
  mutable Vec3s corner_force_;                       // scratch: 4 per hinge
  mutable std::vector<Mat3> dx_blocks_, dv_blocks_;  // scratch: 16 per hinge
  mutable BlockScatter scatter_;
  mutable BlockGather gather_x_, gather_v_;  // threaded assembly (ElementJacobians.h)
};

std::unique_ptr<Term> make_dihedral_bending_term(const ClothMesh& mesh, const Material& m);

}  // namespace loom::cloth
