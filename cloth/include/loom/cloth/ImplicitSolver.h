#pragma once
// Implicit integrators (Baraff & Witkin 1998 §3; Choi & Ko 2002 for BDF2;
// docs/references.md, "Time integration"):
//  - implicit_euler: Baraff & Witkin 1998 backward Euler, M(v+ - v) = h f(x+, v+), x+ = x + h v+.
//  - bdf2:           Choi & Ko 2002 second-order BDF, x+ - 4/3 x + 1/3 x- = 2h/3 v+ and
//                    v+ - 4/3 v + 1/3 v- = 2h/3 M⁻¹ f+; variable-step coefficients when h changes
//                    (ω = h/h_prev: 1, (1+ω)²/(1+2ω), ω²/(1+2ω), γ = h (1+ω)/(1+2ω)); the first step after
//                    construction or reset() is backward Euler.
// Both are one scheme: with (x_b, v_b, γ) = (x, v, h) for backward Euler and the BDF2 combinations above,
//   M (v+ - v_b) = γ f(x_b + γ v+, v+),   x+ = x_b + γ v+.
// newton_iterations = 1 (default): the linearised step, f(x+, v+) ≈ f + K (x+ - x) + D (v+ - v), i.e.
//   (M - γD - γ²K) Δv = M (v_b - v) + γ (f + K (x_b - x + γ v)),  v+ = v + Δv
// which is Baraff-Witkin's (M - hD - h²K) Δv = h (f + h K v) for backward Euler and Choi & Ko 2002's
// linearised BDF2. newton_iterations > 1: Newton on the optimisation form (Gast et al. 2015 style), from
// v+ = v, minimising the incremental potential
//   Φ(v+) = 1/2 (v+ - v_b)ᵀ M (v+ - v_b) + E(x_b + γ v+) + γ Ψ(v+)
// (E: conservative terms, gravity included; Ψ: the non-conservative forces — damping, drag — as a quadratic
// dissipation potential about the current iterate, Ψ = -f_ncᵀ δ - 1/2 δᵀ D δ), with a backtracking
// (Armijo) line search; it stops early when |g|_M⁻¹ <= cg_tolerance |g_0|_M⁻¹.
// Safeguard (safeguard = 1, default; linearised step only): the linearised step is not unconditionally
// stable under large rotations of stiff cloth (docs/references.md, "Time integration"). x+ = x + γ v+ moves
// each vertex along a straight line, while the linearised K of a spring at rest length has no transverse
// stiffness, so a rotation by θ per step stretches the spring by about θ²/2 that the solve never saw, and
// stiff cloth at large steps gains energy step after step. After each linearised step the energy balance is
// checked (kinetic energy of the free vertices + every conservative term, gravity included): a gain beyond
// the work of the kinematic vertices, an upper bound of what non-conservative terms can feed in, and
// safeguard_tolerance times the energy exchanged in the step (energy_gain_excessive()) makes the step be
// redone by up to safeguard_newton_iterations Newton iterations with line search (below), from the linearised
// result or the start, whichever has the lower Φ. The correction must converge (enough Newton iterations;
// they stop early at cg_tolerance). Steps that balance cost two energy evaluations (counter safeguard_ms).
// The default tolerance 0.2 lies between the two regimes: a failing stiff step gains more than half the
// exchanged energy, while the benign gains of linearisation and CG truncation stay well below it. A tighter
// tolerance would replace accurate steps by more dissipative, better-converged backward Euler steps: the
// check is a guard against blow-up, not an accuracy control (docs/validation.md).
// Matrix: A = M - γD - γ²K with M on the left, symmetric: K and D from JacobianOptions{clamp_compression,
// no damping position terms} (springs: clamped transverse term; Baraff-Witkin: clamped stretch, Gauss-Newton
// shear and bending). Non-conservative terms (drag) contribute only their velocity Jacobian D (their
// position dependence is explicit), and A is symmetrised ((A + Aᵀ)/2) after assembly.
// clamp_compression = 0 (parameter, default 1) assembles the exact Jacobians instead (Baraff & Witkin 1998
// publish the exact K): a compressed spring keeps its transverse k (1 - L/l) < 0 and A can be indefinite.
// On a compressed strip (test_buckling.cpp) the linearised step then keeps a linear spring
// model flat and compressed (for γ²|λ| > m it maps the growing buckling mode back onto the unstable flat
// state), where the clamp leaves that transverse push explicit and the strip buckles at once.
// Linear solve: FilteredPCG (block-Jacobi; multigrid = 1 or 2: aggregation multigrid). Kinematic vertices
// (inverse mass 0) are constrained in the filter (S = 0) with the prescribed velocity that makes x+ = x + h v
// exactly (Solver.h contract). imex: implicit-explicit split (Eberhardt, Etzmuß & Hauth 2000,
// "Implicit-explicit schemes for fast animation with particle systems"; Bridson, Marino & Fedkiw 2003 treat
// the stiff part implicitly and the rest explicitly in the same spirit). Only the stiff in-plane terms are
// linearised — Baraff-Witkin stretch and shear, the co-rotated FEM membrane, Choi-Ko's term, and of the
// "springs" term its structural, shear and edge springs — and every other force (bending: dihedral hinges,
// grid bend and hinge springs; gravity, drag, loads) enters explicitly at (x, v):
//   (M - h D_s - h² K_s) Δv = h (f(x, v) + h K_s v),  v+ = v + Δv,  x+ = x + h v+
// i.e. linearised backward Euler on the stiff terms and symplectic Euler on the rest. The linear system is
// smaller-banded than implicit_euler's only for springs (bend springs leave it); the gain is the explicit
// bending (no bending Jacobian, no Gauss-Newton hinge blocks), bought with a step limit from bending
// stiffness. No Newton iterations (newton_iterations is not a parameter of imex).
// adaptive = 1: a substep is rejected and halved when the state turns non-finite or some edge's strain
// |l/L - 1| changes by more than max_strain_change in it; after 4 successful substeps the substep doubles
// again (up to the step asked for). One step(h) call may thus take several substeps.
#include "loom/cloth/FilteredPCG.h"
#include "loom/cloth/Solver.h"

