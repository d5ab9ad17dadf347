#pragma once
// Flat-plate aerodynamics of a wind field, per triangle: drag along the relative air flow and lift across it,
// both quadratic in the flow speed (Keckeisen, Kimmerle, Thomaszewski, Wacker 2004, "Modelling effects of
// wind fields in cloth animations"; the drag and lift coefficients of Bullet's btSoftBody face aero model).
// Loom's exact form, for triangle t with area A, unit normal n̂ and mean vertex velocity v̄:
//   u = w(t) - v̄                       relative air velocity (m/s), û = u / |u|
//   c = n̂·û = cos θ                     θ: angle between the normal and the flow; c = sin α for the angle
//                                       of attack α between the plate and the flow
//   drag  f_D = ½ ρ C_D A |u|² |c| û                   (|f_D| = ½ ρ C_D A |u|² sin α, largest face-on)
//   lift  f_L = ½ ρ C_L A |u|² c (n̂ - c û)             (|f_L| = ½ ρ C_L A |u|² sin α cos α: 0 edge-on and
//                                                        face-on; perpendicular to u, in the plane of u and
//                                                        n̂, on the side the flow pushes the plate)
// Either side of the plate may face the wind (the sign of c cancels in both). f_D + f_L goes a third to each
// vertex of the triangle. Non-conservative (energy 0); every solver takes it as an external force at the
// start of each (sub)step, and its Jacobians are not formed (the force stays explicit in implicit solvers).
// Wind: w(t) = R(a, β sin(2π f_s t)) w0 (1 + Σ_k a_k sin(2π f_k t + φ_k)): gusts scale the speed, the swing
// turns the direction about the axis a by up to β.
#include <string>
#include <vector>

#include "loom/cloth/Term.h"

namespace loom::cloth {

struct Gust {
  double amplitude = 0.0;  // 1, relative to |w0|
  double frequency = 0.0;  // Hz
  double phase = 0.0;      // rad
};

struct WindSettings {
  Vec3 velocity = Vec3::Zero();  // m/s, w0
  double density = 1.2;          // kg/m³, ρ (air at 20 °C: 1.20)
  double drag = 1.0;             // 1, C_D, flat-plate drag coefficient
  double lift = 0.5;             // 1, C_L, lift coefficient
  std::vector<Gust> gusts;
  double swing_angle = 0.0;          // rad, β
  double swing_frequency = 0.0;      // Hz, f_s
  Vec3 swing_axis = Vec3::UnitY();   // unit axis a (normalised by validate)
  Vec3 velocity_at(double t) const;  // m/s, w(t)
  double max_speed() const;          // m/s, |w0| (1 + Σ |a_k|), a bound on |w(t)|
  // Throws loom::Error(file, where + ".<field>", ...) for a value out of range; normalises swing_axis.
  void validate(const std::string& file, const std::string& where);
};

class AeroTerm final : public Term {
 public:
  AeroTerm(const WindSettings& s, std::vector<Tri> triangles, int num_vertices);
  const char* name() const override { return "aero"; }
  bool conservative() const override { return false; }
  double energy(const EvalContext&) const override { return 0.0; }
  void add_forces(const EvalContext& c, Vec3s& f) const override;
  void add_jacobians(const EvalContext&, const JacobianOptions&, BlockMatrix*, BlockMatrix*) const override {}
  bool has_velocity_jacobian() const override { return false; }
  bool symmetric_jacobians(const JacobianOptions&) const override { return true; }  // adds nothing
  long work_items() const override { return static_cast<long>(triangles_.size()); }
  const WindSettings& settings() const { return s_; }

  // f_D + f_L (N) on one triangle (x0, x1, x2) moving with mean velocity v̄ in the wind w (header formula).
  static Vec3 triangle_force(const WindSettings& s, const Vec3& x0, const Vec3& x1, const Vec3& x2,
                             const Vec3& v_mean, const Vec3& w);

 private:
  WindSettings s_;
  std::vector<Tri> triangles_;
  std::vector<std::vector<int>> vertex_triangles_;  // for the deterministic gather
  mutable Vec3s tri_force_;                         // scratch: a third of triangle t's force
};

}  // namespace loom::cloth
