#pragma once
// ClothState: what changes every step, as plain arrays with no pointers into the mesh (docs/architecture.md).
#include "loom/cloth/Types.h"

namespace loom::cloth {

struct ClothState {
  Vec3s x;                       // m, positions
  Vec3s v;                       // m/s, velocities
  Vec3s x_prev;                  // m, positions at the start of the last step (Verlet, BDF2, strain passes)
  std::vector<double> mass;      // kg, lumped vertex masses (pinned vertices keep theirs for statistics)
  std::vector<double> inv_mass;  // 1/kg, 0 for pinned (kinematic) vertices
  // 1, per vertex: the unit normal of a contact the vertex is held against for the next solve (zero vector:
  // none; empty: no contacts). A collision stage sets it after the step; implicit solvers keep the velocity's
  // component along it through their linear solves (Baraff & Witkin 1998 Sec. 5.3, the filtered PCG) and
  // release a contact whose constraint impulse would pull the vertex towards the body. Other solvers ignore
  // it.
  Vec3s contact_normal;

  int size() const { return static_cast<int>(x.size()); }
  bool is_finite() const;
};

}  // namespace loom::cloth
