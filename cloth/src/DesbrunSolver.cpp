#include "loom/cloth/DesbrunSolver.h"

#include <Eigen/Dense>

#include "Numbers.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/SpringSolverSupport.h"

namespace loom::cloth {

void DesbrunSolver::check(const Cloth& cloth) const { check_spring_terms(cloth, name()); }

void DesbrunSolver::prepare(const Cloth& cloth, double h) {
  const ClothState& s = cloth.state();
  std::vector<char> kinematic(s.size());
  for (int i = 0; i < s.size(); ++i) kinematic[i] = s.inv_mass[i] == 0.0;
  if (cloth_ == &cloth && h == h_ && kinematic == kinematic_) return;
  cloth_ = &cloth;
  h_ = h;
  kinematic_ = std::move(kinematic);
  index_ = free_index(s, &num_free_);
  // M - h² H with H the zero-rest-length spring matrix, i.e. M + h² L_k; plus h L_c so that the springs'
  // damping is filtered too (explicit damping with c h / m > 2 would blow up at frame-size steps).
  springs_ = collect_springs(cloth);
  gather_ = PairGather(s.size(), springs_);
  if (!factor_.compute(spring_system_matrix(s, index_, num_free_, springs_, h * h, h))) {
    cloth_ = nullptr;  // nothing is prepared: the next step starts over
    throw Error("", "solver", "desbrun: factorisation of M + h² L failed: " + factor_.error());
  }
  ++factorizations_;
}

void DesbrunSolver::step(Cloth& cloth, double t, double h, int threads) {
  prepare(cloth, h);
  ClothState& s = cloth.state();
  const int n = s.size();
  cloth.compute_forces(s.x, s.v, t, threads, f_);
  rhs_.resize(num_free_, 3);
  for (int i = 0; i < n; ++i)
    if (index_[i] >= 0) rhs_.row(index_[i]) = h * f_[i].transpose();
  factor_.solve(rhs_, dv_, threads);  // parallel only when the factor is split (SplitCholesky)
  if (angular_correction_) correct_angular_momentum(s, h, threads);
  s.x_prev = s.x;
#pragma omp parallel for num_threads(threads) if (threads > 1 && n >= kMinParallel) schedule(static)
  for (int i = 0; i < n; ++i) {
    if (index_[i] >= 0) s.v[i] += dv_.row(index_[i]).transpose();
    s.x[i] += h * s.v[i];
  }
}

void DesbrunSolver::correct_angular_momentum(const ClothState& s, double h, int threads) {
  if (num_free_ < 3) return;
  // The internal forces (springs between free vertices) are central: zero net torque. Their filtered
  // response W h f_int carries a spurious angular momentum; remove it with a rigid rotation about the free
  // vertices' centre of mass (keeps linear momentum). Forces from kinematic vertices, gravity and drag have
  // genuine torques and are left alone.
  double m = 0.0;
  Vec3 c = Vec3::Zero();
  for (int i = 0; i < s.size(); ++i)
    if (index_[i] >= 0) {
      m += s.mass[i];
      c += s.mass[i] * s.x[i];
    }
  c /= m;
  // h f of each spring between free vertices (on its end i), gathered per vertex in a fixed order.
  const int n = s.size(), ns = static_cast<int>(springs_.size());
  spring_force_.resize(ns);
#pragma omp parallel num_threads(threads) if (threads > 1 && n >= kMinParallel)
  {
#pragma omp for schedule(static)
    for (int k = 0; k < ns; ++k) {
      const Spring& sp = springs_[k];
      spring_force_[k] = Vec3::Zero();
      if (index_[sp.i] < 0 || index_[sp.j] < 0) continue;
      const Vec3 d = s.x[sp.j] - s.x[sp.i];
      const double l = d.norm();
      if (l < 1e-12) continue;
      const Vec3 u = d / l;
      spring_force_[k] = h * (sp.k * (l - sp.rest_length) + sp.c * u.dot(s.v[sp.j] - s.v[sp.i])) * u;
    }
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i)
      if (index_[i] >= 0) rhs_.row(index_[i]) = gather_.sum(i, spring_force_).transpose();
  }
  factor_.solve(rhs_, dv_int_, threads);
  Vec3 spurious = Vec3::Zero();
  Mat3 inertia = Mat3::Zero();
  for (int i = 0; i < s.size(); ++i) {
    if (index_[i] < 0) continue;
    const Vec3 r = s.x[i] - c;
    spurious += s.mass[i] * r.cross(dv_int_.row(index_[i]).transpose());
    inertia += s.mass[i] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
  }
  // A degenerate (collinear) vertex set has a singular inertia tensor: leave the step uncorrected.
  Eigen::SelfAdjointEigenSolver<Mat3> eig(inertia);
  if (!(eig.eigenvalues()(0) > 1e-12 * eig.eigenvalues()(2))) return;
  const Vec3 omega = inertia.ldlt().solve(spurious);
  for (int i = 0; i < s.size(); ++i)
    if (index_[i] >= 0) dv_.row(index_[i]) -= omega.cross(s.x[i] - c).transpose();
}

}  // namespace loom::cloth
