#pragma once
// Static equilibrium by energy minimisation (Feynman 1986, Breen et al. 1994): every step minimises the
// total potential E(x) = sum of the conservative terms (elastic + bending + gravity + loads) with the pins at
// their targets for t + h, by Newton's method with a backtracking (Armijo) line search. The Hessian is
// -df/dx with the positive-semi-definite options (compressed springs' transverse terms clamped), plus a
// Levenberg shift mu I that grows when the factorisation fails or the step is not a descent direction.
// Sparse LDLᵀ (Eigen SimplicialLDLT) over the free degrees of freedom. Velocities are zero after a step.
// The equilibrium does not depend on the step: Simulation runs one step per frame (warm-started from the
// last frame's shape) unless a pin follows a path, whose substeps are then continuation steps.
// It cannot use non-conservative terms (drag): check() says so when the scene is loaded.
#include "loom/cloth/Solver.h"

namespace loom::cloth {

struct StaticSettings {
  int max_iterations = 100;  // Newton iterations per step
  double tolerance =
      1e-8;  // stop when max |force| on free vertices < tolerance * (total weight + 1e-12) (N/N)
};

class StaticSolver final : public Solver {
 public:
  explicit StaticSolver(StaticSettings s = {}) : s_(s) {}
  const char* name() const override { return "static"; }
  void check(const Cloth& cloth) const override;
  void step(Cloth& cloth, double t, double h, int threads) override;

  // Diagnostics of the last step.
  int last_iterations() const { return last_iterations_; }
  double last_residual() const { return last_residual_; }  // N, max |force| on free vertices

 private:
  double total_energy(const Cloth& cloth, const Vec3s& x, int threads) const;
  StaticSettings s_;
  int last_iterations_ = 0;
  double last_residual_ = 0.0;
};

}  // namespace loom::cloth
