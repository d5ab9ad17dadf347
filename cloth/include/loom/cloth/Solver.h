#pragma once
// Solver: one time integrator behind one interface (DESIGN.md). Every solver consumes the cloth's terms
// only through Term; a solver that cannot use a term says so in check(), at set-up time.
// Contract for kinematic vertices (inverse mass 0): their velocity was set by the pin stage to reach the
// target at t + h, and the solver moves them by x += h v, whatever its scheme.
#include <memory>
#include <string>
#include <vector>

#include "loom/cloth/Cloth.h"

namespace loom::cloth {

struct SolverSettings {
  std::string method = "symplectic_euler";  // explicit_euler | symplectic_euler | verlet
};

class Solver {
 public:
  virtual ~Solver() = default;
  virtual const char* name() const = 0;
  // Throws loom::Error if the cloth has a term this solver cannot use.
  virtual void check(const Cloth& cloth) const { (void)cloth; }
  // Advances the cloth from t to t + h.
  virtual void step(Cloth& cloth, double t, double h, int threads) = 0;
  // Forget any history (multistep state); called when the step size or the state changes from outside.
  virtual void reset() {}
};

// Throws loom::Error(file, "solver.method", ...) for an unknown method.
std::unique_ptr<Solver> make_solver(const SolverSettings& settings, const std::string& file = "");
std::vector<std::string> solver_names();

}  // namespace loom::cloth
