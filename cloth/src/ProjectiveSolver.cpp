#include "loom/cloth/ProjectiveSolver.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

#include "Numbers.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/SpringSolverSupport.h"

namespace loom::cloth {

void ProjectiveSolver::check(const Cloth& cloth) const { check_spring_terms(cloth, name()); }

void ProjectiveSolver::prepare(const Cloth& cloth, double h) {
  const ClothState& s = cloth.state();
  std::vector<char> kinematic(s.size());
  for (int i = 0; i < s.size(); ++i) kinematic[i] = s.inv_mass[i] == 0.0;
  if (cloth_ == &cloth && h == h_ && kinematic == kinematic_) return;
  if (cloth_ != &cloth) {
    springs_ = collect_springs(cloth);
    gather_ = PairGather(s.size(), springs_);
    triangles_.clear();
    tri_g_.clear();
    tri_weight_.clear();
    if (settings_.strain_limit > 0.0) {
      const ClothMesh& mesh = cloth.mesh();
      const double w = settings_.strain_stiffness > 0.0
                           ? settings_.strain_stiffness
                           : 100.0 * std::max(cloth.material().stretch_weft, cloth.material().stretch_warp);
      for (int t = 0; t < mesh.num_triangles(); ++t) {
        const auto& uv = mesh.triangle_frames()[t].rest_uv;
        Eigen::Matrix2d dm;
        dm.col(0) = uv[1] - uv[0];
        dm.col(1) = uv[2] - uv[0];
        const Eigen::Matrix2d b = dm.inverse();  // F = [x1 - x0, x2 - x0] b
        const Vec2 g1 = b.row(0).transpose(), g2 = b.row(1).transpose();
        triangles_.push_back(mesh.triangles()[t]);
        tri_g_.push_back({-(g1 + g2), g1, g2});
        tri_weight_.push_back(w * mesh.triangle_rest_areas()[t]);
      }
    }
  }
  cloth_ = &cloth;
  h_ = h;
  kinematic_ = std::move(kinematic);
  index_ = free_index(s, &num_free_);
  // Liu 2013, global step: M + h² L_k (+ h L_c for the damping term), kinematic DOFs eliminated.
  Eigen::SparseMatrix<double> a = spring_system_matrix(s, index_, num_free_, springs_, h * h, h);
  if (!triangles_.empty()) {
    // h² Σ_t w A (g_m·g_n) over free corners (Bouaziz 2014: Σ w SᵀAᵀAS).
    std::vector<Eigen::Triplet<double>> trip;
    for (size_t t = 0; t < triangles_.size(); ++t)
      for (int m = 0; m < 3; ++m)
        for (int n = 0; n < 3; ++n) {
          const int fm = index_[triangles_[t][m]], fn = index_[triangles_[t][n]];
          if (fm >= 0 && fn >= 0)
            trip.emplace_back(fm, fn, h * h * tri_weight_[t] * tri_g_[t][m].dot(tri_g_[t][n]));
        }
    Eigen::SparseMatrix<double> tri(num_free_, num_free_);
    tri.setFromTriplets(trip.begin(), trip.end());
    a += tri;
  }
  if (!factor_.compute(a)) {
    cloth_ = nullptr;  // nothing is prepared: the next step starts over
    throw Error("", "solver", "projective: factorisation of M + h² L failed: " + factor_.error());
  }
  ++factorizations_;
}

void ProjectiveSolver::step(Cloth& cloth, double t, double h, int threads) {
  prepare(cloth, h);
  ClothState& s = cloth.state();
  const int n = s.size();
  const int ns = static_cast<int>(springs_.size());
  external_forces(cloth, s.x, s.v, t, threads, f_);
  x_n_ = s.x;
  y_.resize(n);
  base_rhs_.resize(num_free_, 3);
  if (static_cast<int>(spring_rhs_.size()) != ns) spring_rhs_.resize(ns);
  q_.resize(num_free_, 3);
#pragma omp parallel num_threads(threads) if (threads > 1 && n >= kMinParallel)
  {
    // y = x_n + h v_n + h² M⁻¹ f_ext; kinematic vertices sit at their target x_n + h v from the start.
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      y_[i] = s.x[i] + h * (s.v[i] + h * s.inv_mass[i] * f_[i]);
      s.x[i] = y_[i];
    }
    // Constant part of the right-hand side: M y + h L_c x_n + couplings to kinematic vertices, as a term
    // per spring (its end i's share; end j takes the negative) gathered per vertex in a fixed order.
#pragma omp for schedule(static)
    for (int k = 0; k < ns; ++k) {
      const Spring& sp = springs_[k];
      const double w = h * h * sp.k + h * sp.c;
      Vec3 r = -h * sp.c * (x_n_[sp.j] - x_n_[sp.i]);
      if (index_[sp.j] < 0) r += w * s.x[sp.j];
      if (index_[sp.i] < 0) r -= w * s.x[sp.i];
      spring_rhs_[k] = r;
    }
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i)
      if (index_[i] >= 0) {
        base_rhs_.row(index_[i]) = (s.mass[i] * y_[i] + gather_.sum(i, spring_rhs_)).transpose();
        q_.row(index_[i]) = s.x[i].transpose();
      }
  }
  q_prev_ = q_;
  rhs_.resize(num_free_, 3);
  trace_.clear();
  if (record_) trace_.push_back(measure(s, h, threads));
  double omega = 1.0;
  const double rho2 = settings_.rho * settings_.rho;
  for (int it = 0; it < settings_.iterations; ++it) {
    // Local step (Liu 2013, local step): the closest point of each spring's constraint set, as the force term
    // h² J d (on end i: -h² k d, on end j: +h² k d).
#pragma omp parallel num_threads(threads) if (threads > 1 && n >= kMinParallel)
    {
#pragma omp for schedule(static)
      for (int k = 0; k < ns; ++k) {
        const Spring& sp = springs_[k];
        const Vec3 dx = s.x[sp.j] - s.x[sp.i];
        const double l = dx.norm();
        const Vec3 d = l > 1e-12 ? Vec3(dx * (sp.rest_length / l)) : Vec3(dx);
        spring_rhs_[k] = (-h * h * sp.k) * d;
      }
#pragma omp for schedule(static)
      for (int i = 0; i < n; ++i)
        if (index_[i] >= 0)
          rhs_.row(index_[i]) = base_rhs_.row(index_[i]) + gather_.sum(i, spring_rhs_).transpose();
    }
    if (!triangles_.empty()) add_strain_projection(s, h, rhs_);
    // Global step: the prefactorised solve, three right-hand sides at once.
    factor_.solve(rhs_, q_hat_, threads);  // parallel only when the factor is split
    if (settings_.chebyshev && it >= settings_.warmup) {
      // Wang 2015 with γ = 1 (direct global solve).
      omega = it == settings_.warmup ? 2.0 / (2.0 - rho2) : 4.0 / (4.0 - rho2 * omega);
#pragma omp parallel for num_threads(threads) if (threads > 1 && n >= kMinParallel) schedule(static)
      for (int r = 0; r < num_free_; ++r)
        q_hat_.row(r) = omega * (q_hat_.row(r) - q_prev_.row(r)) + q_prev_.row(r);
    }
    q_prev_.swap(q_);
    q_.swap(q_hat_);
#pragma omp parallel for num_threads(threads) if (threads > 1 && n >= kMinParallel) schedule(static)
    for (int i = 0; i < n; ++i)
      if (index_[i] >= 0) s.x[i] = q_.row(index_[i]).transpose();
    if (record_) trace_.push_back(measure(s, h, threads));
  }
  s.x_prev = x_n_;
