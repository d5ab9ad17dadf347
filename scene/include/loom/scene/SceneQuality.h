#pragma once
// Scene key `quality`: one word that picks the solver, its substeps, the collision stages and the checks
// together (docs/scene-format.md, "Quality"). Any explicit scene value still wins: a `solver.method`,
// `solver.substeps`, `constraints.*`, `collision.method` or `body_contact` given in the scene replaces the
// tier's choice for that item only.
//   "reference" (the default when the key is absent): the scene's own settings, nothing added; implicit or
//       other solvers as named, exact continuous body collision (BodyCollisionStage), exact cloth-cloth
//       collision with impact zones (SelfCollisionStage), guard checks as the scene asks.
//       Guarantees: no false negatives in the continuous tests, the census and guard where asked.
//   "balanced": fast_xpbd at 32 substeps with 1 iteration, tethers, the exact continuous body collision
//       (BodyCollisionStage), cloth-cloth by proximity at every substep, strain limiting to 10 % last.
//       Gives up: implicit accuracy, exact cloth-cloth CCD and impact zones.
//   "realtime": fast_xpbd at 12 substeps with 1 iteration (Macklin et al. 2019), tethers, cloth-cloth by
//       proximity on a spatial hash every 2nd substep (RealtimeSelfCollisionStage), discrete per-substep body
//       contact with culling and swept tests only where a motion could pass a collider's middle
//       (RealtimeBodyContactStage), strain limiting to 10 % after contact, then contact again on positions
//       (the vertices the strain limiting moved).
//       Guarantees: no vertex inside a collider at a step's end (save pinches between colliders, counted).
//       Gives up: stiffness beyond what 12 sweeps reach, cloth-cloth crossings faster than the proximity per
//       2 substeps and edge-edge crossings, cloth edges against colliders thinner than the vertex spacing.
// In a Bullet world (a scene with `bodies`) the tier picks how the bridge runs the cloths (WorldTier):
//   "reference": BulletClothSettings::Tier::setup with the scene's own solver, substeps and strain limit;
//       the bodies are kinematic inside each cloth step and take the reaction impulse after it.
//   "realtime": the coupled tier (BulletClothSettings::Tier::realtime): cloth and the dynamic bodies near it
//       in small XPBD steps (2 per Bullet substep, 2 contact/tether/edge sweeps each), edges held to 10 %,
//       tethers to the pins. Guarantees: the bridge's contact invariants (no body centre meets the cloth).
//   "balanced": the coupled tier at twice the steps and sweeps (4 and 4): less strain, twice the time.
// Explicit values that apply there: solver.method when it is pbd, xpbd or fast_xpbd (any other solver runs
// the setup tier with it), solver.iterations, solver.substeps or dt (cloth steps per frame),
// constraints.strain_limit.max_stretch, constraints.tethers.slack; other keys of those objects are
// refused, the tier's own tether passes and contact stages are not added.
#include <optional>
#include <string>

#include "loom/scene/JsonReader.h"

namespace loom::scene {

struct QualityTier {
  std::string name = "reference";
  // Solver (empty method: the scene's own or Loom's default).
  std::string method;
  int iterations = 0;             // solver.iterations for `method` (0: its default)
  int substeps = 0;               // 0: the scene's own
  bool strain_limit = false;      // strain limiting {max_stretch 0.1} after the collision stages, unless the
                                  // scene names constraints.strain_limit
  bool tethers = false;           // add constraints.tethers {slack 0.1} unless the scene gives one
  bool realtime_contact = false;  // body contact by RealtimeBodyContactStage instead of BodyCollisionStage
  bool realtime_self = false;     // cloth-cloth by RealtimeSelfCollisionStage instead of SelfCollisionStage
  int self_every = 1;             // the realtime cloth-cloth stage runs every k-th substep
};

// How the cloths of a scene with `bodies` run in the Bullet world (bullet::BulletSceneOptions); zero or
// empty fields are the bridge's defaults.
struct WorldTier {
  bool coupled = false;          // BulletClothSettings::Tier::realtime, else Tier::setup
  std::string solver;            // coupled: pbd, xpbd or fast_xpbd
  int iterations = 0;            // coupled: solver iterations per cloth step
  int substeps = 0;              // coupled: cloth steps per scene frame (spread over the Bullet substeps)
  int coupling_iterations = 0;   // coupled: contact, tether and edge sweeps per cloth step
  double max_stretch = 0.0;      // 1, coupled: edge strain limit
  double tether_stretch = -1.0;  // 1, coupled: tether slack (< 0: the bridge's)
};

// The world tier of a quality tier before the scene's explicit values.
WorldTier world_tier(const std::string& quality);

// The tier named by the scene's `quality` ("reference" when absent); an unknown name fails naming `quality`.
QualityTier parse_quality(const JsonReader& root);
// The tier by name, or nullopt.
std::optional<QualityTier> quality_tier(const std::string& name);

}  // namespace loom::scene
