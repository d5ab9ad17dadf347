#pragma once
// Helpers of the guard shared by Simulation.cpp and SimulationState.cpp; not installed.
#include "loom/cloth/Simulation.h"

namespace loom::cloth {

GuardSample guard_sample(const FrameStats& s);
// Σ m |g| L over the cloths (J; L: rest bounding-box diagonal), the weight scale of the energy budget.
double guard_weight_scale(const SimulationSetup& setup, const std::vector<std::unique_ptr<Cloth>>& cloths);
// E_ref of Guard.h (J).
double guard_energy_scale(const SimulationSetup& setup, const std::vector<std::unique_ptr<Cloth>>& cloths);

}  // namespace loom::cloth