namespace loom::cloth {

struct ImplicitParams {
  double cg_tolerance = 1e-4;        // 1, relative residual of the filtered PCG (and the Newton stop)
  int cg_max_iterations = 200;       // per linear solve
  int newton_iterations = 1;         // 1 = linearised step; > 1 = Newton with line search
  bool adaptive = false;             // reject-and-halve substeps
  double max_strain_change = 0.1;    // 1, largest |Δ(l/L)| of an edge in one accepted substep (adaptive)
  bool safeguard = true;             // linearised step: energy balance check, Newton correction if violated
  double safeguard_tolerance = 0.2;  // 1, allowed gain relative to the energy exchanged in the step
  int safeguard_newton_iterations = 20;  // most Newton iterations of a correction (stops at cg_tolerance)
  bool clamp_compression = true;  // false: exact Jacobians (compressed springs keep k (1 - L/l) transverse)
  // PCG preconditioner (AggregationMultigrid.h): 0 block-Jacobi, 1 aggregation multigrid with an additive
  // finest level, 2 aggregation multigrid V-cycle (multiplicative on every level).
  int multigrid = 0;
  // Contacts as constraints: vertices a collision stage left against a body (ClothState::contact_normal)
  // keep their normal velocity through the linear solves (filtered PCG), so the step cannot drive them into
  // the body for the collision stage to push them back (a period-2 oscillation). Off by default: the body
  // stage's Coulomb friction is scaled by the approach it removes, which a held contact no longer has, so
  // resting cloth slides. The character scenes turn it on (`solver.contact_filter: 1`).
  bool contact_filter = false;
};

// Work counters since construction.
struct ImplicitCounters {
  long substeps = 0;  // accepted substeps
  long rejected = 0;  // rejected substeps (adaptive)
  long linear_solves = 0;
  long cg_iterations = 0;
  long newton_iterations = 0;
  long line_search_halvings = 0;
  long safeguard_corrections = 0;  // linearised steps redone by Newton (energy balance violated)
  long contact_constraints = 0;    // vertex contacts filtered in linear solves (ClothState::contact_normal)
  long contact_releases = 0;       // of them released (their impulse pulled towards the body), solve redone
  double assembly_ms = 0.0;        // ms, Jacobian assembly (K, D, A)
  double cg_ms = 0.0;              // ms, filtered PCG
  double safeguard_ms = 0.0;       // ms, energy balance checks (not the Newton corrections)
};

class ImplicitSolver final : public Solver {
 public:
  enum class Scheme { kBackwardEuler, kBdf2, kImex };
  ImplicitSolver(Scheme scheme, ImplicitParams params) : scheme_(scheme), p_(params) {
    pcg_.set_preconditioner(p_.multigrid ? Preconditioner::kMultigrid : Preconditioner::kBlockJacobi,
                            p_.multigrid == 2 ? MultigridCycle::kVCycle : MultigridCycle::kAdditiveFinest);
  }
  const char* name() const override {
    return scheme_ == Scheme::kBdf2 ? "bdf2" : scheme_ == Scheme::kImex ? "imex" : "implicit_euler";
  }
  void step(Cloth& cloth, double t, double h, int threads) override;
  // A step whose Newton iterations (full Newton, or the safeguard's correction) stopped because the line
  // search found no decrease of Φ (or the direction was not finite) before the residual |g|_M⁻¹ fell to half
  // its start value, while the predicted decrease -gᵀp was above the round-off of Φ: that step is not a
  // solution (kept, it freezes the cloth at its start): "" or why, read by the guard like a stage's
  // violation (Stage.h: the frame is retried with smaller steps). With adaptive = 1 the substep is halved
  // first.
  const std::string& violation() const { return violation_; }
  void reset() override {
    has_history_ = false;
    energy_cache_valid_ = false;
  }
  // BDF2 history, adaptive substep and the PCG warm start (ImplicitSolverState.cpp).
  void save_state(StateWriter& out) const override;
  void load_state(StateReader& in, const Cloth& cloth) override;
  const ImplicitCounters& stats() const { return counters_; }
  std::vector<std::pair<std::string, double>> counters() const override;
  const ImplicitParams& params() const { return p_; }
  double substep_size() const { return h_sub_; }  // s, the adaptive substep of the last call

