// RealtimeBodyContactStage (the real-time tier's body contact): no vertex ends a step inside a collider, a
// fast capsule does not tunnel through a sheet, friction holds and slides by Coulomb's law, the reaction on
// the collider is minus the cloth's momentum change, and the culling never drops a contact.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

#include "BodyContactTestUtil.h"
#include "SymplecticSetup.h"
#include "loom/cloth/Simulation.h"
#include "loom/cloth/StrainLimitStage.h"
#include "loom/collision/BodyCollisionStage.h"
#include "loom/collision/ColliderDistance.h"
#include "loom/collision/RealtimeBodyContact.h"

namespace loom::collision {
namespace {

using namespace loom::collision::test;
using cloth::Simulation;
using cloth::SimulationSetup;

// The real-time set-up: fast_xpbd, one iteration, `substeps` per 60 Hz frame.
SimulationSetup realtime(cloth::ClothSetup c, int substeps) {
  SimulationSetup s = loom::test::symplectic_setup();
  s.cloths.push_back(std::move(c));
  s.solver.method = "fast_xpbd";
  s.substeps = substeps;
  return s;
}

TEST(RealtimeContact, ASheetDrapedOverCapsulesAndASphereEndsEveryStepOutsideThem) {
  // A 1 m sheet dropped on two crossed capsules and a sphere: every free vertex ends every step at least the
  // thickness outside every collider (the postcondition; nothing is pinched between them here).
  SimulationSetup s = realtime(sheet(21, 1.0, cloth::GridPlane::kXZ, Vec3(-0.5, 0.6, -0.5)), 12);
  Simulation sim(s);
  auto set = std::make_shared<ColliderSet>();
  set->push_back(shape(ShapeType::capsule, 0.08, 0.3));
  set->back().prev = set->back().curr = at(Vec3(0, 0.3, 0), M_PI / 2);
  set->push_back(shape(ShapeType::capsule, 0.06, 0.3));
  set->back().prev = set->back().curr = at(Vec3(0, 0.25, 0.2), 0.3);
  set->push_back(shape(ShapeType::sphere, 0.15));
  set->back().prev = set->back().curr = at(Vec3(0.3, 0.2, -0.2));
  auto stage = std::make_unique<RealtimeBodyContactStage>(set);
  const RealtimeBodyContactStage* rt = stage.get();
  sim.add_stage(std::move(stage));
  const double thickness = sim.cloths()[0]->material().thickness;
  sim.add_stage(std::make_unique<CheckStage>([&](cloth::StageContext& ctx) {
    EXPECT_GT(worst_gap(ctx.cloths[0]->state(), *set, thickness), -1e-9) << "t=" << ctx.t;
  }));
  for (int f = 0; f < 60; ++f) ASSERT_TRUE(sim.step_frame().finite);
  double contacts = 0.0;
  for (const auto& kv : rt->counters())
    if (kv.first == "contacts") contacts = kv.second;
  EXPECT_GT(contacts, 1000.0);  // it draped
}

// 30 small spheres of radius 0.05-0.07 m along a diagonal under the sheets below; `home`: their centres.
std::shared_ptr<ColliderSet> sphere_field(std::vector<Vec3>* home = nullptr) {
  auto set = std::make_shared<ColliderSet>();
  for (int k = 0; k < 30; ++k) {
    const Vec3 c(-0.45 + 0.03 * k, 0.2 + 0.004 * k, -0.4 + 0.027 * k);
    set->push_back(shape(ShapeType::sphere, 0.05 + 0.01 * (k % 3)));
    set->back().prev = set->back().curr = at(c);
    if (home) home->push_back(c);
  }
  return set;
}

TEST(RealtimeContact, CullingDropsNoContact) {
  // 30 small spheres under a falling sheet: the culling (cloth box, collider grid, collider boxes) must not
  // drop a contact, so after every step every vertex is outside every sphere by the brute-force distance.
  SimulationSetup s = realtime(sheet(17, 1.0, cloth::GridPlane::kXZ, Vec3(-0.5, 0.4, -0.5)), 8);
  Simulation sim(s);
  const auto set = sphere_field();
  sim.add_stage(std::make_unique<RealtimeBodyContactStage>(set));
  const double thickness = sim.cloths()[0]->material().thickness;
  long steps = 0;
  sim.add_stage(std::make_unique<CheckStage>([&](cloth::StageContext& ctx) {
    ++steps;
    EXPECT_GT(worst_gap(ctx.cloths[0]->state(), *set, thickness), -1e-9) << "t=" << ctx.t;
  }));
  for (int f = 0; f < 30; ++f) ASSERT_TRUE(sim.step_frame().finite);
  EXPECT_EQ(steps, 30 * 8);
}

TEST(RealtimeContact, CullingDropsNoContactWhenCollidersJump) {
  // The stage keeps, per vertex, the colliders that may reach it over several steps (the collider masks);
  // colliders that jump between frames with no motion in their poses (prev = curr at the new place), by
  // more than any margin, must still be found: after every step every vertex is outside every sphere.
  SimulationSetup s = realtime(sheet(17, 1.0, cloth::GridPlane::kXZ, Vec3(-0.5, 0.4, -0.5)), 8);
  Simulation sim(s);
  std::vector<Vec3> home;
  const auto set = sphere_field(&home);
  auto stage = std::make_unique<RealtimeBodyContactStage>(set);
  const RealtimeBodyContactStage* rt = stage.get();
  sim.add_stage(std::move(stage));
  const double thickness = sim.cloths()[0]->material().thickness;
  sim.add_stage(std::make_unique<CheckStage>([&](cloth::StageContext& ctx) {
    EXPECT_GT(worst_gap(ctx.cloths[0]->state(), *set, thickness), -1e-9) << "t=" << ctx.t;
  }));
  auto contacts = [&] {
    for (const auto& kv : rt->counters())
      if (kv.first == "contacts") return kv.second;
    return 0.0;
  };
  for (int f = 0; f < 20; ++f) ASSERT_TRUE(sim.step_frame().finite);
  const double draped = contacts();
  EXPECT_GT(draped, 0.0);
  for (int f = 0; f < 20; ++f) {
    // Each sphere jumps 0.15 m along x and back up under the sheet, alternately.
    for (int k = 0; k < 30; ++k) {
      const Vec3 p = home[k] + Vec3(f % 2 == 0 ? 0.15 : -0.15, 0.05, 0.0);
      (*set)[k].prev = (*set)[k].curr = at(p);
    }
    ASSERT_TRUE(sim.step_frame().finite);
  }
  EXPECT_GT(contacts(), draped);  // the jumps met the sheet
}

// Largest l/L - 1 over the springs a strain limit acts on.
double max_stretch(const cloth::Cloth& c) {
  double m = -1.0;
  const auto& springs = c.mesh().springs();
  for (int k : cloth::limited_springs(c.mesh())) {
    const cloth::SpringDef& d = springs[k];
    m = std::max(m, (c.state().x[d.j] - c.state().x[d.i]).norm() / d.rest_length - 1.0);
  }
  return m;
}

// A flat sheet at rest length whose middle lies inside a sphere: the positions-only pass pushes those
// vertices out, which stretches the springs to their neighbours far past 10 %. With the strain limit's
// rounds the pushed vertices stay outside the sphere and their neighbours follow: run to convergence no
// spring ends above the limit; with the default budget (the projection has the last word) at most 0.1 %
// above it. The kinematic corners never move.
TEST(RealtimeContact, PositionsOnlyPassWithAStrainLimitLeavesNoSpringAboveIt) {
  enum Budget { kNone, kDefault, kConverged };
  for (const Budget budget : {kNone, kDefault, kConverged}) {
    SCOPED_TRACE(budget == kNone ? "without the limit" : budget == kDefault ? "default rounds" : "converged");
    cloth::ClothSetup c = sheet(21, 1.0, cloth::GridPlane::kXZ, Vec3(-0.5, 0.0, -0.5));
    for (int i : {0, 20, 420, 440}) c.pins.push_back({i, {}, {}, {}});
    SimulationSetup s = realtime(std::move(c), 1);
    Simulation sim(s);
    cloth::ClothState& st = sim.cloths()[0]->state();
    st.x_prev = st.x;
    const Vec3s corners = {st.x[0], st.x[20], st.x[420], st.x[440]};
    auto set = std::make_shared<ColliderSet>();
    set->push_back(shape(ShapeType::sphere, 0.2));
    set->back().prev = set->back().curr = at(Vec3(0.0, -0.15, 0.0));
    RealtimeContactSettings rs;
    rs.positions_only = true;
    if (budget != kNone) rs.strain_limit = cloth::StrainLimitSettings{0.1, 2};
    if (budget == kConverged) rs.rounds = 100, rs.sweeps = 200;
    RealtimeBodyContactStage stage(set, rs);
    ASSERT_LE(max_stretch(*sim.cloths()[0]), 1e-12);
    cloth::StageContext ctx{sim.cloths(), 0.0, 1.0 / 60.0, 1};
    stage.run(ctx);
    const double thickness = sim.cloths()[0]->material().thickness;
    EXPECT_GT(worst_gap(st, *set, thickness), -1e-9);
    if (budget == kNone) {
      EXPECT_GT(max_stretch(*sim.cloths()[0]), 0.2);
      continue;
    }
    EXPECT_LE(max_stretch(*sim.cloths()[0]), budget == kConverged ? 0.1 + 1e-9 : 0.101);
    const int pinned[4] = {0, 20, 420, 440};
    for (int k = 0; k < 4; ++k) EXPECT_EQ(st.x[pinned[k]], corners[k]);
  }
}

TEST(RealtimeContact, CapsuleAt20MetresPerSecondDoesNotTunnel) {
  // A capsule (radius 4 cm, wider than the 5 cm vertex spacing's gaps) shot at 20 m/s through a hanging
  // sheet at 12 substeps: it moves 2.8 cm per substep, most of its radius, so the swept test acts. The
  // sheet's middle is carried along, and no vertex ends a step inside the capsule.
  cloth::ClothSetup c = sheet(13, 0.6, cloth::GridPlane::kXY, Vec3(-0.3, 0.7, 0.0));
  for (int i = 0; i < 13; ++i) c.pins.push_back({c.mesh->grid_index(i, 12), {}, {}, {}});
  SimulationSetup s = realtime(c, 12);
  Simulation sim(s);
  auto set = std::make_shared<ColliderSet>(1, shape(ShapeType::capsule, 0.04, 0.15));
  const double speed = 20.0, z_start = -0.3;
  (*set)[0].motion = [&](double t) { return at(Vec3(0.01, 0.9, z_start + speed * t), M_PI / 2); };
  sim.add_stage(std::make_unique<RealtimeBodyContactStage>(set));
  double carried = 0.0;
  sim.add_stage(std::make_unique<CheckStage>([&](cloth::StageContext& ctx) {
    const auto& st = ctx.cloths[0]->state();
    carried = std::max(carried, st.x[6 * 13 + 6].z());
    EXPECT_GT(worst_gap(st, *set, 0.0), -1e-9) << "t=" << ctx.t;
  }));
  for (int f = 0; f < 3; ++f) ASSERT_TRUE(sim.step_frame().finite);
  EXPECT_GT(carried, 0.3);
}

TEST(RealtimeContact, ASheetThrownFasterThanASphereIsWideDoesNotPassThroughIt) {
  // A sheet thrown down onto a small sphere faster than the sphere is wide per substep (at 12 substeps, 30
  // m/s moves 4.2 cm past a 2 cm sphere, 60 m/s 8.3 cm past a 3 cm one: both ends of a vertex's path lie
  // outside the sphere's box): the vertices right above the sphere are caught on it, none passes below it.
  for (const auto& [speed, radius] : {std::pair<double, double>{30.0, 0.02}, {60.0, 0.03}}) {
    cloth::ClothSetup c = sheet(17, 1.0, cloth::GridPlane::kXZ, Vec3(-0.5, 0.5, -0.5));
    c.initial_velocity = Vec3(0, -speed, 0);
    SimulationSetup s = realtime(c, 12);
    Simulation sim(s);
    auto set = std::make_shared<ColliderSet>(1, shape(ShapeType::sphere, radius));
    (*set)[0].prev = (*set)[0].curr = at(Vec3(0, 0.2, 0));
    sim.add_stage(std::make_unique<RealtimeBodyContactStage>(set));
    ASSERT_TRUE(sim.step_frame().finite);
    const cloth::ClothState& st = sim.cloths()[0]->state();
    int caught = 0;
    for (int i = 0; i < st.size(); ++i) {
      const Vec3& p = st.x[i];
      if (std::hypot(p.x(), p.z()) < 0.5 * radius) {  // started right above the sphere's top
        EXPECT_GT(p.y(), 0.2) << "vertex " << i << " passed the sphere at " << speed << " m/s";
        ++caught;
      }
    }
    EXPECT_GT(caught, 0) << speed;
  }
}

TEST(RealtimeContact, FrictionSticksBelowStaticLimitAndSlidesAbove) {
  // A small sheet on the plane y = 0 under gravity tilted by theta: it stays (tan theta < mu_s = 0.4) or
  // slides (tan theta > mu_s), as Coulomb's law says.
  auto slide = [](double theta) {
    SimulationSetup s = realtime(sheet(3, 0.1, cloth::GridPlane::kXZ, Vec3(0, 0.002, 0)), 8);
    s.gravity = Vec3(9.81 * std::sin(theta), -9.81 * std::cos(theta), 0.0);
    Simulation sim(s);
    auto set = std::make_shared<ColliderSet>(1, shape(ShapeType::plane));
    (*set)[0].friction = 0.3, (*set)[0].static_friction = 0.4;
    sim.add_stage(std::make_unique<RealtimeBodyContactStage>(set));
    const double x0 = sim.cloths()[0]->state().x[0].x();
    for (int f = 0; f < 30; ++f) sim.step_frame();
    return sim.cloths()[0]->state().x[0].x() - x0;
  };
  EXPECT_LT(std::abs(slide(std::atan(0.3))), 1e-3);
  // Sliding at tan 0.6 with kinetic 0.3: a = g (sin - 0.3 cos) = 2.52 m/s², 0.5 s: about 0.31 m.
  EXPECT_GT(slide(std::atan(0.6)), 0.2);
}

TEST(RealtimeContact, ReactionIsMinusTheClothMomentumChange) {
  // A sheet falling onto a sphere: the sum of the reactions on the sphere is minus the momentum the contacts
  // gave the cloth, so it points down (the cloth is stopped from falling).
  SimulationSetup s = realtime(sheet(9, 0.3, cloth::GridPlane::kXZ, Vec3(-0.15, 0.25, -0.15)), 8);
  s.cloths[0].initial_velocity = Vec3(0, -1.0, 0);
  Simulation sim(s);
  auto set = std::make_shared<ColliderSet>(1, shape(ShapeType::sphere, 0.2));
  sim.add_stage(std::make_unique<RealtimeBodyContactStage>(set));
  for (int f = 0; f < 10; ++f) sim.step_frame();
  EXPECT_LT((*set)[0].reaction_impulse.y(), -1e-3);
  EXPECT_LT(std::abs((*set)[0].reaction_impulse.x()), 0.1 * std::abs((*set)[0].reaction_impulse.y()));
}

// A small body pressed down at 0.5 m/s onto the middle of one triangle of a coarse sheet (3 x 3 nodes,
// 0.3 m legs, pinned at its corners), 2 cm above it at first and 3 cm below its rest plane at the end of the
// motion: a 6 cm box corner-first or a capsule (2 cm radius, 12 cm long) end-first, kinematic (`motion`).
// Every cloth vertex stays far outside the body, so only the face step (the body's corner or axis against
// the triangle) keeps the cloth under it. Returns the lowest clearance (m) over all steps between the body's
// lowest point and the cloth's surface straight under it (negative: the point went through the cloth).
double pressed_clearance(ShapeType type, bool faces) {
  cloth::ClothSetup c = sheet(3, 0.6, cloth::GridPlane::kXZ, Vec3(-0.3, 0.0, -0.3));
  for (int i : {0, 2, 6, 8}) c.pins.push_back({i, {}, {}, {}});
  SimulationSetup s = realtime(std::move(c), 12);
  Simulation sim(s);
  const cloth::ClothMesh& mesh = sim.cloths()[0]->mesh();
  const cloth::Tri& t = mesh.triangles()[0];
  const Vec3 centroid =
      (mesh.rest_positions()[t[0]] + mesh.rest_positions()[t[1]] + mesh.rest_positions()[t[2]]) / 3.0;
  auto set = std::make_shared<ColliderSet>();
  Transform rest = Transform::Identity();
  Vec3 tip;  // the body's lowest point in its frame
  if (type == ShapeType::box) {
    set->push_back(shape(ShapeType::box, 0, 0, Vec3(0.03, 0.03, 0.03)));
    rest.linear() = Eigen::Quaterniond::FromTwoVectors(Vec3(1, 1, 1).normalized(), Vec3(0, -1, 0))
                        .toRotationMatrix();  // corner down
    tip = Vec3(0.03, 0.03, 0.03);
  } else {
    set->push_back(shape(ShapeType::capsule, 0.02, 0.04));
    tip = Vec3(0, -0.06, 0);
  }
  const double depth = -(rest.linear() * tip).y();
  const Vec3 start = centroid + Vec3(0, depth + 0.02, 0);
  set->back().motion = [rest, start](double time) {
    Transform p = rest;
    p.translation() = start - Vec3(0, 0.5 * std::min(time, 0.1), 0);
    return p;
  };
  set->back().prev = set->back().curr = set->back().motion(0.0);
  RealtimeContactSettings rs;
  rs.faces = faces;
  sim.add_stage(std::make_unique<RealtimeBodyContactStage>(set, rs));
  double lowest = HUGE_VAL;
  sim.add_stage(std::make_unique<CheckStage>([&](cloth::StageContext& ctx) {
    const cloth::ClothState& st = ctx.cloths[0]->state();
    const Vec3 p = set->back().curr * tip;
    // The cloth's height under p: the triangle whose xz projection holds p's.
    for (const cloth::Tri& tri : mesh.triangles()) {
      const Vec3 &a = st.x[tri[0]], &b = st.x[tri[1]], &c = st.x[tri[2]];
      auto cross2 = [](const Vec3& u, const Vec3& v) { return u.z() * v.x() - u.x() * v.z(); };
      const double area = cross2(b - a, c - a);
      if (std::abs(area) < 1e-12) continue;
      const double wb = cross2(p - a, c - a) / area, wc = cross2(b - a, p - a) / area, wa = 1.0 - wb - wc;
      if (wa < 0.0 || wb < 0.0 || wc < 0.0) continue;
      lowest = std::min(lowest, p.y() - (wa * a.y() + wb * b.y() + wc * c.y()));
      break;
    }
  }));
  for (int f = 0; f < 30; ++f) EXPECT_TRUE(sim.step_frame().finite);
  return lowest;
}

TEST(RealtimeContact, BoxCornerAndCapsuleEndPressedOnATriangleStayOverIt) {
  for (ShapeType type : {ShapeType::box, ShapeType::capsule}) {
    const double with_faces = pressed_clearance(type, true);
    const double vertices_only = pressed_clearance(type, false);
    std::printf("%s: lowest clearance %.4f m with the face step, %.4f m without\n",
                type == ShapeType::box ? "box corner" : "capsule end", with_faces, vertices_only);
    EXPECT_GT(with_faces, 0.0);
    EXPECT_LT(vertices_only, -0.01);  // the control: vertex contacts alone let it through
  }
}

}  // namespace
}  // namespace loom::collision
