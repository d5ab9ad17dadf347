#include "loom/cloth/PositionBasedSolvers.h"

#include <cmath>

#include "loom/cloth/SpringSolverSupport.h"

namespace loom::cloth {

namespace {
// Loops shorter than this run on one thread: a parallel region costs more than the work it would split.
// Results do not depend on it (colours share no vertex; per-vertex loops are independent).
constexpr int kMinParallel = 512;
}  // namespace

void PositionBasedSolver::check(const Cloth& cloth) const { check_spring_terms(cloth, name()); }

void PositionBasedSolver::prepare(const Cloth& cloth) {
  springs_ = collect_springs(cloth);
  colors_ = color_springs(cloth.state().size(), springs_);
  prepared_for_ = &cloth;
}

void PositionBasedSolver::step(Cloth& cloth, double t, double h, int threads) {
  if (prepared_for_ != &cloth) prepare(cloth);
  ClothState& s = cloth.state();
  const int n = s.size();
  external_forces(cloth, s.x, s.v, t, threads, f_);
  p_.resize(n);
  // Prediction (Müller 2007, Alg. 1 lines 5-7): kinematic vertices have inv_mass 0, so p = x + h v exactly.
#pragma omp parallel for num_threads(threads) if (threads > 1 && n >= kMinParallel) schedule(static)
  for (int i = 0; i < n; ++i) p_[i] = s.x[i] + h * (s.v[i] + h * s.inv_mass[i] * f_[i]);
  begin_step();
  for (int it = 0; it < iterations_; ++it)
    for (const auto& color : colors_) project(color, s, h, threads);
  s.x_prev = s.x;
#pragma omp parallel for num_threads(threads) if (threads > 1 && n >= kMinParallel) schedule(static)
  for (int i = 0; i < n; ++i) {
    if (s.inv_mass[i] > 0.0) s.v[i] = (p_[i] - s.x[i]) / h;
    s.x[i] = p_[i];
  }
}

PbdSolver::PbdSolver(int iterations, double stiffness)
    : PositionBasedSolver(iterations), k_iter_(1.0 - std::pow(1.0 - stiffness, 1.0 / iterations)) {}

void PbdSolver::project(const std::vector<int>& color, const ClothState& s, double, int threads) {
  const int nc = static_cast<int>(color.size());
#pragma omp parallel for num_threads(threads) if (threads > 1 && nc >= kMinParallel) schedule(static)
  for (int q = 0; q < nc; ++q) {
    const Spring& sp = springs_[color[q]];
    const double wi = s.inv_mass[sp.i], wj = s.inv_mass[sp.j];
    if (wi + wj == 0.0) continue;
    const Vec3 d = p_[sp.j] - p_[sp.i];
    const double l = d.norm();
    if (l < 1e-12) continue;
    // Müller 2007 for C = l - L: ∇_i C = -n, ∇_j C = n, |∇C|² = 1.
    const Vec3 corr = (k_iter_ * (l - sp.rest_length) / (wi + wj) / l) * d;
    p_[sp.i] += wi * corr;
    p_[sp.j] -= wj * corr;
  }
}

XpbdSolver::XpbdSolver(int iterations, double compliance_scale)
    : PositionBasedSolver(iterations), compliance_scale_(compliance_scale) {}

void XpbdSolver::project(const std::vector<int>& color, const ClothState& s, double h, int threads) {
  const int nc = static_cast<int>(color.size());
  const double inv_h2 = 1.0 / (h * h);
#pragma omp parallel for num_threads(threads) if (threads > 1 && nc >= kMinParallel) schedule(static)
  for (int q = 0; q < nc; ++q) {
    const int k = color[q];
    const Spring& sp = springs_[k];
    const double wi = s.inv_mass[sp.i], wj = s.inv_mass[sp.j];
    if (wi + wj == 0.0 || sp.k <= 0.0) continue;
    const Vec3 d = p_[sp.j] - p_[sp.i];
    const double l = d.norm();
    if (l < 1e-12) continue;
    const Vec3 n = d / l;
    const double C = l - sp.rest_length;
    const double alpha_t = compliance_scale_ / sp.k * inv_h2;  // α̃ = α / h²
    const double gamma = sp.c / (sp.k * h);                    // γ = β / h, β = c / k
    const double rate = n.dot((p_[sp.j] - s.x[sp.j]) - (p_[sp.i] - s.x[sp.i]));  // ∇C·(p - x_n)
    // Macklin 2016 eq. (18), with its damping term.
    const double dlambda = (-C - alpha_t * lambda_[k] - gamma * rate) / ((1.0 + gamma) * (wi + wj) + alpha_t);
    lambda_[k] += dlambda;
    p_[sp.i] -= (wi * dlambda) * n;
    p_[sp.j] += (wj * dlambda) * n;
  }
}

}  // namespace loom::cloth
