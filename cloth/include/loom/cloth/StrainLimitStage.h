#pragma once
// Provot 1995, "Deformation constraints in a mass-spring model to describe rigid cloth behavior",
// Graphics Interface 1995, as a pipeline stage after the solver, usable with any solver.
// Every structural and shear spring (edges on meshes) stretched beyond (1 + τ) L is shortened to exactly
// (1 + τ) L by moving its ends along the spring, in inverse-mass proportion (half each for equal masses,
// all of it to the free end if the other is kinematic). Gauss-Seidel sweeps alternate their order
// (forward, backward, ...) so the result does not favour one side; `iterations` is their most, the sweeps
// stop early once one corrected nothing. Velocities of the moved vertices are
// recomputed from the corrected positions, v = (x_corr - x_prev) / h, so springs do not re-stretch.
#include <vector>

#include "loom/cloth/Stage.h"

namespace loom::cloth {

struct StrainLimitSettings {
  double max_stretch = 0.1;  // 1, τ: largest allowed l/L - 1
  int iterations = 4;        // Gauss-Seidel sweeps per step
  // Sweeps outward from the kinematic vertices (limit_stretch_outward) instead of Provot's alternating
  // sweeps; a cloth without kinematic vertices keeps the alternating ones.
  bool outward = false;
};

// The springs of `springs` (indices into mesh.springs()) in outward order from the vertices with
// inv_mass 0: by the larger hop distance of their ends (over `springs`) from such a vertex, then by the
// smaller one (springs into a layer before the springs inside it), then by index. Empty when no vertex is
// kinematic.
struct OutwardOrder {
  std::vector<int> springs;
  // The same springs packed for the sweep: ends, rest length (m), lead: the end nearer the kinematic
  // vertices (1: i, 2: j; 0: both as far).
  struct Link {
    int i, j;
    double rest_length;
    int lead;
  };
  std::vector<Link> links;
};
OutwardOrder outward_order(const ClothMesh& mesh, const std::vector<int>& springs,
                           const std::vector<double>& inv_mass);

// Outward strain limiting, the follow-the-leader idea of Müller et al. 2012 ("Fast simulation of
// inextensible hair and fur", VRIPHYS) on Provot's projection: in `order`, a spring longer than (1 + τ) L
// is shortened to (1 + τ) L by moving only its end farther from the kinematic vertices (both ends in
// inverse-mass proportion when they are equally far). One sweep carries a pull from the pins to the free
// edge instead of one spring per sweep; `sweeps` sweeps at most, stopping after one that corrected nothing.
// moved: as limit_stretch. Returns the corrections made.
long limit_stretch_outward(const ClothMesh& mesh, const OutwardOrder& order, double max_stretch, int sweeps,
                           ClothState& state, std::vector<int>& moved);

// The springs a strain limit acts on: indices into mesh.springs() of the structural and shear springs (grids)
// or the edges (triangle meshes).
std::vector<int> limited_springs(const ClothMesh& mesh);

// Provot's projection on state.x over `springs` (indices into mesh.springs()): Gauss-Seidel sweeps in
// alternating order, at most `sweeps`, stopping after a sweep that corrected nothing (the sweeps after it
// would change nothing either). held (empty, or one flag per vertex): a held vertex is kinematic for the
// limit (weight 0: the other end moves all the way), unless both ends are held (inverse-mass weights).
// moved (one entry per vertex, zeroed by the caller): 1 + the last sweep that moved the vertex, 0 when none
// did. Returns the corrections made.
long limit_stretch(const ClothMesh& mesh, const std::vector<int>& springs, double max_stretch, int sweeps,
                   const std::vector<char>& held, ClothState& state, std::vector<int>& moved);

class StrainLimitStage final : public Stage {
 public:
  explicit StrainLimitStage(StrainLimitSettings settings) : settings_(settings) {}
  const char* name() const override { return "strain_limit"; }
  void run(StageContext& ctx) override;
  // corrections: projections made since the start; remaining_violations: springs still above (1 + τ) L
  // after the last step's sweeps (all cloths).
  std::vector<std::pair<std::string, double>> counters() const override;
  long remaining_violations() const { return remaining_; }

 private:
  StrainLimitSettings settings_;
  std::vector<std::vector<int>> limited_;  // per cloth: indices of the limited springs in mesh().springs()
  std::vector<int> moved_;                 // scratch (limit_stretch)
  // Per cloth: the limited springs whose ends both have inverse mass 0, for the inverse masses in
  // kinematic_mass_ (recomputed when they change).
  std::vector<std::vector<int>> kinematic_;
  std::vector<std::vector<double>> kinematic_mass_;
  std::vector<OutwardOrder> outward_;  // per cloth (settings_.outward): the sweep order
  std::vector<std::vector<char>>
      outward_kinematic_;  // per cloth: the inv_mass == 0 flags outward_ was built for
  long corrections_ = 0;
  long remaining_ = 0;
};

}  // namespace loom::cloth
