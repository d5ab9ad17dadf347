#include "loom/scene/Build.h"

#include <string>

#include "loom/cloth/Error.h"
#include "loom/collision/BodyCollisionStage.h"
#include "loom/collision/ContactGuardStage.h"
#include "loom/collision/IntersectionGuardStage.h"
#include "loom/collision/MultiClothCensus.h"
#include "loom/collision/RealtimeBodyContact.h"
#include "loom/collision/RealtimeSelfCollision.h"

#ifdef LOOM_HAVE_CHARACTERS
#include "loom/characters/Character.h"
#endif

namespace loom::scene {

std::unique_ptr<cloth::Simulation> build_simulation(const Scene& scene,
                                                    collision::ColliderSetPtr* colliders_out) {
  auto sim = std::make_unique<cloth::Simulation>(scene.setup, scene.file);
  // The one collider set of this simulation: the scene's colliders and a character rig's capsules go in
  // here; the stages that read or move them share it, and the caller (renderer, viewer) draws it.
  const auto colliders = std::make_shared<collision::ColliderSet>(scene.colliders);
#ifdef LOOM_HAVE_CHARACTERS
  // Character: its capsules join the set, its stage moves them and the attached garment vertices.
  if (scene.character) characters::add_character(*sim, scene.character, colliders);
#endif
  // Effects from other modules add their stages here, each only when the scene names it.
  // Body collision: only when there is something to collide with (scene colliders, rig capsules).
  const bool cloth_collision = scene.collision && (scene.collision->self || scene.setup.cloths.size() > 1);
  // Every self- and cloth-cloth stage tests the pairs of triangles that lie close: cloths that start piled
  // onto each other would have them test every pair at every step (minutes per frame), so they are refused.
  if (cloth_collision) {
    std::vector<collision::CensusInput> in;
    for (const auto& c : sim->cloths()) in.push_back({&c->mesh(), &c->state().x});
    if (const auto piled = collision::piled_cloths(in, scene.collision->self, scene.setup.threads)) {
      const auto& c = sim->cloths();
      const std::string a = "'" + c[piled->cloth_a]->name() + "'", b = "'" + c[piled->cloth_b]->name() + "'";
      throw Error(scene.file, "collision",
                  (piled->cloth_a == piled->cloth_b ? "the triangles of cloth " + a
                                                    : "the triangles of cloths " + a + " and " + b) +
                      " start piled onto each other: more than " + std::to_string(piled->bound) +
                      " pairs of triangles overlap (a triangle soup, or a mesh scaled to a point); self- and "
                      "cloth-cloth collision would test every pair at every step");
    }
  }
  // Cloth-cloth by proximity (the realtime and balanced tiers) runs before body contact, so the body stage
  // has the last word at each step's end: no vertex is left inside a collider by a cloth-cloth push.
  if (cloth_collision && scene.proximity)
    sim->add_stage(std::make_unique<collision::RealtimeSelfCollisionStage>(*scene.proximity));
  collision::BodyCollisionStage* body_stage = nullptr;
  if (!colliders->empty() && scene.realtime_contact) {
    auto contact = std::make_unique<collision::RealtimeBodyContactStage>(colliders);
    const collision::RealtimeBodyContactStage* first = contact.get();
    sim->add_stage(std::move(contact));
    // The tier's strain limiting after contact, then contact again (positions only) on the vertices the
    // strain limiting moved: strain limiting has the last word on the stretch a contact caused, body
    // contact on penetration. The final pass's own strain-limit rounds (RealtimeContactSettings::
    // strain_limit) are not used here: they move vertices after the proximity cloth-cloth stage, and the
    // census of the character scenes finds crossed triangle pairs.
    if (scene.strain_limit_after_contact) {
      sim->add_stage(std::make_unique<cloth::StrainLimitStage>(*scene.strain_limit_after_contact));
      collision::RealtimeContactSettings last;
      last.positions_only = true;
      auto final_contact = std::make_unique<collision::RealtimeBodyContactStage>(colliders, last);
      final_contact->set_earlier(first);
      sim->add_stage(std::move(final_contact));
    }
  } else if (!colliders->empty()) {
    collision::BodyCollisionSettings body;
    if (scene.collision)
      body.friction_pairs = scene.collision->friction_pairs;     // the (cloth, collider) entries
    body.contact_normals = scene.setup.solver.holds_contacts();  // only a solver that reads them
    auto stage = std::make_unique<collision::BodyCollisionStage>(colliders, body);
    body_stage = stage.get();
    sim->add_stage(std::move(stage), cloth::Simulation::Slot::after_solve);
  }
  // Self- and cloth-cloth collision, after body collision: only with a `collision` object that asks
  // for self-collision or has more than one cloth to collide. It sees which vertices the body stage left near
  // a collider (those count heavier in cloth-cloth responses).
  if (cloth_collision && !scene.proximity) {
    auto stage = std::make_unique<collision::SelfCollisionStage>(*scene.collision);
    stage->set_body_stage(body_stage);
    sim->add_stage(std::move(stage));
  }
  if (scene.strain_limit_after_contact && !(!colliders->empty() && scene.realtime_contact)) {
    sim->add_stage(std::make_unique<cloth::StrainLimitStage>(*scene.strain_limit_after_contact));
    // The strain limit pulls a vertex toward its neighbours, and next to a collider that moves into the
    // cloth that is into the collider: body contact (positions only, at the colliders' poses at the step's
    // end) has the last word on penetration, as in the realtime tier.
    if (!colliders->empty()) {
      collision::RealtimeContactSettings last;
      last.positions_only = true;
      sim->add_stage(std::make_unique<collision::RealtimeBodyContactStage>(colliders, last));
    }
  }
  // The guard's contact check and the colliders' work (Guard.h), last: only when the scene's `guard`
  // asks for a penetration limit or an energy budget and there are colliders.
  const cloth::GuardSettings& guard = scene.setup.guard;
  if (!colliders->empty() && guard.enabled && (guard.max_penetration > 0.0 || guard.energy_bound > 0.0))
    sim->add_stage(std::make_unique<collision::ContactGuardStage>(colliders, guard.max_penetration));
  // The guard's intersection check, very last: with `guard.intersections` and cloth collision on
  // (without it nothing keeps the cloths apart). The pairs of the start state are allowed in the first step.
  if (cloth_collision && guard.enabled && guard.intersections) {
    auto stage = std::make_unique<collision::IntersectionGuardStage>();
    stage->prime(sim->cloths(), scene.setup.threads);
    sim->add_stage(std::move(stage));
  }
  if (colliders_out) *colliders_out = colliders;
  return sim;
}

}  // namespace loom::scene
