#include "loom/cloth/SpringTerm.h"

#include <cmath>

namespace loom::cloth {

SpringTerm::SpringTerm(int num_vertices, std::vector<Spring> springs, const char* name)
    : name_(name), n_(num_vertices), springs_(std::move(springs)), gather_(num_vertices, springs_) {
  spring_force_.resize(springs_.size());
}

double SpringTerm::energy(const EvalContext& c) const {
  double e = 0.0;
  for (const Spring& s : springs_) {
    const double stretch = (c.x[s.j] - c.x[s.i]).norm() - s.rest_length;
    e += 0.5 * s.k * stretch * stretch;
  }
  return e;
}

void SpringTerm::add_forces(const EvalContext& c, Vec3s& f) const {
  const int ns = static_cast<int>(springs_.size());
#pragma omp parallel num_threads(c.threads) if (c.threads > 1)
  {
#pragma omp for schedule(static)
    for (int k = 0; k < ns; ++k) {
      const Spring& s = springs_[k];
      const Vec3 d = c.x[s.j] - c.x[s.i];
      const double l = d.norm();
      const Vec3 n = d / l;
      spring_force_[k] = (s.k * (l - s.rest_length) + s.c * n.dot(c.v[s.j] - c.v[s.i])) * n;
    }
    // Gather in a fixed order per vertex: deterministic for any thread count.
#pragma omp for schedule(static)
    for (int i = 0; i < n_; ++i) f[i] += gather_.sum(i, spring_force_);
  }
}

void SpringTerm::add_pattern(std::vector<std::pair<int, int>>& pairs) const {
  for (const Spring& s : springs_) pairs.emplace_back(s.i, s.j);
}

void SpringTerm::add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                               BlockMatrix* dfdv) const {
  for (const Spring& s : springs_) {
    const Vec3 d = c.x[s.j] - c.x[s.i];
    const double l = d.norm();
    const Vec3 n = d / l;
    const Mat3 nn = n * n.transpose();
    const Mat3 transverse = Mat3::Identity() - nn;
    if (dfdx) {
      // K = d f_i / d x_j = k [x̂x̂ᵀ + (1 - L/l)(I - x̂x̂ᵀ)]  (methods.md §1.1)
      double ratio = 1.0 - s.rest_length / l;
      if (o.clamp_compression) ratio = std::max(ratio, 0.0);
      Mat3 K = s.k * (nn + ratio * transverse);
      if (o.damping_position_terms && s.c != 0.0) {
        // d/dd [c (x̂·u) x̂] = c [(x̂·u) I + x̂ uᵀ] (I - x̂x̂ᵀ) / l, u = v_j - v_i.
        const Vec3 u = c.v[s.j] - c.v[s.i];
        K += s.c * ((n.dot(u)) * Mat3::Identity() + n * u.transpose()) * transverse / l;
      }
      dfdx->add(s.i, s.i, -K);
      dfdx->add(s.i, s.j, K);
      dfdx->add(s.j, s.i, K);
      dfdx->add(s.j, s.j, -K);
    }
    if (dfdv && s.c != 0.0) {
      const Mat3 D = s.c * nn;
      dfdv->add(s.i, s.i, -D);
      dfdv->add(s.i, s.j, D);
      dfdv->add(s.j, s.i, D);
      dfdv->add(s.j, s.j, -D);
    }
  }
}

}  // namespace loom::cloth
