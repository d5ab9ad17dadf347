#pragma once
// Position-based solvers on the cloth's springs (constraint C = l - L per spring), Müller et al. 2007;
// Macklin et al. 2016. One step: predict p = x + h v + h² M⁻¹ f_ext (f_ext: gravity, drag), project the
// constraints Gauss-Seidel style for `iterations` sweeps, then v = (p - x)/h, x = p. Springs are coloured so
// that no two springs of one colour share a vertex; a colour is projected in parallel, with results
// independent of the thread count. Kinematic vertices (inverse mass 0) have weight 0, so they move by exactly
// x += h v. Sub-stepping with one iteration per substep (Macklin et al. 2019, "Small steps") is `iterations:
// 1` with more `substeps`.
#include <vector>

#include "loom/cloth/Solver.h"
#include "loom/cloth/SpringTerm.h"

namespace loom::cloth {

// Shared set-up: the springs, their colouring and the scratch arrays, rebuilt when the cloth changes.
// springs_ holds the springs colour by colour (colour c is [color_start_[c], color_start_[c + 1])), each
// colour sorted by its springs' lower vertex index so that a sweep reads positions nearly in order. Springs
// of one colour share no vertex, so their order within the colour does not change any result. One step is one
// parallel region: each thread projects its static share of a colour, then all wait at a barrier before the
// next colour.
class PositionBasedSolver : public Solver {
 public:
  explicit PositionBasedSolver(int iterations) : iterations_(iterations) {}
  void check(const Cloth& cloth) const override;
  void step(Cloth& cloth, double t, double h, int threads) override;
  int iterations() const { return iterations_; }

 protected:
  // Projects springs_[begin, end) (all of one colour) onto their constraints, in place on p_.
  virtual void project(int begin, int end, const ClothState& s, double h) = 0;
  // Called by every thread of the step's team with its share [begin, end) of springs_, before any projection.
  virtual void begin_step(int /*begin*/, int /*end*/) {}

  int iterations_;
  const Cloth* prepared_for_ = nullptr;
  std::vector<Spring> springs_;
  std::vector<int> color_start_;
  Vec3s p_;  // m, predicted / projected positions
  Vec3s f_;  // N, external forces

 private:
  void prepare(const Cloth& cloth);
};

// Müller et al. 2007, "Position based dynamics": Δp_i = -k' s w_i ∇_i C, s = C / Σ_j w_j |∇_j C|², with
// k' = 1 - (1 - k)^(1/iterations) so the stiffness k in [0, 1] does not depend on the iteration count
// (for linear cases). The springs' physical k is not used; the result depends on h and iterations.
class PbdSolver final : public PositionBasedSolver {
 public:
  PbdSolver(int iterations, double stiffness);
  const char* name() const override { return "pbd"; }

 private:
  void project(int begin, int end, const ClothState& s, double h) override;
  double k_iter_;  // 1, per-iteration stiffness k'
};

// Macklin et al. 2016, "XPBD" (eq. 18, with damping), with physical compliance from each spring's k:
//   α = scale / k (m/N), α̃ = α / h², λ reset to 0 every step,
//   Δλ = (-C - α̃ λ - γ ∇C·(p - x_n)) / ((1 + γ) ∇C M⁻¹ ∇Cᵀ + α̃),  p += M⁻¹ ∇Cᵀ Δλ.
// Damping: the spring's force -(k C + c Ċ) ∇C, with Ċ ≈ ∇C·(p - x_n)/h, gives γ = β / h, β = c / k (s);
// this is Macklin's γ = α̃ β̃ / h written with the spring's own damping coefficient.
// `compliance_scale` 0 makes every spring inextensible (zero compliance).
class XpbdSolver final : public PositionBasedSolver {
 public:
  XpbdSolver(int iterations, double compliance_scale);
  const char* name() const override { return "xpbd"; }

 private:
  void begin_step(int begin, int end) override;
  void project(int begin, int end, const ClothState& s, double h) override;
  double compliance_scale_;     // 1, multiplies α = 1/k
  std::vector<double> lambda_;  // N·s², accumulated Lagrange multiplier per spring (order of springs_)
};

}  // namespace loom::cloth
