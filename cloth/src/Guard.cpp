#include "loom/cloth/Guard.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace loom::cloth {

std::string guard_violation(const GuardSettings& g, const GuardSample& start, const GuardSample& end,
                            double energy_scale) {
  std::ostringstream why;
  if (!end.finite || !std::isfinite(end.kinetic) || !std::isfinite(end.elastic) ||
      !std::isfinite(end.potential) || !std::isfinite(end.max_strain)) {
    why << "the state became non-finite (a position, velocity or energy is not a finite number)";
    return why.str();
  }
  // Guard.h: no energy source of the scene can pay for this much kinetic energy in one frame.
  const double budget = std::max(0.0, start.kinetic) + std::max(0.0, start.elastic) +
                        std::max(0.0, start.potential - end.potential) + energy_scale;
  const double e_end = end.kinetic + std::max(0.0, end.elastic);
  if (e_end > g.energy_growth * budget) {
    why << "the energy exploded (kinetic + elastic " << e_end << " J at the frame end, from "
        << start.kinetic + std::max(0.0, start.elastic) << " J; bound " << g.energy_growth * budget
        << " J, guard.energy_growth " << g.energy_growth << ")";
    return why.str();
  }
  if (end.max_strain > g.max_strain) {
    why << "the strain exploded (max l/L - 1 = " << end.max_strain << ", limit guard.max_strain "
        << g.max_strain << ")";
    return why.str();
  }
  return "";
}

}  // namespace loom::cloth
