#pragma once
// The explicit family (docs/references.md, "Time integration"), with their
// stability limits (ω_max: the stiffest mode):
//  - explicit Euler:   x+ = x + h v,  v+ = v + h M⁻¹ f(x, v). Unstable on an undamped oscillator for any h.
//  - symplectic Euler: v+ = v + h M⁻¹ f(x, v), then x+ = x + h v+. Stable iff h ω_max < 2.
//  - position Verlet:  x+ = 2x - x- + h² M⁻¹ f(x, v), v+ = (x+ - x)/h + h/2 M⁻¹ f. Stable iff h ω_max < 2.
#include "loom/cloth/Solver.h"

namespace loom::cloth {

class ExplicitEuler final : public Solver {
 public:
  const char* name() const override { return "explicit_euler"; }
  void step(Cloth& cloth, double t, double h, int threads) override;

 private:
  Vec3s f_;
};

class SymplecticEuler final : public Solver {
 public:
  const char* name() const override { return "symplectic_euler"; }
  void step(Cloth& cloth, double t, double h, int threads) override;

 private:
  Vec3s f_;
};

class Verlet final : public Solver {
 public:
  const char* name() const override { return "verlet"; }
  void step(Cloth& cloth, double t, double h, int threads) override;
  void reset() override { h_prev_ = 0.0; }
  void save_state(StateWriter& out) const override { out.f64(h_prev_); }
  void load_state(StateReader& in, const Cloth&) override { h_prev_ = in.f64(); }

 private:
  Vec3s f_;
  double h_prev_ = 0.0;  // step of the last call; 0 = start from (x, v)
};

}  // namespace loom::cloth
