#pragma once
// Liu et al. 2013, "Fast simulation of mass-spring systems" = projective dynamics on springs (Bouaziz et al.
// 2014), Liu et al. 2013 §4. One backward Euler step minimises
//   g(x) = ½ (x - y)ᵀ M (x - y) + h² Σ_s ½ k_s (|x_j - x_i| - L_s)² + (h/2) Σ_s c_s |Δ_s(x - x_n)|²,
//   y = x_n + h v_n + h² M⁻¹ f_ext  (f_ext: gravity, drag at the start of the step),
// by alternating
// clang-format off
//   local:  d_s = L_s (x_j - x_i) / |x_j - x_i|            (Liu 2013, local step, ½k(l - L)² = min_|d|=L ½k|Δx - d|²)
//   global: (M + h² L_k + h L_c) x = M y + h² J d + h L_c x_n  (Liu 2013, global step; L = Σ k A Aᵀ, J = Σ k A Sᵀ).
// clang-format on
// The damping term is the springs' damping c_s applied isotropically to the relative displacement (a
// constant, Rayleigh-like matrix L_c = Σ c A Aᵀ, so the prefactorisation stays valid); with c = 0 the fixed
// point is exactly the backward Euler step of the spring energy. Every iteration decreases g (block
// coordinate descent); plain iterations converge linearly.
// Kinematic vertices are eliminated: their x = x_n + h v is moved to the right-hand side. The global matrix
// is factorised once with Eigen's SimplicialLLT and refactorised only when h, a spring's k or c, or the set
// of kinematic vertices changes.
// Chebyshev acceleration (Wang 2015): after `warmup` plain iterations,
//   q_{k+1} = ω_{k+1} (q̂_{k+1} - q_{k-1}) + q_{k-1},  ω_S = 2/(2 - ρ²),  ω_{k+1} = 4/(4 - ρ² ω_k),
// with ρ the estimated spectral radius of the plain iteration (err low).
// Optional triangle strain limiting (Bouaziz et al. 2014, strain constraint): per triangle the energy
//   (w A / 2) |F - T|², F = deformation gradient (3x2, rest uv frame), T = U clamp(Σ, 1 - τ, 1 + τ) Vᵀ
// from the SVD of F; zero while both principal stretches are within [1 - τ, 1 + τ], a stiff spring back to
// the band outside it. It adds w A Σ (g_m·g_n) to the constant matrix, so the factorisation stays valid.
#include <vector>

#include "loom/cloth/PairGather.h"
#include "loom/cloth/Solver.h"
#include "loom/cloth/SplitCholesky.h"
#include "loom/cloth/SpringTerm.h"

namespace loom::cloth {

struct ProjectiveSettings {
  int iterations = 10;        // local/global iterations per step
  bool chebyshev = false;     // Wang 2015 acceleration
  double rho = 0.9;           // 1, spectral radius estimate for Chebyshev
  int warmup = 3;             // plain iterations before Chebyshev starts (Wang's S)
  double strain_limit = 0.0;  // 1, τ of the triangle strain projection; 0 = off
  double strain_stiffness =
      0.0;  // N/m, w of the strain projection; 0 = 100 x the material's larger stretch modulus
};

// One local/global iteration's measurements (only when recording is on; for tests and studies).
struct ProjectiveIteration {
  double objective = 0.0;  // J·s², g(x) after the global step
  double residual = 0.0;   // N·s², |∇g(x)| over free vertices: the backward Euler residual times h²
};

class ProjectiveSolver final : public Solver {
 public:
  explicit ProjectiveSolver(ProjectiveSettings settings) : settings_(settings) {}
  const char* name() const override { return "projective"; }
  void check(const Cloth& cloth) const override;
  void step(Cloth& cloth, double t, double h, int threads) override;

  const ProjectiveSettings& settings() const { return settings_; }
  long factorizations() const { return factorizations_; }
  // Records objective and residual after every iteration of the next steps (costs one energy evaluation).
  void record_iterations(bool on) { record_ = on; }
  // Entry 0 is the initial guess x = y, then one entry per iteration (of the last step).
  const std::vector<ProjectiveIteration>& last_iterations() const { return trace_; }

 private:
  void prepare(const Cloth& cloth, double h);
  void add_strain_projection(const ClothState& s, double h, Eigen::MatrixX3d& rhs) const;
  double strain_energy(const ClothState& s, Vec3s* gradient) const;  // J; gradient += dE/dx if given
  ProjectiveIteration measure(const ClothState& s, double h, int threads);

  ProjectiveSettings settings_;
  // Factorisation and what it was built for.
  SplitCholesky factor_;
  const Cloth* cloth_ = nullptr;
  double h_ = 0.0;               // s
  std::vector<char> kinematic_;  // 1 for inverse mass 0
  std::vector<Spring> springs_;
  PairGather gather_;       // per-vertex sums of per-spring terms
  std::vector<int> index_;  // free index per vertex, -1 for kinematic
  // Triangle strain projection (when strain_limit > 0): per triangle the corner weights g_m (1/m, F = Σ x_m
  // g_mᵀ) and w A (N·m).
  std::vector<Tri> triangles_;
  std::vector<std::array<Vec2, 3>> tri_g_;
  std::vector<double> tri_weight_;
  int num_free_ = 0;
  long factorizations_ = 0;
  // Per-step scratch.
  Vec3s f_, y_, x_n_, spring_rhs_, gradient_;
  Eigen::MatrixX3d base_rhs_, rhs_, q_, q_prev_, q_hat_;
  bool record_ = false;
  std::vector<ProjectiveIteration> trace_;
};

}  // namespace loom::cloth
