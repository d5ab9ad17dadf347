#pragma once
// The setup many engine tests are written for: symplectic Euler, one step per frame. The C++ API's default
// is the real-time tier's solver (Solver.h, SolverSettings); a test that checks a stage, a term or a pipeline
// rule with the simple explicit integrator names it through this helper.
#include "loom/cloth/Simulation.h"

namespace loom::test {

inline cloth::SimulationSetup symplectic_setup() {
  cloth::SimulationSetup s;
  s.solver.method = "symplectic_euler";
  s.substeps = 1;
  return s;
}

}  // namespace loom::test
