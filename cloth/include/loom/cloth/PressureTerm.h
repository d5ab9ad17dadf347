#pragma once
// Gas pressure inside a closed cloth (a pillow, a balloon, a closed garment), per triangle: the net pressure
// Δp = p_in - p_out pushes each face outward with f_t = Δp A_t n̂_t = ½ Δp N_t (N_t = e1 × e2, outward),
// a third to each vertex. On a closed mesh Σ_t ⅓ ½ N_t over the faces of vertex i is ∂V/∂x_i, so the force is
// Δp ∇V (the pressure model of soft-body and balloon simulations, e.g. Matyka and Ollila 2003, "Pressure
// model of soft body simulation"). The enclosed volume is V = ⅙ Σ_t x0·(x1 × x2) (divergence theorem).
//   constant:   Δp = p_over
//   ideal_gas:  p_in V = n R T fixed at the rest volume (isothermal Boyle law):
//               Δp(V) = (p_out + p_over) V_rest / V - p_out
// Non-conservative as far as the solvers see it (energy 0): every solver takes it as an external force at the
// start of each (sub)step; its Jacobians are not formed.
#include <string>
#include <vector>

#include "loom/cloth/Term.h"

namespace loom::cloth {

struct PressureSettings {
  bool ideal_gas = false;     // false: Δp = overpressure at any volume
  double overpressure = 0.0;  // Pa, p_in - p_out (constant), or at the rest volume (ideal gas)
  double ambient = 101325.0;  // Pa, p_out (ideal gas only)
  // Throws loom::Error(file, where + ".<field>", ...) for a value out of range.
  void validate(const std::string& file, const std::string& where) const;
};

class PressureTerm final : public Term {
 public:
  // `triangles` must close a volume (consistently wound; either orientation: the rest volume's sign says
  // which way is out). `rest_positions` give V_rest.
  PressureTerm(const PressureSettings& s, std::vector<Tri> triangles, const Vec3s& rest_positions);
  const char* name() const override { return "pressure"; }
  bool conservative() const override { return false; }
  double energy(const EvalContext&) const override { return 0.0; }
  void add_forces(const EvalContext& c, Vec3s& f) const override;
  void add_jacobians(const EvalContext&, const JacobianOptions&, BlockMatrix*, BlockMatrix*) const override {}
  bool has_velocity_jacobian() const override { return false; }
  bool symmetric_jacobians(const JacobianOptions&) const override { return true; }  // adds nothing
  long work_items() const override { return static_cast<long>(triangles_.size()); }

  // Signed volume enclosed by the triangles at x (m³), outward orientation positive.
  double volume(const Vec3s& x) const;
  double rest_volume() const { return rest_volume_; }  // m³
  double pressure_at(double volume) const;             // Pa, Δp(V)

 private:
  PressureSettings s_;
  std::vector<Tri> triangles_;
  double orientation_ = 1.0;  // +1 or -1: makes the rest volume positive
  double rest_volume_ = 0.0;  // m³
  std::vector<std::vector<int>> vertex_triangles_;
  mutable Vec3s tri_force_;  // scratch: a third of triangle t's force
};

// "" if the mesh's triangles close a volume (every edge shared by two triangles), else why not.
std::string closed_mesh_problem(int num_edges, int num_interior_edges);

}  // namespace loom::cloth
