// The Bullet twins (loom::bullet): the same cloth as Loom's in Bullet's classic soft-body world and in its
// deformable world — same masses and pins, finite short runs with fixed pins, falling under gravity.
#include <gtest/gtest.h>

#include <cmath>

#include "SymplecticSetup.h"
#include "loom/bullet/BulletTwin.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Material.h"
#include "loom/cloth/Simulation.h"

using namespace loom::cloth;
using loom::bullet::BulletTwin;
using loom::bullet::TwinKind;

namespace {

// The benchmark's hanging cloth: 1 m of cotton, 0.2 kg, horizontal, pinned at the corners of one edge.
std::unique_ptr<Simulation> hanging_cloth(int n, bool pinned = true) {
  SimulationSetup s = loom::test::symplectic_setup();
  ClothSetup c;
  GridSpec g;
  g.nodes_u = g.nodes_v = n;
  g.origin = Vec3(-0.5, 1.5, -0.5);
  c.mesh = ClothMesh::grid(g);
  c.material = material_preset("cotton");
  c.material.areal_density = 0.2 / c.mesh->total_area();
  if (pinned)
    c.pins = {PinSpec{c.mesh->grid_index(0, 0), {}, {}, {}},
              PinSpec{c.mesh->grid_index(n - 1, 0), {}, {}, {}}};
  s.cloths = {c};
  return std::make_unique<Simulation>(s);
}

const TwinKind kKinds[] = {TwinKind::kClassic, TwinKind::kDeformable};

}  // namespace

TEST(BulletTwin, SameMassesLinksAndPinsAsLoom) {
  auto sim = hanging_cloth(9);
  const Cloth& cloth = *sim->cloths()[0];
  for (TwinKind kind : kKinds) {
    SCOPED_TRACE(loom::bullet::system_name(kind));
    BulletTwin twin(kind, loom::bullet::make_twin_cloth(cloth, sim->setup().gravity), {});
    ASSERT_EQ(twin.num_nodes(), cloth.mesh().num_vertices());
    EXPECT_EQ(twin.num_links(), static_cast<int>(cloth.mesh().springs().size()));
    double loom_total = 0.0, bullet_free = 0.0, pinned_mass = 0.0;
    int pinned = 0;
    for (int i = 0; i < twin.num_nodes(); ++i) {
      const double m = cloth.state().mass[i];
      loom_total += m;
      if (cloth.state().inv_mass[i] == 0.0) {
        EXPECT_TRUE(twin.is_pinned(i)) << i;
        pinned_mass += m;
        ++pinned;
      } else {
        EXPECT_FALSE(twin.is_pinned(i)) << i;
        EXPECT_NEAR(twin.node_mass(i), m, 1e-6 * m) << i;  // float build of Bullet
        bullet_free += twin.node_mass(i);
      }
    }
    EXPECT_EQ(pinned, 2);
    EXPECT_NEAR(loom_total, 0.2, 1e-12);
    EXPECT_NEAR(bullet_free + pinned_mass, loom_total, 1e-6 * loom_total);
  }
}

TEST(BulletTwin, ShortRunStaysFiniteWithPinsInPlace) {
  auto sim = hanging_cloth(9);
  const Cloth& cloth = *sim->cloths()[0];
  const auto tc = loom::bullet::make_twin_cloth(cloth, sim->setup().gravity);
  for (TwinKind kind : kKinds) {
    SCOPED_TRACE(loom::bullet::system_name(kind));
    BulletTwin twin(kind, tc, {});  // defaults: 4 substeps (1/240 s), 10 iterations / 1 Newton iteration
    Vec3s x;
    for (int f = 0; f < 30; ++f) twin.step_frame();
    twin.positions(x);
    EXPECT_TRUE(twin.simulating());
    for (const Vec3& p : x) ASSERT_TRUE(p.allFinite());
    for (int p : tc.pinned) EXPECT_LT((x[p] - tc.start[p]).norm(), 1e-6) << p;
    // Structural strain stays small for a cloth of 2000 N/m under 0.2 kg.
    for (int k : cloth.mesh().strain_springs()) {
      const SpringDef& d = cloth.mesh().springs()[k];
      EXPECT_LT(std::abs((x[d.j] - x[d.i]).norm() / d.rest_length - 1.0), 0.1) << k;
    }
  }
}

TEST(BulletTwin, ClothFallsUnderGravity) {
  auto sim = hanging_cloth(9);
  const auto tc = loom::bullet::make_twin_cloth(*sim->cloths()[0], sim->setup().gravity);
  for (TwinKind kind : kKinds) {
    SCOPED_TRACE(loom::bullet::system_name(kind));
    BulletTwin twin(kind, tc, {});
    for (int f = 0; f < 15; ++f) twin.step_frame();  // 0.25 s
    Vec3s x;
    twin.positions(x);
    double drop = 0.0;
    for (size_t i = 0; i < x.size(); ++i) drop += tc.start[i].y() - x[i].y();
    drop /= x.size();
    // Pinned at one edge: the centroid falls, but less than free fall (g t²/2 = 0.307 m).
    EXPECT_GT(drop, 0.05);
    EXPECT_LT(drop, 0.307);
  }
}

// A free, unstretched sheet: both schemes update v += h g, then x += h v (symplectic / backward Euler with a
// constant force), so after n steps it has fallen exactly g h² n(n+1)/2.
TEST(BulletTwin, FreeSheetFallsAsTheSchemePredicts) {
  auto sim = hanging_cloth(5, false);
  const auto tc = loom::bullet::make_twin_cloth(*sim->cloths()[0], sim->setup().gravity);
  for (TwinKind kind : kKinds) {
    SCOPED_TRACE(loom::bullet::system_name(kind));
    loom::bullet::TwinSettings s;
    s.substeps = 1;
    BulletTwin twin(kind, tc, s);
    const int n = 10;
    for (int f = 0; f < n; ++f) twin.step_frame();
    Vec3s x;
    twin.positions(x);
    const double h = 1.0 / 60.0, expected = 9.81 * h * h * n * (n + 1) / 2.0;  // 0.1499 m
    for (size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(tc.start[i].y() - x[i].y(), expected, 1e-4) << i;
  }
}

TEST(BulletTwin, RejectsBadInput) {
  auto sim = hanging_cloth(5);
  auto tc = loom::bullet::make_twin_cloth(*sim->cloths()[0], sim->setup().gravity);
  tc.pinned.push_back(25);
  EXPECT_THROW(BulletTwin(TwinKind::kClassic, tc, {}), loom::Error);
  tc.pinned.pop_back();
  loom::bullet::TwinSettings s;
  s.substeps = 0;
  EXPECT_THROW(BulletTwin(TwinKind::kDeformable, tc, s), loom::Error);
  s.substeps = 4;
  s.stiffness = 2.0;  // classic kLST must stay in (0, 1]
  EXPECT_THROW(BulletTwin(TwinKind::kClassic, tc, s), loom::Error);
}
