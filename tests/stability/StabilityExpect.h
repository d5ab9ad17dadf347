#pragma once
// Shared by the stability tables (test_stability.cpp, test_stability_collisions.cpp): the solvers every hard
// case runs, in the order of the kExpected columns, and what each row expects of a solver.
#include <string>
#include <vector>

namespace loom::test {

inline const std::vector<std::string> kStabilitySolvers = {
    "explicit_euler", "symplectic_euler", "verlet", "implicit_euler", "bdf2", "pbd",
    "xpbd",           "projective",       "desbrun"};

// kSurvive: every invariant after every step/frame. kFailCleanly: stops with a clean, named failure (the
// guard's cause, the frames handed out before are finite, nothing non-finite written). There is no third
// kind: a row that breaks an invariant the guard does not check is a defect, not an expectation.
enum class Expect { kSurvive, kFailCleanly };
constexpr Expect S = Expect::kSurvive, F = Expect::kFailCleanly;

}  // namespace loom::test
