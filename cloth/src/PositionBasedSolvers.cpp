#include "loom/cloth/PositionBasedSolvers.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "Numbers.h"
#include "loom/cloth/SpringSolverSupport.h"

namespace loom::cloth {

void PositionBasedSolver::check(const Cloth& cloth) const { check_spring_terms(cloth, name()); }

void PositionBasedSolver::prepare(const Cloth& cloth) {
  const std::vector<Spring> springs = collect_springs(cloth);
  const std::vector<std::vector<int>> colors = color_springs(cloth.state().size(), springs);
  springs_.clear();
  springs_.reserve(springs.size());
  color_start_.assign(1, 0);
  for (std::vector<int> color : colors) {
    std::sort(color.begin(), color.end(), [&](int a, int b) {
      return std::min(springs[a].i, springs[a].j) < std::min(springs[b].i, springs[b].j);
    });
    for (int k : color) springs_.push_back(springs[k]);
    color_start_.push_back(static_cast<int>(springs_.size()));
  }
  prepared_for_ = &cloth;
}

namespace {
// Thread `me` of `team`'s static share of [begin, end).
void share(int begin, int end, int me, int team, int* b, int* e) {
  const long len = end - begin;
  *b = begin + static_cast<int>(len * me / team);
  *e = begin + static_cast<int>(len * (me + 1) / team);
}
}  // namespace

void PositionBasedSolver::step(Cloth& cloth, double t, double h, int threads) {
  if (prepared_for_ != &cloth) prepare(cloth);
  ClothState& s = cloth.state();
  const int n = s.size();
  const int ns = static_cast<int>(springs_.size());
  const int num_colors = static_cast<int>(color_start_.size()) - 1;
  external_forces(cloth, s.x, s.v, t, threads, f_);
  p_.resize(n);
  s.x_prev.resize(n);
#pragma omp parallel num_threads(threads) if (threads > 1 && n >= kMinParallel)
  {
    const int team = omp_get_num_threads(), me = omp_get_thread_num();
    int b = 0, e = 0;
    share(0, ns, me, team, &b, &e);
    begin_step(b, e);
    // Prediction (Müller 2007, Alg. 1 lines 5-7): kinematic vertices have inv_mass 0, so p = x + h v exactly.
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) p_[i] = s.x[i] + h * (s.v[i] + h * s.inv_mass[i] * f_[i]);
    for (int it = 0; it < iterations_; ++it)
      for (int c = 0; c < num_colors; ++c) {
        share(color_start_[c], color_start_[c + 1], me, team, &b, &e);
        project(b, e, s, h);
#pragma omp barrier
      }
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      s.x_prev[i] = s.x[i];
      if (s.inv_mass[i] > 0.0) s.v[i] = (p_[i] - s.x[i]) / h;
      s.x[i] = p_[i];
    }
  }
}

PbdSolver::PbdSolver(int iterations, double stiffness)
    : PositionBasedSolver(iterations), k_iter_(1.0 - std::pow(1.0 - stiffness, 1.0 / iterations)) {}

void PbdSolver::project(int begin, int end, const ClothState& s, double) {
  for (int q = begin; q < end; ++q) {
    const Spring& sp = springs_[q];
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

void XpbdSolver::begin_step(int begin, int end) {
  // One thread sizes λ (single's implicit barrier follows); each thread then zeroes its share.
#pragma omp single
  lambda_.resize(springs_.size());
  std::fill(lambda_.begin() + begin, lambda_.begin() + end, 0.0);
}

void XpbdSolver::project(int begin, int end, const ClothState& s, double h) {
  const double inv_h2 = 1.0 / (h * h);
  for (int k = begin; k < end; ++k) {
    const Spring& sp = springs_[k];
    const double wi = s.inv_mass[sp.i], wj = s.inv_mass[sp.j];
    if (wi + wj == 0.0 || sp.k <= 0.0) continue;
    const Vec3 d = p_[sp.j] - p_[sp.i];
    const double l = d.norm();
    if (l < 1e-12) continue;
    const Vec3 n = d / l;
    const double C = l - sp.rest_length;
    const double alpha_t = compliance_scale_ / sp.k * inv_h2;                    // α̃ = α / h²
    const double gamma = sp.c / (sp.k * h);                                      // γ = β / h, β = c / k
    const double rate = n.dot((p_[sp.j] - s.x[sp.j]) - (p_[sp.i] - s.x[sp.i]));  // ∇C·(p - x_n)
    // Macklin 2016 eq. (18), with its damping term.
    const double dlambda = (-C - alpha_t * lambda_[k] - gamma * rate) / ((1.0 + gamma) * (wi + wj) + alpha_t);
    lambda_[k] += dlambda;
    p_[sp.i] -= (wi * dlambda) * n;
    p_[sp.j] += (wj * dlambda) * n;
  }
}

}  // namespace loom::cloth
