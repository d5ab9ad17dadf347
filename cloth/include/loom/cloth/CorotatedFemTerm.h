#pragma once
// Co-rotated linear FEM membrane (Müller & Gross 2004, "Interactive virtual materials"; Etzmuss, Keckeisen &
// Straßer 2003, "A fast finite element solution for cloth modelling") on constant-strain triangles, in the
// material (weft u, warp v) frame of each triangle (TriangleFrame::rest_uv).
// Per triangle (rest area A, deformation gradient F = [w_u w_v], 3x2, the Baraff-Witkin w_u, w_v):
//   polar decomposition F = R S, R (3x2) with orthonormal columns, S (2x2) symmetric positive definite;
//   closed form for 2x2: C = FᵀF, S = sqrt(C) = (C + sqrt(det C) I) / sqrt(tr C + 2 sqrt(det C)).
//   Strain in the rotated frame: ε = S - I (the linear strain of the unrotated displacement RᵀF - I).
//   Orthotropic linear elasticity, no Poisson coupling (Material carries none; the same law as
//   Baraff-Witkin's conditions at small strain), 2D moduli in N/m:
//     E = A (1/2 Y_u ε_uu² + 1/2 Y_v ε_vv² + 1/2 G γ²),  γ = 2 ε_uv,
//   Y_u = stretch_weft, Y_v = stretch_warp, G = shear. E depends on FᵀF only, so any rigid motion of a
//   stretched sheet rotates its forces with it and adds no force of its own.
// Forces: the exact gradient f_m = -∂E/∂x_m = -2 F Γ (a_m, b_m)ᵀ with Γ solving S Γ + Γ S = σ (σ = ∂E/∂S;
// the 2x2 Lyapunov equation of d(S²) = dC, solved in closed form). For an isotropic law this is the classical
// co-rotated force -R K (Rᵀx - X); for an orthotropic one it also carries the term from the rotation's
// dependence on x (σ and S do not commute), so forces stay conservative (the static solver and Newton
// line searches use the energy).
// Damping: stiffness-proportional (docs/references.md, "Fabric measurement"), d = -damping R K₀ Rᵀ v per
// triangle. Jacobians (JacobianOptions):
//   clamp_compression = false: exact df/dx (forward-mode AutoDiff of the analytic gradient, as the dihedral
//     term does), exact df/dv; what the finite-difference tests check.
//   clamp_compression = true (implicit solvers): the exact Hessian projected per triangle onto the negative
//     semi-definite matrices (its 9x9 eigenvalues clamped to <= 0), symmetric; df/dv = -damping R K₀ Rᵀ.
//     The standard co-rotational stiffness df/dx ≈ -R K₀ Rᵀ (K₀ the linear stiffness of the rest triangle in
//     its material plane, R held constant) is available with set_corotational_only(true): symmetric,
//     negative semi-definite, equal to the exact Hessian at zero strain for any rotation and O(strain) off
//     otherwise — but it has no stiffness against rotating a stretched triangle (the tension's geometric
//     stiffness, ∂R/∂x), and with it backward Euler at one step per frame blew the hanging sheet up (17 x 17
//     cotton, 60 Hz: max strain 8.97 within 1.5 s, test_corotated_fem.cpp); the projected Hessian keeps that
//     stiffness and is what solvers get by default. At zero strain the two coincide.
#include <memory>
#include <vector>

#include "loom/cloth/BaraffWitkinTerm.h"
#include "loom/cloth/BlockGather.h"
#include "loom/cloth/BlockScatter.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/ElementGather.h"
#include "loom/cloth/Material.h"
#include "loom/cloth/Term.h"

namespace loom::cloth {

class CorotatedFemTerm final : public Term {
 public:
  // Moduli in N/m; damping in s. Triangles: the rest data of make_bw_triangles (a, b; alpha² = rest area).
  CorotatedFemTerm(int num_vertices, std::vector<BwTriangle> triangles, double y_u, double y_v, double shear,
                   double damping);
  const char* name() const override { return "corotated_fem"; }
  double energy(const EvalContext& c) const override;
  void add_forces(const EvalContext& c, Vec3s& f) const override;
  void add_pattern(std::vector<std::pair<int, int>>& pairs) const override;
  void add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                     BlockMatrix* dfdv) const override;
  long work_items() const override { return static_cast<long>(tris_.size()); }
  // true: solvers (JacobianOptions::clamp_compression) get the standard co-rotational stiffness -R K₀ Rᵀ
  // instead of the projected exact Hessian (header).
  void set_corotational_only(bool on) { corotational_only_ = on; }

 private:
  void triangle_forces(int k, const EvalContext& c, Vec3* out) const;
  void triangle_blocks(int k, const EvalContext& c, const JacobianOptions& o, Mat3* kx, Mat3* kv) const;

  int n_;
  std::vector<BwTriangle> tris_;
  double y_u_, y_v_, g_;  // N/m
  double damping_;        // s
  bool corotational_only_ = false;
  ElementGather gather_;
  mutable Vec3s corner_force_;                       // scratch: 3 per triangle
  mutable std::vector<Mat3> dx_blocks_, dv_blocks_;  // scratch: 9 per triangle (row m, column n)
  mutable BlockScatter scatter_;
  mutable BlockGather gather_x_, gather_v_;  // slot lists of the df/dx and df/dv matrices (threads > 1)
};

std::unique_ptr<Term> make_corotated_fem_term(const ClothMesh& mesh, const Material& m);

}  // namespace loom::cloth
