#pragma once
// ContactGuardStage: the contact side of the non-finite / explosion guard (cloth/Guard.h). The
// pipeline stage "contact_guard", after the collision stages (the scene builder adds it when the scene's
// `guard` asks for `max_penetration` or `energy_bound`). After every step it
//   - measures the deepest free cloth vertex inside a collider at its end pose (`curr`), by the collider's
//     signed distance (ColliderDistance.h; meshes have no inside); deeper than `max_depth` is a violation
//     (Stage::violation(): "could not resolve contacts: vertex V of cloth C is D mm inside collider K"), so
//     the guard rolls the frame back, retries it with smaller steps and, failing that, stops the run with it;
//   - adds the colliders' push to the work put into the cloths (Stage::work_in(), the guard's energy
//     budget): per collider |ΔJ·v| + |ΔL·ω|, ΔJ and ΔL the change over the step of its reaction impulse and
//     of its moment about curr's origin (the body stage sums them), v and ω its velocity and spin over the
//     step (prev -> curr). The work of a rigid body on the cloth is Σ J_i·(v + ω × r_i) = v·ΣJ_i + ω·Σ r_i ×
//     J_i.
#include <string>
#include <vector>

#include "loom/cloth/Stage.h"
#include "loom/collision/Collider.h"

namespace loom::collision {

class ContactGuardStage final : public cloth::Stage {
 public:
  // max_depth: m, deepest accepted vertex inside a collider after a step (<= 0: never a violation).
  ContactGuardStage(ColliderSetPtr colliders, double max_depth);
  const char* name() const override { return "contact_guard"; }
  void run(cloth::StageContext& ctx) override;
  std::string violation() const override { return violation_; }
  double work_in() const override { return work_; }
  // deepest_mm: the deepest vertex inside a collider after any step so far (mm); steps.
  std::vector<std::pair<std::string, double>> counters() const override;
  void save_state(cloth::StateWriter& out) const override;
  void load_state(cloth::StateReader& in) override;

 private:
  ColliderSetPtr colliders_;
  double max_depth_;
  std::string violation_;                    // of the last step
  double work_ = 0.0;                        // J, since the start
  cloth::Vec3s last_impulse_, last_moment_;  // N s, N m s: each collider's reaction after the last step
  double deepest_ = 0.0;                     // m, over all steps
  long steps_ = 0;
};

}  // namespace loom::collision
