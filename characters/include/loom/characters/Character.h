#pragma once
// Character: a Motion, its CapsuleRig and the garment vertices attached to its bones, plus the pipeline
// stage that moves them (docs/architecture.md, "One step"). The stage runs before the solver ("character",
// Simulation::Slot::before_solve) at every substep [t, t + h]:
//   - each capsule collider gets prev = its pose at t and curr = its pose at t + h (swept contacts);
//   - each attached vertex (a pin: inverse mass 0) gets v = (target(t + h) - x) / h, so the solver's
//     x += h v puts it exactly on its bone target (the pin contract of Solver.h), the target being the bone
//     at t + h sampled from the animation (slerp/lerp between keys): targets are interpolated across
//     substeps.
#include <memory>
#include <string>
#include <vector>

#include "loom/characters/CapsuleRig.h"
#include "loom/characters/Garments.h"
#include "loom/characters/Motion.h"
#include "loom/cloth/Simulation.h"
#include "loom/collision/Collider.h"

namespace loom::characters {

struct Attachment {
  int cloth = 0;  // index into the simulation's cloths
  int vertex = 0;
  int joint = 0;
  Vec3 local = Vec3::Zero();  // m, the vertex in the joint's frame at t = 0
};

struct Character {
  Motion motion;
  CapsuleRig rig;
  std::vector<Attachment> attachments;
  double friction = 0.3;   // 1, capsule-cloth kinetic friction (Collider::friction)
  double thickness = 0.0;  // m, contact offset of the capsules (0: the body-collision stage's default)

  Vec3 target(const Attachment& a, const std::vector<Transform>& pose) const {
    return pose[a.joint] * a.local;
  }
  // Appends a garment as a cloth of `setup` (its attached vertices become pins) and records its attachments.
  void add_garment(cloth::SimulationSetup& setup, const Garment& garment, const std::string& name,
                   const cloth::Material& material, const std::string& model = "springs");
};

class CharacterStage final : public cloth::Stage {
 public:
  // Moves colliders[first, first + rig.bones().size()) of `colliders` (may be null: no capsules written).
  CharacterStage(std::shared_ptr<const Character> character, collision::ColliderSetPtr colliders,
                 size_t first);
  const char* name() const override { return "character"; }
  void run(cloth::StageContext& ctx) override;
  std::vector<std::pair<std::string, double>> counters() const override;

 private:
  std::shared_ptr<const Character> character_;
  collision::ColliderSetPtr colliders_;
  size_t first_ = 0;
  std::vector<Transform> pose_a_, pose_b_, caps_a_, caps_b_;  // scratch
  long updates_ = 0;
};

// Appends the rig's capsules to `colliders` (when not null) and adds the character stage (before_solve).
void add_character(cloth::Simulation& sim, std::shared_ptr<const Character> character,
                   const collision::ColliderSetPtr& colliders);

}  // namespace loom::characters
