#include "loom/cloth/DesbrunSolver.h"

#include <Eigen/Dense>

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
  // M - h² H with H the zero-rest-length spring matrix, i.e. M + h² L_k.
  llt_.compute(spring_system_matrix(s, index_, num_free_, collect_springs(cloth), h * h, 0.0));
  if (llt_.info() != Eigen::Success) throw Error("", "solver", "desbrun: factorisation of M + h² L failed");
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
  dv_ = llt_.solve(rhs_);
  if (angular_correction_) correct_angular_momentum(s, h);
  s.x_prev = s.x;
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
  for (int i = 0; i < n; ++i) {
    if (index_[i] >= 0) s.v[i] += dv_.row(index_[i]).transpose();
    s.x[i] += h * s.v[i];
  }
}

void DesbrunSolver::correct_angular_momentum(const ClothState& s, double h) {
  if (num_free_ < 3) return;
  double m = 0.0;
  Vec3 c = Vec3::Zero();
  for (int i = 0; i < s.size(); ++i)
    if (index_[i] >= 0) {
      m += s.mass[i];
      c += s.mass[i] * s.x[i];
    }
  c /= m;
  Vec3 wanted = Vec3::Zero(), got = Vec3::Zero();
  Mat3 inertia = Mat3::Zero();
  for (int i = 0; i < s.size(); ++i) {
    if (index_[i] < 0) continue;
    const Vec3 r = s.x[i] - c;
    wanted += h * r.cross(f_[i]);
    got += s.mass[i] * r.cross(dv_.row(index_[i]).transpose());
    inertia += s.mass[i] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
  }
  // A degenerate (collinear) vertex set has a singular inertia tensor: leave the step uncorrected.
  Eigen::SelfAdjointEigenSolver<Mat3> eig(inertia);
  if (!(eig.eigenvalues()(0) > 1e-12 * eig.eigenvalues()(2))) return;
  const Vec3 omega = inertia.ldlt().solve(wanted - got);
  for (int i = 0; i < s.size(); ++i)
    if (index_[i] >= 0) dv_.row(index_[i]) += omega.cross(s.x[i] - c).transpose();
}

}  // namespace loom::cloth