 private:
  void prepare(const Cloth& cloth);
  bool substep(Cloth& cloth, double t, double h, int threads);
  // K, D and A at (x, v). With `ky` (and y), also ky = K y (the same sums as multiply(K_, y, ky)), formed in
  // the pass that writes A when it can (one pass over K less).
  void assemble(Cloth& cloth, const Vec3s& x, const Vec3s& v, double t, double gamma, int threads,
                const Vec3s* y = nullptr, Vec3s* ky = nullptr);
  void multiply(const BlockMatrix& m, const Vec3s& x, Vec3s& y, int threads) const;
  double incremental_potential(Cloth& cloth, const Vec3s& v, double t, int threads);
  // False when it stopped without solving the step (violation()); the reason goes into violation_.
  bool newton(Cloth& cloth, double t, double h, int threads, int iterations);
  // Kinetic energy of the free vertices (returned) and, unless kinetic_only, each conservative term's energy
  // (per_term), J.
  double mechanical_energy(const Cloth& cloth, const Vec3s& x, const Vec3s& v, double t, int threads,
                           std::vector<double>& per_term, bool kinetic_only = false) const;
  static std::vector<const Term*> term_list(const Cloth& cloth);
  bool energy_gain_excessive(Cloth& cloth, double t, double h, int threads);
  double max_strain_change(const Vec3s& before, const Vec3s& after) const;
  // pcg_.solve with the cloth's contact constraints (ClothState::contact_normal) as filters; a contact whose
  // constraint impulse ((A x - b)·n) comes out negative (holding the vertex against the body) is released and
  // the system solved again from the result (Baraff & Witkin 1998 Sec. 5.3). Counts into counters_.
  PcgResult solve_with_contacts(const Cloth& cloth, Vec3s& x, bool warm_start, int threads);

  Scheme scheme_;
  ImplicitParams p_;
  ImplicitCounters counters_;
  FilteredPCG pcg_;
  Vec3s normals_;  // the contact filters of the current solve
  // Pattern (built once per cloth).
  const Cloth* cloth_ = nullptr;
  int n_ = 0;
  BlockMatrix K_, D_, A_;
  std::vector<Mat3>
      dinv_;  // block-Jacobi inverses of A (0 on fixed vertices), formed where A's diagonal is written
  // The terms whose Jacobians enter A: all of the cloth's, or for imex the stiff in-plane ones (some owned:
  // the stiff springs of a "springs" term).
  std::vector<const Term*> jac_terms_;
  std::vector<std::unique_ptr<Term>> owned_terms_;
  std::vector<int> transpose_;  // index of block (j, i) for block (i, j)
  std::vector<char> fixed_;
  std::vector<double> edge_rest_;  // m
  // BDF2 history: the state at the start of the previous step and that step's size.
  bool has_history_ = false;
  Vec3s x_hist_, v_hist_;
  double h_hist_ = 0.0;
  // Adaptive substep.
  double h_sub_ = 0.0;
  int streak_ = 0;
  // Scratch.
  Vec3s f_, fc_, xb_, vb_, rhs_, dv_, y_, tmp_, vk_, xk_, g_, p_dir_, vtry_;
  std::vector<double> e_start_, e_end_;  // J, per conservative term (safeguard)
  // The last check's end positions and terms: e_end_ holds their energies while valid (the next start reuses
  // them).
  Vec3s energy_cache_x_;
  std::vector<const Term*> energy_cache_terms_;
  bool energy_cache_valid_ = false;
  double gamma_ = 0.0;
  std::string violation_;       // violation() of the last step
  std::string newton_failure_;  // why the last substep's Newton did not solve it ("" if it did)
  double h_dv_ = 0.0;           // s, step of the Δv kept in dv_ (the PCG's warm start); 0 = none
  bool d_written_ =
      false;  // the last assembly wrote df/dv into D_ (so D_ must be cleared before it is skipped)
};

}  // namespace loom::cloth
