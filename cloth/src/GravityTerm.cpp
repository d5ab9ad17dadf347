#include "loom/cloth/GravityTerm.h"

namespace loom::cloth {

double GravityTerm::energy(const EvalContext& c) const {
  return -chunked_sum(static_cast<int>(mass_.size()), c.threads,
                      [&](int i) { return mass_[i] * g_.dot(c.x[i]); });
}

void GravityTerm::add_forces(const EvalContext& c, Vec3s& f) const {
  const int n = static_cast<int>(mass_.size());
#pragma omp parallel for num_threads(c.threads) if (c.threads > 1 && n >= kParallelMinVertices) \
    schedule(static)
  for (int i = 0; i < n; ++i) f[i] += mass_[i] * g_;
}

}  // namespace loom::cloth
