// fast_xpbd's float coordinates (FastXpbdSolver.h): the motion of a cloth does not depend on where in the
// world it is, and, with a frame that turns with it (Solver::set_frame), on which way it faces.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "TestUtil.h"
#include "loom/cloth/GravityTerm.h"
#include "loom/cloth/Model.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

// 10 km along a skew direction: double keeps 2e-12 m there, float in world coordinates would keep 1 mm.
const Vec3 kFar(8000.0, -3000.0, 5196.15);
constexpr int kNodes = 13;

// A 1 m curtain of cotton with a coat's bending (1e-4 N m) and damping (0.05 s), so that its swing is not
// chaotic over a second and runs can be compared vertex by vertex.
Material curtain_material() {
  Material m = material_preset("cotton");
  m.areal_density = 0.2;
  m.bend_weft = m.bend_warp = 1e-4;
  m.damping = 0.05;
  return m;
}

// The same random push (m/s) for every run: vertex i's velocity in the curtain's own axes.
Vec3s pushes(int n) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  Vec3s v(n);
  for (Vec3& p : v) p = Vec3(u(rng), u(rng), u(rng));
  return v;
}

double worst_difference(const std::vector<Vec3s>& a, const std::vector<Vec3s>& b) {
  double worst = 0.0;
  for (size_t f = 0; f < a.size(); ++f)
    for (size_t i = 0; i < a[f].size(); ++i) worst = std::max(worst, (a[f][i] - b[f][i]).norm());
  return worst;
}

// The largest distance of any vertex from its place in the first frame: how far the curtain swung.
double swing_extent(const std::vector<Vec3s>& run) {
  return worst_difference(run, std::vector<Vec3s>(run.size(), run.front()));
}

// The curtain in the xy plane from y = 0 to 1, moved by `offset`, its top row pinned, pushed and swung for
// 1 s (60 frames of 16 fast_xpbd steps) through Simulation. Returns the positions at every frame end, minus
// `offset`.
std::vector<Vec3s> curtain_in_a_simulation(const Vec3& offset) {
  SimulationSetup s;
  ClothSetup c;
  GridSpec g;
  g.nodes_u = g.nodes_v = kNodes;
  g.plane = GridPlane::kXY;
  g.origin = Vec3(-0.5, 0.0, 0.0) + offset;
  c.mesh = ClothMesh::grid(g);
  c.material = curtain_material();
  for (int i = 0; i < kNodes; ++i) c.pins.push_back(PinSpec{c.mesh->grid_index(i, kNodes - 1), {}, {}, {}});
  s.cloths.push_back(c);
  s.solver.method = "fast_xpbd";
  s.substeps = 16;
  Simulation sim(s);
  ClothState& st = sim.cloths()[0]->state();
  const Vec3s v = pushes(st.size());
  for (int i = 0; i < st.size(); ++i)
    if (st.inv_mass[i] > 0.0) st.v[i] = v[i];
  std::vector<Vec3s> out;
  for (int f = 0; f < 60; ++f) {
    EXPECT_TRUE(sim.step_frame().finite);
    Vec3s x = st.x;
    for (Vec3& p : x) p -= offset;
    out.push_back(x);
  }
  return out;
}

// The same curtain built placed by `place` (gravity turned with it, from_triangles with the grid's texture
// coordinates, so springs and fabric axes are the same in every placement), stepped by fast_xpbd directly
// (960 steps of 1/960 s), with set_frame(place) when `framed`. Returns place⁻¹ x every 16 steps.
std::vector<Vec3s> placed_curtain(const Eigen::Isometry3d& place, bool framed) {
  GridSpec g;
  g.nodes_u = g.nodes_v = kNodes;
  g.plane = GridPlane::kXY;
  g.origin = Vec3(-0.5, 0.0, 0.0);
  const auto grid = ClothMesh::grid(g);
  std::vector<std::array<Vec2, 3>> uvs;
  for (const Tri& t : grid->triangles()) {
    std::array<Vec2, 3> uv;
    for (int k = 0; k < 3; ++k) uv[k] = grid->rest_positions()[t[k]].head<2>();
    uvs.push_back(uv);
  }
  Vec3s rest = grid->rest_positions();
  for (Vec3& p : rest) p = place * p;
  Cloth cloth("curtain", ClothMesh::from_triangles(rest, grid->triangles(), uvs, "curtain"),
              curtain_material());
  cloth.add_term(std::make_unique<GravityTerm>(cloth.state().mass, place.linear() * Vec3(0.0, -9.81, 0.0)));
  add_model_terms(cloth, "springs", "curtain", "model");
  ClothState& st = cloth.state();
  const Vec3s v = pushes(st.size());
  for (int i = 0; i < st.size(); ++i) st.v[i] = place.linear() * v[i];
  for (int i = 0; i < kNodes; ++i) {
    st.inv_mass[grid->grid_index(i, kNodes - 1)] = 0.0;
    st.v[grid->grid_index(i, kNodes - 1)] = Vec3::Zero();
  }
  SolverSettings settings;
  settings.method = "fast_xpbd";
  auto solver = make_solver(settings);
  solver->check(cloth);
  if (framed) solver->set_frame(place);
  std::vector<Vec3s> out;
  const double h = 1.0 / 960.0;
  for (int k = 0; k < 960; ++k) {
    solver->step(cloth, k * h, h, 1);
    if (k % 16 != 15) continue;
    Vec3s x = st.x;
    for (Vec3& p : x) p = place.inverse() * p;
    out.push_back(x);
  }
  return out;
}

}  // namespace

// Float rounding is relative to the cloth (about 1e-7 of its size per step) and a swing amplifies it: two
// runs that round differently, wherever they are, part by up to about 1e-4 m over the second. Float in world
// coordinates would round at 1 mm 10 km away.
TEST(FastXpbdFrame, TheSameClothTenKilometresAwayMovesTheSame) {
  const std::vector<Vec3s> here = curtain_in_a_simulation(Vec3::Zero());
  const std::vector<Vec3s> far = curtain_in_a_simulation(kFar);
  EXPECT_GT(swing_extent(here), 0.01);  // it swung: agreement is not that of a curtain at rest
  const double worst = worst_difference(here, far);
  EXPECT_LT(worst, 2e-4);
  std::printf("fast_xpbd at the origin vs 10 km away: worst vertex distance %.3g m over 1 s (swing %.3g m)\n",
              worst, swing_extent(here));
}

TEST(FastXpbdFrame, ATurnedClothWithItsFrameMovesTheSame) {
  Eigen::Isometry3d place = Eigen::Isometry3d::Identity();
  place.translation() = kFar;
  place.linear() = Eigen::AngleAxisd(2.1, Vec3(0.3, -0.8, 0.5).normalized()).toRotationMatrix();
  const std::vector<Vec3s> here = placed_curtain(Eigen::Isometry3d::Identity(), true);
  EXPECT_GT(swing_extent(here), 0.01);
  const double framed = worst_difference(here, placed_curtain(place, true));
  EXPECT_LT(framed, 2e-4);
  const double unframed = worst_difference(here, placed_curtain(place, false));
  std::printf(
      "fast_xpbd turned and 10 km away: worst vertex distance %.3g m with its frame, %.3g m without\n",
      framed, unframed);
}

}  // namespace loom::cloth
