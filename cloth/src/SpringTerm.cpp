#include "loom/cloth/SpringTerm.h"

#include <algorithm>
#include <cmath>

namespace loom::cloth {

SpringTerm::SpringTerm(int num_vertices, std::vector<Spring> springs, const char* name)
    : name_(name), n_(num_vertices), springs_(std::move(springs)), gather_(num_vertices, springs_) {
  spring_force_.resize(springs_.size());
  for (const Spring& s : springs_) damped_ = damped_ || s.c != 0.0;
}

double SpringTerm::energy(const EvalContext& c) const {
  return chunked_sum(static_cast<int>(springs_.size()), c.threads, [&](int k) {
    const Spring& s = springs_[k];
    const double stretch = (c.x[s.j] - c.x[s.i]).norm() - s.rest_length;
    return 0.5 * s.k * stretch * stretch;
  });
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
  const int ns = static_cast<int>(springs_.size());
  const bool want_v = dfdv && damped_;
  if (!dfdx && !want_v) return;
  if (dfdx) kx_.resize(ns);
  if (want_v) kv_.resize(ns);
    // Per spring, in parallel: the block K = df_i/dx_j (and D = df_i/dv_j); the matrix gets -K, K, K, -K at
    // (i,i), (i,j), (j,i), (j,j).
#pragma omp parallel for num_threads(c.threads) if (c.threads > 1) schedule(static)
  for (int k = 0; k < ns; ++k) {
    const Spring& s = springs_[k];
    const Vec3 d = c.x[s.j] - c.x[s.i];
    const double l = d.norm();
    const Vec3 n = d / l;
    const Mat3 nn = n * n.transpose();
    if (dfdx) {
      // K = d f_i / d x_j = k [x̂x̂ᵀ + (1 - L/l)(I - x̂x̂ᵀ)]  (docs/references.md, "Cloth models")
      const Mat3 transverse = Mat3::Identity() - nn;
      double ratio = 1.0 - s.rest_length / l;
      if (o.clamp_compression) ratio = std::max(ratio, 0.0);
      Mat3 K = s.k * (nn + ratio * transverse);
      if (o.damping_position_terms && s.c != 0.0) {
        // d/dd [c (x̂·u) x̂] = c [(x̂·u) I + x̂ uᵀ] (I - x̂x̂ᵀ) / l, u = v_j - v_i.
        const Vec3 u = c.v[s.j] - c.v[s.i];
        K += s.c * ((n.dot(u)) * Mat3::Identity() + n * u.transpose()) * transverse / l;
      }
      kx_[k] = K;
    }
    if (want_v) kv_[k] = s.c * nn;  // zero for an undamped spring of a damped set: adds nothing
  }
  // Added block by block in spring order: the same sums as a serial loop over springs, for any thread count.
  auto add = [&](BlockGather& g, BlockMatrix& m, const std::vector<Mat3>& src) {
    if (!g.ready(m, ns))
      g.build(m, ns, [&](const auto& emit) {
        for (int k = 0; k < ns; ++k) {
          const Spring& s = springs_[k];
          emit(s.i, s.i, k, true);
          emit(s.i, s.j, k, false);
          emit(s.j, s.i, k, false);
          emit(s.j, s.j, k, true);
        }
      });
    g.add(m, src, c.threads);
  };
  if (dfdx) add(gather_x_, *dfdx, kx_);
  if (want_v) add(gather_v_, *dfdv, kv_);
}

}  // namespace loom::cloth
