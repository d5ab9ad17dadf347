#pragma once
// Desbrun, Schröder & Barr 1999, "Interactive animation of structured deformable objects",
// Graphics Interface: an approximate implicit step with a constant filter.
// clang-format off
//   H = the springs' linear part (zero rest length): H_ij = k_ij I, H_ii = -Σ_j k_ij I, so M - h² H = M + h² L.
//   Predictor:  (M + h² L + h L_c) Δv = h f(x_n, v_n)   (all forces, nonlinear), v+ = v + Δv, x+ = x + h v+,
//   where L_c = Σ c A Aᵀ filters the springs' damping the same way (our addition: the damping force is
//   explicit in f, and unfiltered it limits h to about 2 m / Σc).
// clang-format on
// Instead of the paper's dense inverse W = (M - h² H)⁻¹ the matrix is factorised once (sparse Cholesky,
// kinematic vertices eliminated) and refactorised only when h or the kinematic set changes.
// Corrector: the filter keeps linear momentum (the columns of L sum to zero) but not angular momentum.
// The internal spring forces (both ends free) are central and carry no torque, but their filtered response
// W h f_int does; a rigid rotation Δv_i -= ω × (x_i - x_c) of the free vertices, I ω = Σ m_i (x_i - x_c) ×
// (W h f_int)_i, removes it (one extra solve). Torques of gravity, drag and springs to kinematic vertices
// are genuine and kept.
// Heavily damped by design (docs/references.md, "Time integration").
#include <vector>

#include "loom/cloth/PairGather.h"
#include "loom/cloth/Solver.h"
#include "loom/cloth/SplitCholesky.h"
#include "loom/cloth/SpringTerm.h"

namespace loom::cloth {

class DesbrunSolver final : public Solver {
 public:
  explicit DesbrunSolver(bool angular_correction = true) : angular_correction_(angular_correction) {}
  const char* name() const override { return "desbrun"; }
  void check(const Cloth& cloth) const override;
  void step(Cloth& cloth, double t, double h, int threads) override;
  long factorizations() const { return factorizations_; }

 private:
  void prepare(const Cloth& cloth, double h);
  void correct_angular_momentum(const ClothState& s, double h, int threads);

  bool angular_correction_;
  SplitCholesky factor_;
  const Cloth* cloth_ = nullptr;
  double h_ = 0.0;               // s
  std::vector<char> kinematic_;  // 1 for inverse mass 0
  std::vector<Spring> springs_;
  PairGather gather_;       // springs incident to each vertex
  Vec3s spring_force_;      // N·s per spring, on its end i (angular correction)
  std::vector<int> index_;  // free index per vertex, -1 for kinematic
  int num_free_ = 0;
  long factorizations_ = 0;
  Vec3s f_;                             // N
  Eigen::MatrixX3d rhs_, dv_, dv_int_;  // N·s, m/s (free rows)
};

}  // namespace loom::cloth
