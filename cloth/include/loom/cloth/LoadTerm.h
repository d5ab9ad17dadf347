#pragma once
// LoadTerm: constant external forces on chosen vertices (a tensile tester's clamp, a hanging weight).
// Conservative: E = -sum F_i · x_i; Jacobians are zero.
#include "loom/cloth/Term.h"

namespace loom::cloth {

class LoadTerm final : public Term {
 public:
  LoadTerm(std::vector<int> vertices, Vec3s forces)
      : vertices_(std::move(vertices)), forces_(std::move(forces)) {}
  const char* name() const override { return "load"; }
  double energy(const EvalContext& c) const override {
    double e = 0.0;
    for (size_t k = 0; k < vertices_.size(); ++k) e -= forces_[k].dot(c.x[vertices_[k]]);
    return e;
  }
  void add_forces(const EvalContext&, Vec3s& f) const override {
    for (size_t k = 0; k < vertices_.size(); ++k) f[vertices_[k]] += forces_[k];
  }
  void add_jacobians(const EvalContext&, const JacobianOptions&, BlockMatrix*, BlockMatrix*) const override {}
  bool has_velocity_jacobian() const override { return false; }
  bool symmetric_jacobians(const JacobianOptions&) const override { return true; }  // adds nothing
  long work_items() const override { return static_cast<long>(vertices_.size()); }

 private:
  std::vector<int> vertices_;
  Vec3s forces_;  // N
};

}  // namespace loom::cloth
