#pragma once
// The non-finite / explosion guard. Simulation saves the whole changing state at the start of every
// frame (StateArchive.h: every cloth's x, v, x_prev, solver and stage history). A frame whose end state is
// non-finite or exploding is rolled back to that snapshot and run again with twice the substeps, up to
// `max_halvings` times; if the last try fails too, the state stays at the last good frame and the frame is
// reported as failed with its cause (Simulation::failure()). The retries stop early when the next one
// would bring the frame's solver steps (all tries together) past kMaxStepsPerFrame. A run that never rolls
// back is bit-identical to a run without the guard (the snapshot only reads the state).
//
// "Exploding" at the end of a frame, with E_kin, E_el the kinetic and elastic energies (J), ΔE_pot the drop
// of gravitational energy over the frame and E_ref = Σ m (|g| L + ½ v_ref²) an energy scale of the scene
// (L: each cloth's rest bounding-box diagonal, m; v_ref = 10 m/s + the fastest of wind with gusts, initial
// velocity and pin paths):
//   E_kin(end) + E_el(end) > energy_growth · (E_kin(start) + E_el(start) + max(0, ΔE_pot) + E_ref)
// (no stored or supplied energy source can pay for that much motion and stretch in one frame), or a strain
// max(l/L - 1) above `max_strain`.
//
// Two more criteria, off by default (scene key `guard`):
//  - energy budget (`energy_bound` > 0): since the start, with E(t) = E_kin + E_el + E_pot(t) - E_pot(0),
//      E(t) > energy_bound · max(E_kin(0) + E_el(0), Σ m |g| L) + W(t)
//    is exploding; W(t) is an upper estimate of the work put in from outside: kinematic (pinned, attached)
//    vertices |f·v| Δt per frame (f: the cloth's forces on them at the frame end), wind |f_drag| (|v| +
//    |wind| (1 + gusts)) Δt per vertex and frame, plus each stage's Stage::work_in() (a moving collider's
//    push): the stability suite's invariant "energy never above 10x its start plus work done" as a guard;
//  - contacts (`max_penetration` > 0, m): a stage that checks contacts (collision::ContactGuardStage, added
//    by the scene builder) reports a cloth vertex deeper than this inside a collider after a step as a
//    violation (Stage::violation(): "could not resolve contacts: ..."); any stage's violation after any step
//    rejects the frame like an explosion;
//  - intersections (`intersections` true): collision::IntersectionGuardStage (added by the scene builder when
//    the scene has cloth-cloth or self-collision) finds the intersecting triangle pairs after every step
//    (exact, the census of `loom run --census`); a pair the step's start did not have is a violation
//    ("cloth intersections: N intersecting triangle pairs the step start did not have (cloth 'C': triangles
//    A and B)"). `loom run` turns it on for such scenes unless the scene sets it (RunCommand.cpp).
#include <string>

namespace loom::cloth {

// Solver steps one frame may take in all, the guard's retries included: a retry that would bring the
// frame past it is not run and the frame fails with that cause.
constexpr long kMaxStepsPerFrame = 1000000;

struct GuardSettings {
  bool enabled = true;
  int max_halvings = 5;          // retries of a failed frame, each with twice the substeps of the one before
  double max_strain = 10.0;      // 1, largest accepted l/L - 1 of a strain edge at a frame end
  double energy_growth = 100.0;  // 1, factor of the kinetic-energy bound above
  double energy_bound = 0.0;     // 1, factor of the energy budget since the start (0: off)
  double max_penetration = 0.0;  // m, deepest accepted cloth vertex inside a collider after a step (0: off)
  bool intersections = false;    // reject a step that leaves new intersecting triangle pairs (with collision)
  bool intersections_set = false;  // the scene gave `intersections` (a caller's default must not override it)
};

// The guard's view of a frame end (energies in J, strain in 1).
struct GuardSample {
  bool finite = true;
  double kinetic = 0.0, potential = 0.0, elastic = 0.0, max_strain = 0.0;
};

// Why the frame from `start` to `end` is rejected, or "" if it is accepted. `energy_scale`: E_ref (J).
std::string guard_violation(const GuardSettings& g, const GuardSample& start, const GuardSample& end,
                            double energy_scale);

}  // namespace loom::cloth
