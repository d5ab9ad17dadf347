#pragma once
// Pins: vertices whose motion is prescribed. A pin is fixed at its start position, or follows a path of
// keyframed offsets (linear in time, held constant past the last key) — the base of moving attachments.
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::cloth {

struct Pin {
  int vertex = 0;
  Vec3 anchor = Vec3::Zero();  // m, position at t = 0 (the vertex's start position unless given)
  std::vector<double> times;   // s, strictly increasing keyframe times (empty: fixed pin)
  std::vector<Vec3> offsets;   // m, offset from `anchor` at each key time

  Vec3 target(double t) const;  // m, where the vertex must be at time t
};

}  // namespace loom::cloth
