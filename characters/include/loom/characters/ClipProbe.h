#pragma once
// ClipProbe: the character checks measured at every pipeline step of a character run (tests,
// `loom_bench_character_clips`). Add it last (Simulation::Slot::after_solve, after the collision stages);
// at the end of each step [t, t + h] it records
//   - whether every position and velocity is finite,
//   - the largest vertex speed (m/s),
//   - the deepest free (non-attached) vertex inside a capsule of the rig at its pose at t + h, measured
//     independently of the collision stage (segment distance minus radius), and the same for attached ones,
//   - the largest distance of an attached vertex from its bone target at t + h,
//   - optionally the exact intersection census of all cloths (collision::count_all_intersections).
// Maxima of a frame that the guard rolls back are discarded with it (save_state / load_state).
#include <memory>
#include <vector>

#include "loom/characters/Character.h"

namespace loom::characters {

struct ProbeFigures {
  long steps = 0;
  bool finite = true;
  double max_speed = 0.0;  // m/s, over all vertices
  double max_depth = 0.0;  // m, deepest free vertex inside a capsule (0: none inside)
  double max_attached_depth =
      0.0;                     // m, the same for attached vertices (they follow their bone, not contacts)
  double max_track = 0.0;      // m, attached vertex to bone target
  long max_intersections = 0;  // census: intersecting triangle pairs (self and between cloths), worst step
  long census_steps = 0;       // steps the census ran at
  // s, simulated time (end of the step) of the worst step of each: where the hardest seconds of a clip are
  double max_speed_time = 0.0, max_depth_time = 0.0, max_attached_depth_time = 0.0;
  // Rig bone (index into CapsuleRig::bones()) of the deepest free / attached vertex (-1: none inside)
  int max_depth_bone = -1, max_attached_depth_bone = -1;
};

class ClipProbe final : public cloth::Stage {
 public:
  // `census_every`: run the census every n-th step (0: never; it costs about as much as a step).
  explicit ClipProbe(std::shared_ptr<const Character> character, int census_every = 0);
  const char* name() const override { return "character_probe"; }
  void run(cloth::StageContext& ctx) override;
  void save_state(cloth::StateWriter& out) const override;
  void load_state(cloth::StateReader& in) override;
  const ProbeFigures& figures() const { return f_; }

 private:
  std::shared_ptr<const Character> character_;
  int census_every_ = 0;
  ProbeFigures f_;
  std::vector<std::vector<char>> attached_;  // per cloth, per vertex
  std::vector<Transform> pose_;
};

}  // namespace loom::characters
