#include "loom/cloth/StaticSolver.h"

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>

#include "loom/cloth/Error.h"

namespace loom::cloth {

void StaticSolver::check(const Cloth& cloth) const {
  for (const auto& t : cloth.terms())
    if (!t->conservative())
      throw Error("", "solver.method",
                  std::string("the static solver cannot use the non-conservative term '") + t->name() +
                      "' (remove the effect or use a dynamic solver)");
}

double StaticSolver::total_energy(const Cloth& cloth, const Vec3s& x, int threads) const {
  const Vec3s v(x.size(), Vec3::Zero());
  const EvalContext ctx{x, v, 0.0, threads};
  double e = 0.0;
  for (const auto& t : cloth.terms()) e += t->energy(ctx);
  return e;
}

void StaticSolver::step(Cloth& cloth, double t, double h, int threads) {
  ClothState& s = cloth.state();
  const int n = s.size();
  s.x_prev = s.x;
  // Pins go to their targets (the pin stage set v so that x + h v is the target).
  for (int i = 0; i < n; ++i)
    if (s.inv_mass[i] == 0.0) s.x[i] += h * s.v[i];
  // Free degrees of freedom.
  std::vector<int> dof(n, -1);
  int nf = 0;
  double weight = 0.0;
  for (int i = 0; i < n; ++i) {
    if (s.inv_mass[i] != 0.0) dof[i] = nf++;
    weight += s.mass[i] * 9.81;
  }
  const Vec3s zero_v(n, Vec3::Zero());
  std::vector<std::pair<int, int>> pairs;
  for (const auto& term : cloth.terms()) term->add_pattern(pairs);
  BlockMatrix K(n, pairs);
  JacobianOptions opts;
  opts.clamp_compression = true;
  opts.damping_position_terms = false;
  Vec3s f;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  double mu = 0.0;
  last_iterations_ = 0;
  // H = -K over the free DOFs: one pattern, analysed (ordered) once per step; each Levenberg try only
  // refactorises H + mu I numerically.
  Eigen::SparseMatrix<double> H(3 * nf, 3 * nf), Hs;
  bool analysed = false;
  for (int it = 0; it < s_.max_iterations; ++it) {
    cloth.compute_forces(s.x, zero_v, t + h, threads, f);
    Eigen::VectorXd g(3 * nf);
    double residual = 0.0;
    for (int i = 0; i < n; ++i)
      if (dof[i] >= 0) {
        g.segment<3>(3 * dof[i]) = -f[i];
        residual = std::max(residual, f[i].cwiseAbs().maxCoeff());
      }
    last_residual_ = residual;
    if (residual < s_.tolerance * (weight + 1e-12)) break;
    ++last_iterations_;
    // H = -K over the free DOFs.
    K.set_zero();
    const EvalContext ctx{s.x, zero_v, t + h, threads};
    for (const auto& term : cloth.terms()) term->add_jacobians(ctx, opts, &K, nullptr);
    std::vector<Eigen::Triplet<double>> trips;
    trips.reserve(static_cast<size_t>(K.num_blocks()) * 9);
    double max_diag = 0.0;
    for (int i = 0; i < n; ++i) {
      if (dof[i] < 0) continue;
      for (int k = K.row_start()[i]; k < K.row_start()[i + 1]; ++k) {
        const int j = K.cols()[k];
        if (dof[j] < 0) continue;
        const Mat3& b = K.blocks()[k];
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) trips.emplace_back(3 * dof[i] + r, 3 * dof[j] + c, -b(r, c));
        if (i == j) max_diag = std::max(max_diag, -b.diagonal().minCoeff());
      }
    }
    H.setFromTriplets(trips.begin(), trips.end());  // the same pattern every iteration (zeros are kept)
    if (!analysed) {
      ldlt.analyzePattern(H);
      analysed = true;
    }
    if (mu == 0.0) mu = 1e-10 * std::max(max_diag, 1e-12);
    Eigen::VectorXd p;
    // Levenberg shift: grow until the factorisation succeeds and p is a descent direction.
    for (int tries = 0; tries < 40; ++tries) {
      Hs = H;
      Hs.diagonal().array() += mu;  // K has every diagonal block, so the diagonal is in the pattern
      ldlt.factorize(Hs);
      if (ldlt.info() == Eigen::Success) {
        p = ldlt.solve(-g);
        if (ldlt.info() == Eigen::Success && p.allFinite() && p.dot(g) < 0.0) break;
      }
      mu *= 10.0;
      p.resize(0);
    }
    if (p.size() == 0) break;  // no descent direction: leave the state as it is (finite)
    // Backtracking line search on E (Armijo).
    const double e0 = total_energy(cloth, s.x, threads), slope = p.dot(g);
    Vec3s trial = s.x;
    double alpha = 1.0;
    bool accepted = false;
    for (int ls = 0; ls < 30; ++ls) {
      for (int i = 0; i < n; ++i)
        if (dof[i] >= 0) trial[i] = s.x[i] + alpha * p.segment<3>(3 * dof[i]);
      const double e = total_energy(cloth, trial, threads);
      if (std::isfinite(e) && e <= e0 + 1e-4 * alpha * slope) {
        accepted = true;
        break;
      }
      alpha *= 0.5;
    }
    if (!accepted) {
      mu *= 10.0;  // make the next direction more like gradient descent
      continue;
    }
    s.x.swap(trial);
    mu = std::max(mu * (alpha == 1.0 ? 0.1 : 1.0), 1e-14 * std::max(max_diag, 1e-12));
  }
  for (int i = 0; i < n; ++i) s.v[i] = s.inv_mass[i] == 0.0 ? s.v[i] : Vec3::Zero();
}

}  // namespace loom::cloth
