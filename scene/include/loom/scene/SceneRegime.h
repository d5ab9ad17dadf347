#pragma once
// Why a scene's run may have stopped on divergence (the guard, a non-finite state): the scene's values that
// lie outside the regime Loom is validated in, each named by its JSON field with its figure. Every value
// here is legal on its own (SceneLimits.h bounds what can be read at all); together they can ask for more
// than a frame's steps can carry, and the guard then stops the run. The report turns "the strain exploded"
// into "gravity is 1766 g".

#include <string>
#include <vector>

#include "loom/scene/Scene.h"

namespace loom::scene {

// The bounds of the validated regime (docs/validation.md: the bundled scenes and the stability suite stay
// well inside them).
constexpr double kRegimeAcceleration = 98.1;     // m/s^2, 10 g: gravity
constexpr double kRegimeWindAcceleration = 1e4;  // m/s^2: a wind's push on a light cloth (a flag: ~760)
constexpr double kRegimeWaveSpeed = 1e4;         // m/s, stretch waves sqrt(E / rho): above steel's 5e3
constexpr double kRegimeSpeed = 100.0;           // m/s, initial cloth and body speeds
constexpr double kRegimeCourant = 1.0;           // 1, c h / l_min for the explicit solvers (CFL number)
constexpr double kRegimeDampingSteps = 1.0;      // 1, a damping's relaxation per step (drag, material)
constexpr double kRegimeDamping = 1.0;           // s, stiffness-proportional material damping
constexpr double kRegimePinReach = 0.25;         // 1, a pin's first target from its vertex, per cloth size
constexpr double kRegimeClipSpeed = 3.0;         // 1, clip seconds per second (the stability suite's 3x clip)

// "; the values outside the validated regime: gravity (|g| = 1.73e+04 m/s^2, more than 98.1), ..."; when no
// value is outside it, the fields that give the frame more steps (solver.substeps, guard.max_halvings).
// Never empty: a divergence message always names a field.
std::string divergence_suspects(const Scene& scene);
// The values outside the validated regime, each "field (figure; bound)"; empty inside it. step_bound: the
// value is per solver step (an explicit step's Courant number, a damping's relaxation per step), so the
// guard's retries with more substeps bring it back. A scene with an outlier that is not step-bound gets
// guard.max_halvings of at most kRegimeOutsideHalvings unless it sets the field (Scene.cpp): more substeps
// seldom carry such a frame, and each retry doubles its cost.
// start: a cloth that starts inside a collider or its thickness (a vertex, or a point of an edge a thin
// collider passes through), pushed out in the first step: `loom run` prints it as a warning in every tier.
struct RegimeOutlier {
  std::string text;
  bool step_bound = false;
  bool start = false;
};
std::vector<RegimeOutlier> regime_outliers(const Scene& scene);
constexpr int kRegimeOutsideHalvings = 1;

}  // namespace loom::scene
