// The resolution-independent mapping: the hanging cloth's settled sag changes by < 2% between N = 17
// and N = 33 with the same material.
#include <gtest/gtest.h>

#include "TestUtil.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

// Height of the pins above the cloth's centre of mass once it has settled.
double settled_sag(int n) {
  SimulationSetup s = test::hanging_sheet(n);               // pins at y = 1 m
  s.drag = DragSettings{1.0, 0.0, Vec3::Zero(), 0.0, 0.0};  // settles it; per area, so resolution-free
  s.substeps = n <= 17 ? 50 : 100;
  s.threads = 1;
  Simulation sim(s);
  for (int f = 0; f < 360; ++f) sim.step_frame();
  const ClothState& st = sim.cloths()[0]->state();
  double m = 0.0, my = 0.0;
  for (int i = 0; i < st.size(); ++i) {
    m += st.mass[i];
    my += st.mass[i] * st.x[i].y();
  }
  EXPECT_LT(sim.measure().kinetic, 1e-3) << "N = " << n << " has not settled";
  return 1.0 - my / m;
}

TEST(Refinement, HangingClothSagIsResolutionIndependent) {
  const double coarse = settled_sag(17), fine = settled_sag(33);
  EXPECT_GT(coarse, 0.3);
  EXPECT_LT(std::abs(coarse - fine) / fine, 0.02) << "sag N=17: " << coarse << " m, N=33: " << fine << " m";
}

}  // namespace
}  // namespace loom::cloth
