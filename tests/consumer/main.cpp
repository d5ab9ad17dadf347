// Uses only installed headers and loom::cloth: a pinned 9x9 sheet falls for 10 frames; prints the lowest
// vertex height and exits 0 when the free corner moved down and the pinned corner stayed put.
#include <cmath>
#include <cstdio>

#include "loom/cloth/Simulation.h"

int main() {
  using namespace loom::cloth;
  SimulationSetup setup;
  ClothSetup c;
  GridSpec g;
  g.nodes_u = g.nodes_v = 9;
  g.origin = Vec3(0.0, 1.0, 0.0);
  c.mesh = ClothMesh::grid(g);
  c.material = material_preset("cotton");
  c.pins = {PinSpec{0, {}, {}, {}}};
  setup.cloths.push_back(c);  // the API's default solver and steps: the real-time tier's (Solver.h)
  Simulation sim(setup);
  for (int f = 0; f < 10; ++f) sim.step_frame();
  const Vec3s& x = sim.cloths()[0]->state().x;
  double lowest = x[0].y();
  for (const Vec3& p : x) lowest = std::min(lowest, p.y());
  std::printf("consumer: %zu vertices, pinned corner y = %.6f, lowest y = %.6f\n", x.size(), x[0].y(),
              lowest);
  const bool ok = std::abs(x[0].y() - 1.0) < 1e-12 && x.back().y() < 0.99;
  return ok ? 0 : 1;
}
