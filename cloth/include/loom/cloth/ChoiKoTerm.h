#pragma once
// Choi & Ko 2002, "Stable but responsive cloth", §3-4: fabric has no compression
// resistance and buckles at once.
//  - Type 1, sequential springs (structural + shear on grids, edges on meshes): Hooke springs in tension
//    only, E = k/2 (l - L)² for l >= L, 0 below; damping c along the spring.
//  - Type 2, interlaced springs (i <-> i+2 along warp, weft and both diagonals on grids; the two vertices
//    opposite each interior edge on meshes): act only under compression, with the buckling force of the
//    circular-arc model evaluated exactly (no polynomial fit):
//        l / L = sinc(y),  κ = 2y / L,  f_b = k_b κ² / (cos y - sinc y),  E_arc = 2 k_b y² / L,
//    limits f_b -> -12 k_b/L² (l -> L) and -4π² k_b/L² (l -> 0).
// Bending and membrane compression are measured apart [derived]. Let l_u be the
// unfolded chord: the length of the path i -> middle -> j on grids, the distance of i and j with the two
// hinge triangles laid flat on meshes (from the five edge lengths). Then
//  - bending ratio r = l / l_u <= 1 (= 1 exactly when flat, whatever the in-plane strain): the spring stores
//    the exact arc energy E_arc(r L), with no linear branch. Its gradient vanishes when flat, so there is
//    no force jump, and gentle bends get the full ½ B κ² (the chord-based measure with a linear branch
//    below a crossover curvature leaves them with E ∝ κ⁴, and a membrane stretched by the finite
//    f_b(L⁻) hides the bend: the cantilever comes out too soft);
//  - membrane ratio m = w / (1 + φ(w - 1)), w = l_u / l_u0 (φ(z) = z for z >= z0, 0 for z <= 0, C¹ between):
//    in-plane compression (m < 1) is resisted by the Choi-Ko force on the length m L, with the linear branch
//    f* = max(f_b, c_b (l - L)), c_b = 12 k_b / (ε* L³) (Blender's fbstar) that removes the jump at l = L.
//    The crossover strain ε* = (κ0 L)² / 24 is set per spring from a crossover curvature κ0 (1/m).
// E = E_arc(r L) + E*(m L). Jacobian: exact; with JacobianOptions::clamp_compression (Choi-Ko) the membrane
// part keeps only (dT/dl) ∇(mL)∇(mL)ᵀ and the bending part's 12x12 Hessian is projected onto its
// non-negative eigenvalues, so M - h²K stays positive definite and keeps the bending stiffness.
// Type-1 springs are tension only, as in Choi-Ko: the earlier deviation (compressed sequential springs as
// buckled arcs, against a sliding mode of the middle nodes) is not needed with this split; a strip shortened
// by 5% then stores no compression (tests/cloth/test_buckling.cpp).
#include <memory>

#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/ElementGather.h"
#include "loom/cloth/Material.h"
#include "loom/cloth/PairGather.h"
#include "loom/cloth/SpringTerm.h"
#include "loom/cloth/Term.h"

namespace loom::cloth {

namespace choi_ko {
// y in [0, π] with sinc(y) = ratio (ratio >= 1 gives 0, ratio <= 0 gives π). Newton with bisection guard.
double arc_half_angle(double ratio);
// The exact circular-arc buckling force f_b(l) (N, negative), its derivative (N/m) and energy (J).
double buckling_force(double l, double rest, double kb);
double buckling_force_derivative(double l, double rest, double kb);
double buckling_energy(double l, double rest, double kb);
// l*/L where the linear branch meets the curve, for crossover strain ε* (bisection; ε* < 0.3).
double crossover_ratio(double crossover_strain);
}  // namespace choi_ko

struct BucklingSpring {
  int i = 0, j = 0;
  double rest_length = 0.0;  // m
  double kb = 0.0;           // N·m, bending stiffness of the arc (energy k_b/2 ∫κ² ds)
  // The cloth between i and j: the middle node on grids (a = b), the hinge edge's ends on meshes; -1: none.
  // They define the unfolded chord l_u (see above); without them (a = -1) the spring sees its chord only.
  int a = -1, b = -1;
  double path_rest = 0.0;  // m, l_u at rest (= L for a flat rest state)
  // Filled by ChoiKoTerm from the crossover curvature:
  double cb = 0.0;        // N/m, slope of the linear branch
  double l_star = 0.0;    // m, where the linear branch meets the curve
  double e_offset = 0.0;  // J, energy of the linear branch at l_star minus E_arc(l_star)
};

class ChoiKoTerm final : public Term {
 public:
  // `crossover_curvature` κ0 (1/m): sets the membrane part's linear branch, c_b ∝ 1/(κ0² L⁵) (see above).
  // `sequential_kb` (optional, not used by make_choi_ko_term): gives compressed sequential springs the
  // buckled-arc response with these k_b (N·m) instead of none.
  ChoiKoTerm(int num_vertices, std::vector<Spring> sequential, std::vector<BucklingSpring> interlaced,
             double crossover_curvature = 4.0, double compensation_strain = 1e-5,
             std::vector<double> sequential_kb = {});
  const char* name() const override { return "choi_ko"; }
  double energy(const EvalContext& c) const override;
  void add_forces(const EvalContext& c, Vec3s& f) const override;
  void add_pattern(std::vector<std::pair<int, int>>& pairs) const override;
  void add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                     BlockMatrix* dfdv) const override;
  long work_items() const override { return static_cast<long>(sequential_.size() + interlaced_.size()); }