#pragma omp parallel for num_threads(threads) if (threads > 1 && n >= kMinParallel) schedule(static)
  for (int i = 0; i < n; ++i)
    if (index_[i] >= 0) s.v[i] = (s.x[i] - x_n_[i]) / h;
}

ProjectiveIteration ProjectiveSolver::measure(const ClothState& s, double h, int) {
  ProjectiveIteration r;
  const int n = s.size();
  gradient_.assign(n, Vec3::Zero());
  for (int i = 0; i < n; ++i) {
    if (index_[i] < 0) continue;
    const Vec3 e = s.x[i] - y_[i];
    r.objective += 0.5 * s.mass[i] * e.squaredNorm();
    gradient_[i] = s.mass[i] * e;
  }
  for (const Spring& sp : springs_) {
    const Vec3 dx = s.x[sp.j] - s.x[sp.i];
    const double l = dx.norm();
    const double stretch = l - sp.rest_length;
    const Vec3 rel = dx - (x_n_[sp.j] - x_n_[sp.i]);
    r.objective += h * h * 0.5 * sp.k * stretch * stretch + 0.5 * h * sp.c * rel.squaredNorm();
    // ∇ of the spring and damping terms with respect to x_j (minus for x_i).
    const Vec3 g = h * h * sp.k * stretch * (l > 0.0 ? Vec3(dx / l) : Vec3::Zero()) + h * sp.c * rel;
    gradient_[sp.i] -= g;
    gradient_[sp.j] += g;
  }
  if (!triangles_.empty()) {
    Vec3s g(n, Vec3::Zero());
    r.objective += h * h * strain_energy(s, &g);
    for (int i = 0; i < n; ++i) gradient_[i] += h * h * g[i];
  }
  double sum = 0.0;
  for (int i = 0; i < n; ++i)
    if (index_[i] >= 0) sum += gradient_[i].squaredNorm();
  r.residual = std::sqrt(sum);
  return r;
}

