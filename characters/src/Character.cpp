#include "loom/characters/Character.h"

#include <algorithm>

namespace loom::characters {

void Character::add_garment(cloth::SimulationSetup& setup, const Garment& garment, const std::string& name,
                            const cloth::Material& material, const std::string& model) {
  std::vector<Transform> pose0;
  motion.pose(0.0, pose0);
  cloth::ClothSetup cs;
  cs.name = name;
  cs.mesh = garment.mesh;
  cs.material = material;
  cs.model = model;
  const int cloth = static_cast<int>(setup.cloths.size());
  for (size_t k = 0; k < garment.attached_vertices.size(); ++k) {
    Attachment a;
    a.cloth = cloth;
    a.vertex = garment.attached_vertices[k];
    a.joint = garment.attached_joints[k];
    const Vec3 x0 = garment.mesh->rest_positions()[a.vertex];
    a.local = pose0[a.joint].inverse() * x0;
    attachments.push_back(a);
    cloth::PinSpec pin;  // kinematic: inverse mass 0; the character stage drives it
    pin.vertex = a.vertex;
    cs.pins.push_back(pin);
  }
  setup.cloths.push_back(std::move(cs));
}

CharacterStage::CharacterStage(std::shared_ptr<const Character> character,
                               collision::ColliderSetPtr colliders, size_t first)
    : character_(std::move(character)), colliders_(std::move(colliders)), first_(first) {}

void CharacterStage::run(cloth::StageContext& ctx) {
  const Character& c = *character_;
  c.motion.pose(ctx.t, pose_a_);
  c.motion.pose(ctx.t + ctx.h, pose_b_);
  if (colliders_) {
    c.rig.capsule_poses(pose_a_, caps_a_);
    c.rig.capsule_poses(pose_b_, caps_b_);
    collision::ColliderSet& set = *colliders_;
    for (size_t k = 0; k < caps_a_.size(); ++k) {
      set[first_ + k].prev = caps_a_[k];
      set[first_ + k].curr = caps_b_[k];
    }
  }
  for (const Attachment& a : c.attachments) {
    cloth::ClothState& s = ctx.cloths[a.cloth]->state();
    s.v[a.vertex] = (c.target(a, pose_b_) - s.x[a.vertex]) / ctx.h;
  }
  updates_ += static_cast<long>(c.attachments.size());
}

std::vector<std::pair<std::string, double>> CharacterStage::counters() const {
  return {{"capsules", static_cast<double>(character_->rig.bones().size())},
          {"attachment_updates", static_cast<double>(updates_)}};
}

void add_character(cloth::Simulation& sim, std::shared_ptr<const Character> character,
                   const collision::ColliderSetPtr& colliders) {
  size_t first = 0;
  if (colliders) {
    first = colliders->size();
    std::vector<Transform> pose0;
    character->motion.pose(0.0, pose0);
    for (collision::Collider& c : character->rig.make_colliders(pose0)) {
      c.friction = character->friction;
      c.static_friction = std::max(c.static_friction, c.friction);
      c.thickness = character->thickness;
      colliders->push_back(std::move(c));
    }
  }
  sim.add_stage(std::make_unique<CharacterStage>(std::move(character), colliders, first),
                cloth::Simulation::Slot::before_solve);
}

}  // namespace loom::characters
