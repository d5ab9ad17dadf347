#pragma once
// Gravity: f_i = m_i g, E = -sum m_i g·x_i. Jacobians are zero.
#include "loom/cloth/Term.h"

namespace loom::cloth {

class GravityTerm final : public Term {
 public:
  GravityTerm(std::vector<double> mass, const Vec3& g) : mass_(std::move(mass)), g_(g) {}
  const char* name() const override { return "gravity"; }
  double energy(const EvalContext& c) const override;
  void add_forces(const EvalContext& c, Vec3s& f) const override;
  void add_jacobians(const EvalContext&, const JacobianOptions&, BlockMatrix*, BlockMatrix*) const override {}
  bool has_velocity_jacobian() const override { return false; }
  bool symmetric_jacobians(const JacobianOptions&) const override { return true; }  // adds nothing
  long work_items() const override { return static_cast<long>(mass_.size()); }
  const Vec3& g() const { return g_; }
  const std::vector<double>& mass() const { return mass_; }  // kg, per vertex: f_i = mass()[i] g

 private:
  std::vector<double> mass_;  // kg
  Vec3 g_;                    // m/s²
};

}  // namespace loom::cloth