namespace {
// Deformation gradient of triangle t (3x2) and its projection onto the strain band (SVD clamp).
Eigen::Matrix<double, 3, 2> clamp_strain(const Eigen::Matrix<double, 3, 2>& f, double tau) {
  // Full U (3x3) and its first two columns: Eigen allows thin U/V only for a dynamic column count (with
  // fixed sizes it asserts in debug builds and leaves U's shape undefined without asserts).
  Eigen::JacobiSVD<Eigen::Matrix<double, 3, 2>> svd(f, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Vec2 sigma = svd.singularValues();
  for (int k = 0; k < 2; ++k) sigma[k] = std::clamp(sigma[k], 1.0 - tau, 1.0 + tau);
  return svd.matrixU().leftCols<2>() * sigma.asDiagonal() * svd.matrixV().transpose();
}
}  // namespace

void ProjectiveSolver::add_strain_projection(const ClothState& s, double h, Eigen::MatrixX3d& rhs) const {
  // Local step for triangles, then their part of the right-hand side, h² w A T g_m (minus the couplings to
  // kinematic corners, which sit on the left in the free rows). Sequential: deterministic sums.
  for (size_t t = 0; t < triangles_.size(); ++t) {
    const Tri& tri = triangles_[t];
    const auto& g = tri_g_[t];
    Eigen::Matrix<double, 3, 2> f = Eigen::Matrix<double, 3, 2>::Zero();
    for (int m = 0; m < 3; ++m) f += s.x[tri[m]] * g[m].transpose();
    const Eigen::Matrix<double, 3, 2> target = clamp_strain(f, settings_.strain_limit);
    const double w = h * h * tri_weight_[t];
    for (int m = 0; m < 3; ++m) {
      const int fm = index_[tri[m]];
      if (fm < 0) continue;
      Vec3 b = w * (target * g[m]);
      for (int n = 0; n < 3; ++n)
        if (index_[tri[n]] < 0) b -= w * g[m].dot(g[n]) * s.x[tri[n]];
      rhs.row(fm) += b.transpose();
    }
  }
}

double ProjectiveSolver::strain_energy(const ClothState& s, Vec3s* gradient) const {
  double e = 0.0;
  for (size_t t = 0; t < triangles_.size(); ++t) {
    const Tri& tri = triangles_[t];
    const auto& g = tri_g_[t];
    Eigen::Matrix<double, 3, 2> f = Eigen::Matrix<double, 3, 2>::Zero();
    for (int m = 0; m < 3; ++m) f += s.x[tri[m]] * g[m].transpose();
    const Eigen::Matrix<double, 3, 2> d = f - clamp_strain(f, settings_.strain_limit);
    e += 0.5 * tri_weight_[t] * d.squaredNorm();
    if (gradient)
      for (int m = 0; m < 3; ++m) (*gradient)[tri[m]] += tri_weight_[t] * (d * g[m]);
  }
  return e;
}

}  // namespace loom::cloth
