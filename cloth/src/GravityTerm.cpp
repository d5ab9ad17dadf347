#include "loom/cloth/GravityTerm.h"

namespace loom::cloth {

double GravityTerm::energy(const EvalContext& c) const {
  double e = 0.0;
  for (size_t i = 0; i < mass_.size(); ++i) e -= mass_[i] * g_.dot(c.x[i]);
  return e;
}

void GravityTerm::add_forces(const EvalContext&, Vec3s& f) const {
  for (size_t i = 0; i < mass_.size(); ++i) f[i] += mass_[i] * g_;
}

}  // namespace loom::cloth
