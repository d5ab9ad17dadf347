#include "loom/cloth/ImplicitSolver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

#include "loom/cloth/SpringTerm.h"

namespace loom::cloth {

namespace {
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
}  // namespace

std::vector<std::pair<std::string, double>> ImplicitSolver::counters() const {
  const ImplicitCounters& c = counters_;
  return {{"substeps", double(c.substeps)},
          {"rejected_substeps", double(c.rejected)},
          {"linear_solves", double(c.linear_solves)},
          {"cg_iterations", double(c.cg_iterations)},
          {"newton_iterations", double(c.newton_iterations)},
          {"line_search_halvings", double(c.line_search_halvings)},
          {"safeguard_corrections", double(c.safeguard_corrections)},
          {"contact_constraints", double(c.contact_constraints)},
          {"contact_releases", double(c.contact_releases)},
          {"safeguard_ms", c.safeguard_ms},
          {"assembly_ms", c.assembly_ms},
          {"cg_ms", c.cg_ms}};
}

void ImplicitSolver::prepare(const Cloth& cloth) {
  const int n = cloth.state().size();
  if (&cloth == cloth_ && n == n_) return;
  cloth_ = &cloth;
  n_ = n;
  jac_terms_.clear();
  owned_terms_.clear();
  for (const auto& t : cloth.terms()) {
    if (scheme_ != Scheme::kImex) {
      jac_terms_.push_back(t.get());
      continue;
    }
    // IMEX: the stiff in-plane terms only (header).
    const char* nm = t->name();
    for (const char* stiff : {"bw_stretch", "bw_shear", "corotated_fem", "choi_ko"})
      if (!std::strcmp(nm, stiff)) jac_terms_.push_back(t.get());
    const auto* springs = dynamic_cast<const SpringTerm*>(t.get());
    const auto& defs = cloth.mesh().springs();
    if (springs && !std::strcmp(nm, "springs")) {
      if (springs->springs().size() != defs.size()) {
        jac_terms_.push_back(t.get());  // not the mesh's spring set: keep it whole
        continue;
      }
      std::vector<Spring> stiff;
      for (size_t k = 0; k < defs.size(); ++k)
        if (defs[k].kind != SpringKind::kBend && defs[k].kind != SpringKind::kHinge)
          stiff.push_back(springs->springs()[k]);
      owned_terms_.push_back(std::make_unique<SpringTerm>(n, std::move(stiff), "springs_in_plane"));
      jac_terms_.push_back(owned_terms_.back().get());
    }
  }
  std::vector<std::pair<int, int>> pairs;
  for (const Term* t : jac_terms_) t->add_pattern(pairs);
  for (auto& p : pairs)
    if (p.first > p.second) std::swap(p.first, p.second);
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  K_ = BlockMatrix(n, pairs);
  d_written_ = false;
  D_ = K_;  // copies share the pattern (and its pattern_id(), so the terms' slot lists serve all three)
  A_ = K_;
  transpose_.resize(A_.num_blocks());
  const Mat3* base = A_.blocks().data();
  for (int i = 0; i < n; ++i)
    for (int k = A_.row_start()[i]; k < A_.row_start()[i + 1]; ++k)
      transpose_[k] = static_cast<int>(A_.find(A_.cols()[k], i) - base);
  const Vec3s& X = cloth.mesh().rest_positions();
  edge_rest_.clear();
  for (const Edge& e : cloth.mesh().edges()) edge_rest_.push_back((X[e.j] - X[e.i]).norm());
  fixed_.assign(n, 0);
  dv_.assign(n, Vec3::Zero());
  h_dv_ = 0.0;
  has_history_ = false;
  energy_cache_valid_ = false;
}

void ImplicitSolver::multiply(const BlockMatrix& m, const Vec3s& x, Vec3s& y, int threads) const {
  const int n = m.size();
  y.resize(n);
  const auto& rs = m.row_start();
  const auto& cols = m.cols();
  const auto& b = m.blocks();
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
  for (int i = 0; i < n; ++i) {
    Vec3 acc = Vec3::Zero();
    for (int k = rs[i]; k < rs[i + 1]; ++k) acc += b[k] * x[cols[k]];
    y[i] = acc;
  }
}

void ImplicitSolver::assemble(Cloth& cloth, const Vec3s& x, const Vec3s& v, double t, double gamma,
                              int threads, const Vec3s* y, Vec3s* ky) {
  const auto t0 = Clock::now();
  auto& kb = K_.blocks();
  auto& db = D_.blocks();
  const int nb = A_.num_blocks();
  // D is cleared and read only when some term has a velocity Jacobian (damped springs, drag); otherwise it
  // stays zero (cleared once if an earlier assembly wrote it).
  bool use_d = false;
  for (const Term* term : jac_terms_) use_d = use_d || term->has_velocity_jacobian();
  const bool clear_d = use_d || d_written_;
  d_written_ = use_d;
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
  for (int k = 0; k < nb; ++k) {
    kb[k].setZero();
    if (clear_d) db[k].setZero();
  }
  JacobianOptions o;
  o.clamp_compression = p_.clamp_compression;
  o.damping_position_terms = false;
  const EvalContext ctx{x, v, t, threads};
  for (const Term* term : jac_terms_) {
    // Non-conservative terms (drag): only df/dv goes into A; their position dependence stays explicit.
    term->add_jacobians(ctx, o, term->conservative() ? &K_ : nullptr, use_d ? &D_ : nullptr);
  }
  // A = M - γD - γ²K, then symmetrised: A_ij = (A_ij + A_jiᵀ)/2. Row i writes its blocks (i, j >= i) and
  // their mirrors (j, i): every block is written once, rows in parallel.
  const ClothState& s = cloth.state();
  auto& a = A_.blocks();
  const auto& rs = A_.row_start();
  const auto& cols = A_.cols();
  auto raw = [&](int k) -> Mat3 {
    return use_d ? Mat3(-gamma * db[k] - gamma * gamma * kb[k]) : Mat3(-gamma * gamma * kb[k]);
  };
  bool symmetric = true;
  for (const Term* term : jac_terms_) symmetric = symmetric && term->symmetric_jacobians(o);
  if (symmetric) {
    // Every term mirrors its blocks bit for bit (Term::symmetric_jacobians): raw(j, i) = raw(i, j)ᵀ exactly,
    // so (raw + rawᵀ)/2 = raw exactly and one pass over the blocks, without the transposed reads, gives the
    // same A. K y is summed in the same pass, row by row in column order as multiply() does (the same bits).
    // The PCG's block-Jacobi inverses too (FilteredPCG::diagonal_inverse), where the diagonal block is
    // written.
    if (ky) ky->resize(n_);
    dinv_.resize(n_);
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
    for (int i = 0; i < n_; ++i) {
      Vec3 acc = Vec3::Zero();
      for (int k = rs[i]; k < rs[i + 1]; ++k) {
        a[k] = raw(k);
        if (cols[k] == i) {
          a[k] += s.mass[i] * Mat3::Identity();
          dinv_[i] = fixed_[i] ? Mat3::Zero() : FilteredPCG::diagonal_inverse(a[k]);
        }
        if (ky) acc += kb[k] * (*y)[cols[k]];
      }
      if (ky) (*ky)[i] = acc;
    }
    counters_.assembly_ms += ms_since(t0);
    return;
  }
  dinv_.resize(n_);
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
  for (int i = 0; i < n_; ++i)
    for (int k = rs[i]; k < rs[i + 1]; ++k) {
      const int j = cols[k];
      if (j == i) {
        const Mat3 d = raw(k);
        a[k] = 0.5 * (d + d.transpose());
        a[k] += s.mass[i] * Mat3::Identity();
        dinv_[i] = fixed_[i] ? Mat3::Zero() : FilteredPCG::diagonal_inverse(a[k]);
      } else if (j > i) {
        const Mat3 avg = 0.5 * (raw(k) + raw(transpose_[k]).transpose());
        a[k] = avg;
        a[transpose_[k]] = avg.transpose();
      }
    }
  if (ky) multiply(K_, *y, *ky, threads);
  counters_.assembly_ms += ms_since(t0);
}

double ImplicitSolver::incremental_potential(Cloth& cloth, const Vec3s& v, double t, int threads) {
  // Φ_c(v) = 1/2 (v - v_b)ᵀ M (v - v_b) + E(x_b + γ v)
  const ClothState& s = cloth.state();
  for (int i = 0; i < n_; ++i) xk_[i] = xb_[i] + gamma_ * v[i];
  double phi = 0.0;
  for (int i = 0; i < n_; ++i) phi += 0.5 * s.mass[i] * (v[i] - vb_[i]).squaredNorm();
  const EvalContext ctx{xk_, v, t, threads};
  for (const auto& term : cloth.terms())
    if (term->conservative()) phi += term->energy(ctx);
  return phi;
}

double ImplicitSolver::max_strain_change(const Vec3s& before, const Vec3s& after) const {
  const auto& edges = cloth_->mesh().edges();
  double worst = 0.0;
  for (size_t k = 0; k < edges.size(); ++k) {
    const double l0 = (before[edges[k].j] - before[edges[k].i]).norm();
    const double l1 = (after[edges[k].j] - after[edges[k].i]).norm();
    worst = std::max(worst, std::abs(l1 - l0) / edge_rest_[k]);
  }
  return std::isfinite(worst) ? worst : 1e300;
}

bool ImplicitSolver::substep(Cloth& cloth, double t, double h, int threads) {
  ClothState& s = cloth.state();
  const int n = n_;
  // The per-vertex loops of the step run on several threads from kParallelMinVertices up (each writes its own
  // vertex: the same results for any thread count).
  const bool par = threads > 1 && n >= kParallelMinVertices;
  for (int i = 0; i < n; ++i) fixed_[i] = s.inv_mass[i] == 0.0;
  xb_.resize(n);
  vb_.resize(n);
  xk_.resize(n);
  const bool bdf2 = scheme_ == Scheme::kBdf2 && has_history_ && h_hist_ > 0.0;
  double c1 = 1.0, c2 = 0.0, gamma = h;
  if (bdf2) {
    // Variable-step BDF2 with ω = h_n / h_{n-1}.
    const double w = h / h_hist_;
    c1 = (1.0 + w) * (1.0 + w) / (1.0 + 2.0 * w);
    c2 = w * w / (1.0 + 2.0 * w);
    gamma = h * (1.0 + w) / (1.0 + 2.0 * w);
  }
  gamma_ = gamma;
#pragma omp parallel for num_threads(threads) if (par) schedule(static)
  for (int i = 0; i < n; ++i) {
    xb_[i] = bdf2 ? Vec3(c1 * s.x[i] - c2 * x_hist_[i]) : s.x[i];
    vb_[i] = bdf2 ? Vec3(c1 * s.v[i] - c2 * v_hist_[i]) : s.v[i];
  }
  // The velocity in the scheme that puts a kinematic vertex at x + h v.
  auto pinned_velocity = [&](int i) -> Vec3 {
    return bdf2 ? Vec3((s.x[i] + h * s.v[i] - xb_[i]) / gamma) : s.v[i];
  };
  Vec3s& vplus = vk_;
  vplus.resize(n);
  bool solved = true;
  newton_failure_.clear();
  if (p_.newton_iterations <= 1) {
    // Linearised step (Baraff & Witkin 1998 eq. 18; Choi & Ko 2002 for BDF2).
    cloth.compute_forces(s.x, s.v, t, threads, f_);
    y_.resize(n);
#pragma omp parallel for num_threads(threads) if (par) schedule(static)
    for (int i = 0; i < n; ++i) y_[i] = xb_[i] - s.x[i] + gamma * s.v[i];
    assemble(cloth, s.x, s.v, t, gamma, threads, &y_, &tmp_);  // and tmp_ = K y_
    rhs_.resize(n);
    // Warm start: the previous step's Δv (≈ h a), scaled to this step.
    dv_.resize(n, Vec3::Zero());
    const double scale = h_dv_ > 0.0 ? h / h_dv_ : 0.0;
#pragma omp parallel for num_threads(threads) if (par) schedule(static)
    for (int i = 0; i < n; ++i) {
      dv_[i] *= scale;
      rhs_[i] = s.mass[i] * (vb_[i] - s.v[i]) + gamma * (f_[i] + tmp_[i]);
      if (fixed_[i]) dv_[i] = pinned_velocity(i) - s.v[i];
    }
    const auto t0 = Clock::now();
    const PcgResult r = solve_with_contacts(cloth, dv_, true, threads);
    h_dv_ = h;
    counters_.cg_ms += ms_since(t0);
    ++counters_.linear_solves;
    counters_.cg_iterations += r.iterations;
#pragma omp parallel for num_threads(threads) if (par) schedule(static)
    for (int i = 0; i < n; ++i) vplus[i] = s.v[i] + dv_[i];
    const auto t_check = Clock::now();
    const bool excessive = p_.safeguard && energy_gain_excessive(cloth, t, h, threads);
    counters_.safeguard_ms += ms_since(t_check);
    if (excessive) {
      energy_cache_valid_ = false;
      // The linearised step created energy that no external work explains (large rotations of stiff
      // cloth, docs/references.md, "Time integration"): correct this step by Newton with line search, from
      // the better of the linearised result and the start.
      ++counters_.safeguard_corrections;
      vtry_.resize(n);
      for (int i = 0; i < n; ++i) vtry_[i] = fixed_[i] ? vplus[i] : s.v[i];
      if (incremental_potential(cloth, vtry_, t + h, threads) <
          incremental_potential(cloth, vplus, t + h, threads))
        vplus.swap(vtry_);
      solved = newton(cloth, t, h, threads, p_.safeguard_newton_iterations);
      for (int i = 0; i < n; ++i) dv_[i] = vplus[i] - s.v[i];  // the next step's warm start
    }
  } else {
    // Newton on the incremental potential with a backtracking line search.
    for (int i = 0; i < n; ++i) vplus[i] = fixed_[i] ? pinned_velocity(i) : s.v[i];
    solved = newton(cloth, t, h, threads, p_.newton_iterations);
  }
  // Commit: free vertices x+ = x_b + γ v+; kinematic vertices x+ = x + h v exactly.
  y_.resize(n);
  tmp_.resize(n);
  x_hist_.resize(n);
  s.x_prev.resize(n);
#pragma omp parallel for num_threads(threads) if (par) schedule(static)
  for (int i = 0; i < n; ++i) {
    y_[i] = s.x[i];  // start of the step
    tmp_[i] = s.v[i];
    if (fixed_[i]) {
      s.x[i] = s.x[i] + h * s.v[i];
    } else {
      s.v[i] = vplus[i];
      s.x[i] = xb_[i] + gamma * vplus[i];
    }
  }
  // x_prev and the BDF2 history: the start of the step (x_prev a copy, the history swapped in).
#pragma omp parallel for num_threads(threads) if (par) schedule(static)
  for (int i = 0; i < n; ++i) s.x_prev[i] = y_[i];
  x_hist_.swap(y_);
  v_hist_.swap(tmp_);
  h_hist_ = h;
  has_history_ = true;
  return s.is_finite() && solved;
}

std::vector<const Term*> ImplicitSolver::term_list(const Cloth& cloth) {
  std::vector<const Term*> out;
  for (const auto& term : cloth.terms()) out.push_back(term.get());
  return out;
}

double ImplicitSolver::mechanical_energy(const Cloth& cloth, const Vec3s& x, const Vec3s& v, double t,
                                         int threads, std::vector<double>& per_term,
                                         bool kinetic_only) const {
  const ClothState& s = cloth.state();
  double kinetic = 0.0;
  for (int i = 0; i < n_; ++i)
    if (!fixed_[i]) kinetic += 0.5 * s.mass[i] * v[i].squaredNorm();
  if (kinetic_only) return kinetic;
  per_term.clear();
  const EvalContext ctx{x, v, t, threads};
  for (const auto& term : cloth.terms())
    if (term->conservative()) per_term.push_back(term->energy(ctx));
  return kinetic;
}

bool ImplicitSolver::energy_gain_excessive(Cloth& cloth, double t, double h, int threads) {
  // Energy balance of the step just solved (start: s.x, s.v; end: x+ = x_b + γ v+, v+ in vk_):
  //   ΔE = ΔK + Σ ΔE_term  must not exceed  W_pins + W_in + tol (K_0 + K_1 + Σ |ΔE_term| + |W_pins| + W_in)
  // with K the kinetic energy of the free vertices, E_term the conservative terms (gravity included),
  // W_pins = -Σ_kinematic f_i·Δx_i the work of the kinematic vertices (forces at the start of the step; the
  // trapezoid rule with the end-of-step forces too before a step with moving pins is called excessive) and
  // W_in = h Σ_free max(0, f_nc,i·v+_i) an upper bound of what non-conservative terms (drag in wind) can
  // feed in. Damping only dissipates. An exactly solved backward Euler step of a conservative system
  // dissipates; the linearised step can gain energy only through the linearisation (docs/references.md, "Time
  // integration").
  const ClothState& s = cloth.state();
  const int n = n_;
  const Vec3s& vplus = vk_;
  xk_.resize(n);
  for (int i = 0; i < n; ++i) xk_[i] = xb_[i] + gamma_ * vplus[i];
  // The start's term energies are the last check's end energies when the step starts where that one ended
  // (the same positions bit for bit, the same terms): conservative energies depend on x alone (Term.h).
  const bool reuse = energy_cache_valid_ && energy_cache_terms_ == term_list(cloth) && s.x == energy_cache_x_;
  const double k0 = mechanical_energy(cloth, s.x, s.v, t, threads, e_start_, reuse);
  if (reuse) e_start_ = e_end_;
  const double k1 = mechanical_energy(cloth, xk_, vplus, t + h, threads, e_end_);
  energy_cache_x_ = xk_;
  energy_cache_terms_ = term_list(cloth);
  energy_cache_valid_ = true;  // cleared below if the step is redone (its end then moves)
  double gain = k1 - k0, exchanged = k0 + k1;
  for (size_t k = 0; k < e_start_.size(); ++k) {
    gain += e_end_[k] - e_start_[k];
    exchanged += std::abs(e_end_[k] - e_start_[k]);
  }
  double w_pins = 0.0;
  for (int i = 0; i < n; ++i)
    if (fixed_[i]) w_pins -= f_[i].dot(xk_[i] - s.x[i]);
  double w_in = 0.0;
  bool any_nc = false;
  for (const auto& term : cloth.terms()) any_nc = any_nc || !term->conservative();
  if (any_nc) {
    tmp_.assign(n, Vec3::Zero());
    const EvalContext ctx{xk_, vplus, t + h, threads};
    for (const auto& term : cloth.terms())
      if (!term->conservative()) term->add_forces(ctx, tmp_);
    for (int i = 0; i < n; ++i)
      if (!fixed_[i]) w_in += h * std::max(0.0, tmp_[i].dot(vplus[i]));
  }
  auto allowed = [&]() {
    return w_pins + w_in + p_.safeguard_tolerance * (exchanged + std::abs(w_pins) + w_in);
  };
  if (gain <= allowed()) return false;
  // Moving kinematic vertices: the start-of-step forces miss the work of a pin that loads the cloth during
  // the step (a pin compressing an unloaded strip sees zero force at the start). Before calling the step
  // excessive, take the trapezoid rule W_pins = -Σ 1/2 (f_i(x) + f_i(x+))·Δx_i (exact for linear springs).
  bool pins_moved = false;
  for (int i = 0; i < n && !pins_moved; ++i) pins_moved = fixed_[i] && xk_[i] != s.x[i];
  if (pins_moved) {
    cloth.compute_forces(xk_, vplus, t + h, threads, fc_);
    w_pins = 0.0;
    for (int i = 0; i < n; ++i)
      if (fixed_[i]) w_pins -= 0.5 * (f_[i] + fc_[i]).dot(xk_[i] - s.x[i]);
  }
  return !(gain <= allowed());  // a non-finite balance counts as excessive
}

PcgResult ImplicitSolver::solve_with_contacts(const Cloth& cloth, Vec3s& x, bool warm_start, int threads) {
  const ClothState& s = cloth.state();
  int constrained = 0;
  if (p_.contact_filter && static_cast<int>(s.contact_normal.size()) == n_) {
    normals_ = s.contact_normal;
    for (int i = 0; i < n_; ++i) {
      if (fixed_[i]) normals_[i].setZero();
      if (!normals_[i].isZero(0.0)) ++constrained;
    }
  }
  if (constrained == 0)
    return pcg_.solve(A_, rhs_, fixed_, x, p_.cg_tolerance, p_.cg_max_iterations, threads, warm_start,
                      nullptr, &dinv_);
  counters_.contact_constraints += constrained;
  PcgResult r = pcg_.solve(A_, rhs_, fixed_, x, p_.cg_tolerance, p_.cg_max_iterations, threads, warm_start,
                           &normals_, &dinv_);
  // Release the contacts that hold their vertex against the body: the constraint impulse λ n = (A x - b)
  // along n (n points out of the body) is negative there. One more solve from this result, without them.
  multiply(A_, x, tmp_, threads);
  int released = 0;
  for (int i = 0; i < n_; ++i) {
    if (normals_[i].isZero(0.0)) continue;
    if ((tmp_[i] - rhs_[i]).dot(normals_[i]) < 0.0) normals_[i].setZero(), ++released;
  }
  if (released == 0) return r;
  counters_.contact_releases += released;
  counters_.cg_iterations += r.iterations;
  ++counters_.linear_solves;
  return pcg_.solve(A_, rhs_, fixed_, x, p_.cg_tolerance, p_.cg_max_iterations, threads, true, &normals_,
                    &dinv_);
}

bool ImplicitSolver::newton(Cloth& cloth, double t, double h, int threads, int iterations) {
  // Newton on the incremental potential Φ from the iterate in vk_, with a backtracking line search.
  ClothState& s = cloth.state();
  const int n = n_;
  const double gamma = gamma_;
  Vec3s& vplus = vk_;
  const Vec3s zero(n, Vec3::Zero());
  g_.resize(n);
  double g0 = 0.0, g_scale = 0.0;
  Vec3s xk(n);
  for (int it = 0; it < iterations; ++it) {
    for (int i = 0; i < n; ++i) xk[i] = xb_[i] + gamma * vplus[i];
    cloth.compute_forces(xk, vplus, t + h, threads, f_);
    double gnorm = 0.0;
    for (int i = 0; i < n; ++i) {
      g_[i] = fixed_[i] ? Vec3::Zero() : Vec3(s.mass[i] * (vplus[i] - vb_[i]) - gamma * f_[i]);
      if (!fixed_[i]) gnorm += g_[i].squaredNorm() / s.mass[i];
    }
    gnorm = std::sqrt(gnorm);
    if (it == 0) {
      g0 = gnorm;
      // The size of the residual's two parts, m (v+ - v_b) and γ f, in the same norm: a residual a
      // billionth of it is round-off, a converged step whatever the line search finds next.
      // At rest with no load both vanish: the floor is the momentum of the free mass at 1 mm/s.
      double momentum = 0.0, impulse = 0.0, mass = 0.0;
      for (int i = 0; i < n; ++i)
        if (!fixed_[i]) {
          momentum += s.mass[i] * (vplus[i] - vb_[i]).squaredNorm() + s.mass[i] * vb_[i].squaredNorm();
          impulse += (gamma * f_[i]).squaredNorm() / s.mass[i];
          mass += s.mass[i];
        }
      g_scale = std::sqrt(momentum) + std::sqrt(impulse) + 1e-3 * std::sqrt(mass);
    }
    if (!std::isfinite(gnorm)) break;
    if (gnorm == 0.0 || (it > 0 && gnorm <= p_.cg_tolerance * g0)) break;
    ++counters_.newton_iterations;
    // Conservative forces alone (at zero velocity): the rest is f_nc, the dissipative part.
    fc_.assign(n, Vec3::Zero());
    {
      const EvalContext ctx{xk, zero, t + h, threads};
      for (const auto& term : cloth.terms())
        if (term->conservative()) term->add_forces(ctx, fc_);
    }
    assemble(cloth, xk, vplus, t + h, gamma, threads);
    rhs_.resize(n);
    for (int i = 0; i < n; ++i) rhs_[i] = -g_[i];
    p_dir_.assign(n, Vec3::Zero());
    const auto t0 = Clock::now();
    const PcgResult r = solve_with_contacts(cloth, p_dir_, false, threads);
    counters_.cg_ms += ms_since(t0);
    ++counters_.linear_solves;
    counters_.cg_iterations += r.iterations;
    double slope = 0.0, fnc_p = 0.0;
    for (int i = 0; i < n; ++i) {
      slope += g_[i].dot(p_dir_[i]);
      fnc_p += (f_[i] - fc_[i]).dot(p_dir_[i]);
    }
    // A stop before the residual halved, with a residual above round-off (g_scale) and a predicted
    // decrease above the round-off of Φ (or a non-finite one), is a failed solve (violation()); a finite
    // non-descent direction is not counted.
    const auto stalled = [&](const char* what) {
      if (!(gnorm > 0.5 * g0) || gnorm <= 1e-9 * g_scale) return false;
      const double phi = incremental_potential(cloth, vplus, t + h, threads);
      if (std::isfinite(slope) && !(-slope > 1e-8 * std::abs(phi))) return false;
      std::ostringstream why;
      why << "the " << name() << " step of h = " << h << " s did not converge (" << what
          << " at Newton iteration " << it + 1 << ", residual " << gnorm << " of " << g0
          << "): the step is too long for this cloth; give more solver.substeps";
      newton_failure_ = why.str();
      return true;
    };
    if (!(slope < 0.0)) return !stalled("no descent direction");  // truncated CG, indefinite model
    // An update that moves no position by more than a few units in the last place of the largest
    // coordinate is converged: the residual is the round-off of the forces at these coordinates (a cloth at
    // rest 16 m from the origin has one of 1e-12 that no step reduces), and a line search would compare
    // round-off of Φ.
    double dx = 0.0, xmax = 0.0;
    for (int i = 0; i < n; ++i) {
      if (fixed_[i]) continue;
      dx = std::max(dx, gamma * p_dir_[i].lpNorm<Eigen::Infinity>());
      xmax = std::max(xmax, xk[i].lpNorm<Eigen::Infinity>());
    }
    if (dx <= 64.0 * std::numeric_limits<double>::epsilon() * xmax) break;
    multiply(D_, p_dir_, tmp_, threads);
    double pDp = 0.0;
    for (int i = 0; i < n; ++i) pDp += p_dir_[i].dot(tmp_[i]);
    const double phi0 = incremental_potential(cloth, vplus, t + h, threads);
    double step = 1.0;
    vtry_.resize(n);
    bool accepted = false;
    for (int ls = 0; ls < 20; ++ls) {
      for (int i = 0; i < n; ++i) vtry_[i] = vplus[i] + step * p_dir_[i];
      // Ψ = -f_ncᵀ δ - 1/2 δᵀ D δ with δ = step p.
      const double phi = incremental_potential(cloth, vtry_, t + h, threads) +
                         gamma * (-step * fnc_p - 0.5 * step * step * pDp);
      if (std::isfinite(phi) && phi <= phi0 + 1e-4 * step * slope) {
        accepted = true;
        break;
      }
      step *= 0.5;
      ++counters_.line_search_halvings;
    }
    if (!accepted) return !stalled("the line search found no decrease of the incremental potential");
    vplus.swap(vtry_);
  }
  return true;
}

void ImplicitSolver::step(Cloth& cloth, double t, double h, int threads) {
  prepare(cloth);
  violation_.clear();
  if (!p_.adaptive) {
    substep(cloth, t, h, threads);
    violation_ = newton_failure_;
    ++counters_.substeps;
    return;
  }
  ClothState& s = cloth.state();
  if (!(h_sub_ > 0.0) || h_sub_ > h) h_sub_ = h;
  const double h_min = h * std::ldexp(1.0, -16);
  double done = 0.0;
  Vec3s x0, v0, xp0, xh0, vh0;
  while (done < h) {
    double hs = std::min(h_sub_, h - done);
    if (h - done - hs <= 1e-9 * h) hs = h - done;  // the last substep ends exactly at t + h
    x0 = s.x;
    v0 = s.v;
    xp0 = s.x_prev;
    xh0 = x_hist_;
    vh0 = v_hist_;
    const bool had_history = has_history_;
    const double hh0 = h_hist_;
    const bool finite = substep(cloth, t + done, hs, threads);
    const bool ok = finite && max_strain_change(x0, s.x) <= p_.max_strain_change;
    if (!ok && hs > h_min) {
      s.x = x0;
      s.v = v0;
      s.x_prev = xp0;
      x_hist_ = xh0;
      v_hist_ = vh0;
      has_history_ = had_history;
      h_hist_ = hh0;
      h_sub_ = 0.5 * hs;
      streak_ = 0;
      ++counters_.rejected;
      continue;
    }
    done = hs == h - done ? h : done + hs;
    ++counters_.substeps;
    if (++streak_ >= 4 && h_sub_ < h) {
      h_sub_ = std::min(2.0 * h_sub_, h);
      streak_ = 0;
    }
    if (!finite) {  // could not be rescued at the smallest substep: leave it to the caller
      violation_ = newton_failure_;
      return;
    }
  }
}

}  // namespace loom::cloth