  const std::vector<Spring>& sequential() const { return sequential_; }
  const std::vector<BucklingSpring>& interlaced() const { return interlaced_; }
  // Tension T(l) (N) and dT/dl (N/m) of interlaced spring s at (effective) length l.
  double interlaced_tension(const BucklingSpring& s, double l) const;
  double interlaced_stiffness(const BucklingSpring& s, double l) const;
  double interlaced_energy(const BucklingSpring& s, double l) const;
  // The interlaced springs' bending part alone (the arc energy of r = l / l_u; see the header comment), J.
  double interlaced_bending_energy(const Vec3s& x) const;

 private:
  std::vector<Spring> sequential_;
  std::vector<BucklingSpring> interlaced_;
  double z0_ = 1e-5;  // φ's transition strain
  // Compression of sequential springs (empty: tension only): the same buckled-arc response as the
  // interlaced springs, with k_b for the spring's own length (see make_choi_ko_term).
  std::vector<BucklingSpring> seq_buckle_;
  void set_crossover(std::vector<BucklingSpring>& springs, double crossover_curvature) const;
  double sequential_tension(int k, double l) const;
  using Vec12 = Eigen::Matrix<double, 12, 1>;
  using Mat12 = Eigen::Matrix<double, 12, 12>;
  // Chord l and unfolded chord l_u of an interlaced spring with their gradients (and Hessians) over the
  // corners (i, j, a, b).
  struct SpringGeometry {
    double l = 0.0, lu = 0.0;  // m
    Vec12 gl, glu;
    Mat12 Hl, Hlu;
  };
  static bool has_path(const BucklingSpring& s);
  void geometry(const BucklingSpring& s, const Vec3s& x, bool hessian, SpringGeometry& g) const;
  // Bending ratio r = l / l_u and membrane ratio m(l_u) with dm/dl_u, d²m/dl_u² (see the header comment).
  void ratios(const BucklingSpring& s, const SpringGeometry& g, double& r, double& m, double& dm,
              double& ddm) const;
  double bending_tension(const BucklingSpring& s, double r) const;
  double bending_stiffness(const BucklingSpring& s, double r) const;
  double bending_energy(const BucklingSpring& s, double r) const;
  double spring_energy(const BucklingSpring& s, const Vec3s& x) const;
  void spring_derivatives(const BucklingSpring& s, const Vec3s& x, Vec12* grad, Mat12* hess,
                          bool project) const;
  PairGather gather_seq_;
  ElementGather gather_int_;
  mutable Vec3s seq_force_, int_force_;  // int_force_: 4 corners per interlaced spring
};

// The Choi-Ko model of a mesh and material: tension-only sequential springs from the mesh's structural/shear
// (grid) or edge springs with the stiffness mapping of SpringSet.h, interlaced springs with k_b from the
// bending rigidity so that the bending response does not depend on resolution or direction:
//   grid (warp, weft, both diagonals at every node): k_b = (8/9) B(φ) du dv / L. A taut strip is a polyline
//     kinked by α = κ du at every node, whose interlaced chord is shorter than l_u by L α²/8, not the smooth
//     arc's L (κL)²/24 (3/4 of it): hence 8/9 = 4/3 x the arc mapping's 2/3;
//   mesh (hinge pairs): a fold θ across the edge e shortens the chord by h_i h_j θ² / (2 l_u) (h: the heights
//     of i and j over e), and k_b = B(φ) |e| L³ / (6 h_i h_j (h_i + h_j)) makes the spring's energy the
//     dihedral hinge's (B/2) |e|²/(A1 + A2) θ² (DihedralBendingTerm.h), exact in every direction on
//     equilateral meshes.
std::unique_ptr<ChoiKoTerm> make_choi_ko_term(const ClothMesh& mesh, const Material& material);

}  // namespace loom::cloth
