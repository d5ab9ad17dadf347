#pragma once
// Choi & Ko 2002, "Stable but responsive cloth" (reference/methods.md §1.6): fabric has no compression
// resistance and buckles at once.
//  - Type 1, sequential springs (structural + shear on grids, edges on meshes): Hooke springs in tension
//    only, E = k/2 (l - L)² for l >= L, 0 below; damping c along the spring.
//  - Type 2, interlaced springs (i <-> i+2 along warp, weft and both diagonals on grids; the two vertices
//    opposite each interior edge on meshes): act only under compression, with the buckling force of the
//    circular-arc model evaluated exactly (no polynomial fit):
//        l / L = sinc(y),  κ = 2y / L,  f_b = k_b κ² / (cos y - sinc y),  E_arc = 2 k_b y² / L,
//    limits f_b -> -12 k_b/L² (l -> L) and -4π² k_b/L² (l -> 0). Near l = L a linear branch
//    f* = max(f_b, c_b (l - L)), c_b = 12 k_b / (ε* L³), removes the force jump (Blender's fbstar).
//    The crossover strain is set per spring from a physical crossover curvature κ0 (1/m):
//    ε* = (κ0 L)² / 24, the compression of a spring bent to κ0. Bends sharper than κ0 follow the exact
//    curve at every resolution, and the energy the linear branch leaves out is the fraction (κ0/κ)²/2
//    whatever L is. (A fixed ε*, as in Blender, makes fine meshes fall back to the linear branch: the
//    compression of an ordinary fold, κ²L²/24, shrinks with L² — methods.md §1.6.)
// Stretch compensation [derived]: the arc model needs the chord l and the arc length; Choi-Ko takes the
// arc length as the rest length L. A membrane stretched by z (tension from gravity, a pull) lengthens the
// chord by (1 + z) and so hides compressions below z: because f_b(L⁻) = -12 k_b/L² is finite, a strip in
// bending then stretches its sequential springs by ~B/(Y L²) instead of compressing its interlaced ones
// (fine meshes lose the bending response). So the interlaced spring sees the effective length
// l_eff = l / (1 + φ(P/P0 - 1)), P the current path length through the middle cloth, with φ(z) = z for
// z >= z0, 0 for z <= 0 and 2z²/z0 - z³/z0² between (C¹, φ(z) <= z). Compression (z < 0) is not
// compensated: in-plane compression stays resisted by the buckling force, as in Choi-Ko.
// Tension T(l) = dE/dl; the force on end i is T x̂. Jacobian: (dT/dl) x̂x̂ᵀ + (T/l)(I - x̂x̂ᵀ); with
// JacobianOptions::clamp_compression the transverse part of compressed springs is dropped (Choi-Ko), which
// keeps M - h²K positive definite since dT/dl >= 0 everywhere.
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
  // Stretch compensation: the chord is compared with the rest length scaled by the stretch of the path
  // i -> a -> j, i -> b -> j (see ChoiKoTerm), so that a stretched membrane does not hide a bend.
  int a = -1, b = -1;
  double path_rest = 0.0;    // m, rest length of that path, ½ (|ia| + |aj| + |ib| + |bj|)
  // Filled by ChoiKoTerm from the crossover curvature:
  double cb = 0.0;           // N/m, slope of the linear branch
  double l_star = 0.0;       // m, where the linear branch meets the curve
  double e_offset = 0.0;     // J, energy of the linear branch at l_star minus E_arc(l_star)
};

class ChoiKoTerm final : public Term {
 public:
  // `crossover_curvature` κ0 (1/m): bends gentler than this use the linear branch (see above). Larger κ0
  // softens the linear branch (c_b ∝ 1/(κ0² L⁵)) at the price of more energy left out of gentle bends.
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
  void ratios(const BucklingSpring& s, const SpringGeometry& g, double& r, double& m, double& dm, double& ddm) const;
  double bending_tension(const BucklingSpring& s, double r) const;
  double bending_stiffness(const BucklingSpring& s, double r) const;
  double bending_energy(const BucklingSpring& s, double r) const;
  double spring_energy(const BucklingSpring& s, const Vec3s& x) const;
  void spring_derivatives(const BucklingSpring& s, const Vec3s& x, Vec12* grad, Mat12* hess, bool project) const;
  PairGather gather_seq_;
  ElementGather gather_int_;
  mutable Vec3s seq_force_, int_force_;  // int_force_: 4 corners per interlaced spring
};

// The Choi-Ko model of a mesh and material: sequential springs from the mesh's structural/shear (grid) or
// edge springs with the stiffness mapping of SpringSet.h, interlaced springs with k_b from the bending
// rigidity so that the bending response does not depend on resolution:
//   grid (warp, weft, both diagonals at every node): k_b = (2/3) B(φ) du dv / L
//   mesh (hinge pairs, three directions per vertex): k_b = (8/3) B(φ) A_e / L, A_e = (A1 + A2) / 3
// Sequential springs under compression [deviation from the tension-only type 1 of methods.md §1.6]: a
// compressed sequential spring acts as a buckled arc of its own length (the circular-arc force with
// k_b = B(φ) A_e / L, A_e its area share), i.e. it yields at the sub-grid Euler load instead of carrying
// linear compression. Purely tension-only springs leave the middle node of every interlaced pair free to
// slide along the line under compression (a zero-energy mode): measured on a 41-node strip shortened by
// 5%, single sequential springs collapsed by 44-70%.
// Both follow from matching Σ ½ k_b L κ_n² (κ_n = κ cos²θ, Euler) to ½ B κ² per area for every bend direction.
std::unique_ptr<ChoiKoTerm> make_choi_ko_term(const ClothMesh& mesh, const Material& material);

}  // namespace loom::cloth
