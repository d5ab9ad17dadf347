#pragma once
// ClothState: what changes every step, as plain arrays with no pointers into the mesh (DESIGN.md).
#include "loom/cloth/Types.h"

namespace loom::cloth {

struct ClothState {
  Vec3s x;                        // m, positions
  Vec3s v;                        // m/s, velocities
  Vec3s x_prev;                   // m, positions at the start of the last step (Verlet, BDF2, strain passes)
  std::vector<double> mass;       // kg, lumped vertex masses (pinned vertices keep theirs for statistics)
  std::vector<double> inv_mass;   // 1/kg, 0 for pinned (kinematic) vertices

  int size() const { return static_cast<int>(x.size()); }
  bool is_finite() const;
};

}  // namespace loom::cloth
