// BodyCollisionStage: friction (stick below tan(theta) = mu_s, slide above with mu_k), reaction impulse =
// minus the cloth's momentum change, nothing tunnels (a capsule at 30 m/s through a coarse hanging sheet, a
// sheet falling at 20 m/s onto a thin box), no vertex ends a step inside a collider, thread-count
// determinism.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "BodyContactTestUtil.h"
#include "SymplecticSetup.h"
#include "loom/cloth/Simulation.h"
#include "loom/collision/BodyCollisionStage.h"
#include "loom/collision/ColliderDistance.h"

namespace loom::collision {
namespace {

using namespace loom::collision::test;
using cloth::Simulation;
using cloth::SimulationSetup;

// A small sheet resting on the plane y = 0 under gravity tilted by theta (same as an incline). With `pair`,
// the collider's own coefficients are 0.05 and the (cloth, plane) material pair gives 0.4 / 0.5.
double incline_slide(double theta, double seconds, bool pair = false) {
  SimulationSetup s = loom::test::symplectic_setup();
  s.cloths.push_back(sheet(3, 0.1, cloth::GridPlane::kXZ, Vec3(0, 0.002, 0)));
  s.gravity = 9.81 * Vec3(std::sin(theta), -std::cos(theta), 0.0);
  s.substeps = 100;
  Simulation sim(s);
  auto set = std::make_shared<ColliderSet>(1, shape(ShapeType::plane));
  (*set)[0].friction = 0.4;
  (*set)[0].static_friction = 0.5;
  (*set)[0].thickness = 0.002;
  BodyCollisionSettings bs;
  if (pair) {
    (*set)[0].friction = (*set)[0].static_friction = 0.05;
    FrictionPair fp;
    fp.cloth = 0, fp.collider = 0, fp.friction = 0.4, fp.static_friction = 0.5;
    bs.friction_pairs.push_back(fp);
  }
  sim.add_stage(std::make_unique<BodyCollisionStage>(set, bs));
  const Vec3 x0 = sim.cloths()[0]->state().x[4];
  for (int f = 0; f < std::lround(seconds * 60); ++f) sim.step_frame();
  const auto& st = sim.cloths()[0]->state();
  EXPECT_GT(worst_gap(st, *set, 0.002), -1e-9);
  return st.x[4].x() - x0.x();
}

TEST(BodyCollision, FrictionSticksBelowStaticLimitAndSlidesAbove) {
  // tan(theta) = 0.45 < mu_s = 0.5: no motion at all.
  EXPECT_LT(std::abs(incline_slide(std::atan(0.45), 0.5)), 1e-9);
  // tan(theta) = 0.6 > mu_s: slides with a = g (sin - mu_k cos).
  const double theta = std::atan(0.6);
  const double a = 9.81 * (std::sin(theta) - 0.4 * std::cos(theta));
  const double d = incline_slide(theta, 0.5);
  EXPECT_NEAR(d, 0.5 * a * 0.25, 0.03 * 0.5 * a * 0.25);
}

// The same through a per-material-pair entry: it wins over the collider's coefficients (0.05, which would
// slide).
TEST(BodyCollision, FrictionPairWinsOverTheCollidersCoefficients) {
  EXPECT_LT(std::abs(incline_slide(std::atan(0.45), 0.5, true)), 1e-9);
  const double theta = std::atan(0.6);
  const double a = 9.81 * (std::sin(theta) - 0.4 * std::cos(theta));
  EXPECT_NEAR(incline_slide(theta, 0.5, true), 0.5 * a * 0.25, 0.03 * 0.5 * a * 0.25);
}

// A 20 cm patch resting on top of a sphere (radius 0.3 m) that spins about the horizontal z axis, so its top
// moves sideways at rate * 0.3 m/s, like a roller under the cloth; implicit Euler at 1/120 s. Returns the
// patch's mean displacement along x after 0.3 s. Only friction can move it along x.
double roller_drag(double mu, double rate) {
  SimulationSetup s = loom::test::symplectic_setup();
  s.cloths.push_back(sheet(21, 0.2, cloth::GridPlane::kXZ, Vec3(-0.1, 0.806, -0.1)));
  s.cloths[0].material.areal_density = 0.25;
  s.solver.method = "implicit_euler";
  s.substeps = 2;
  Simulation sim(s);
  auto set = std::make_shared<ColliderSet>(1, shape(ShapeType::sphere, 0.3));
  Collider& ball = (*set)[0];
  ball.friction = ball.static_friction = mu;
  ball.thickness = 0.005;
  ball.motion = [rate](double t) {
    Transform tr = Transform::Identity();
    tr.linear() = Eigen::AngleAxisd(rate * t, Vec3::UnitZ()).toRotationMatrix();
    tr.translation() = Vec3(0.0, 0.5, 0.0);
    return tr;
  };
  sim.add_stage(std::make_unique<BodyCollisionStage>(set));
  auto mean_x = [&] {
    const auto& st = sim.cloths()[0]->state();
    double sum = 0.0;
    for (int i = 0; i < st.size(); ++i) sum += st.x[i].x();
    return sum / st.size();
  };
  const double x0 = mean_x();
  for (int f = 0; f < 18; ++f) sim.step_frame();
  EXPECT_GT(worst_gap(sim.cloths()[0]->state(), *set, 0.005), -1e-6);
  return mean_x() - x0;
}

// A vertex the swept test catches slides from the contact point carried with the body by Coulomb's law
// (ending at the carried point always would be full stick whatever the friction coefficient).
TEST(BodyCollision, SweptHitsOnASpinningSphereFollowCoulombFriction) {
  // No friction: the surface cannot drag the cloth at all.
  EXPECT_LT(std::abs(roller_drag(0.0, 10.0)), 1e-3);
  EXPECT_LT(std::abs(roller_drag(0.0, 30.0)), 1e-3);
  // Kinetic friction: the drag does not depend on the surface speed (the patch stays far slower than the
  // surface), and it is what μ_k g gives in 0.3 s, ½ μ g t² = 4.4 cm, plus the downhill pull once the patch
  // leaves the top: a point mass on the roller's top (radius R = 0.305 m with the thickness) follows
  // x'' = μ g + g x / R, so x(t) = μ R (cosh(sqrt(g / R) t) - 1) = 5.6 cm, the upper bound.
  const double g = 9.81, mu = 0.1, t = 0.3, r = 0.305;
  const double lower = 0.5 * mu * g * t * t, upper = mu * r * (std::cosh(std::sqrt(g / r) * t) - 1.0);
  const double slow = roller_drag(mu, 10.0), fast = roller_drag(mu, 30.0);
  EXPECT_LT(slow, -0.5 * lower);  // dragged with the surface (towards -x on top for a positive spin)
  EXPECT_LT(std::abs(slow), upper);
  EXPECT_NEAR(fast, slow, 0.1 * std::abs(slow));
}

TEST(BodyCollision, ReactionImpulseIsMinusTheClothMomentumChange) {
  SimulationSetup s = loom::test::symplectic_setup();
  s.cloths.push_back(sheet(9, 0.4, cloth::GridPlane::kYZ, Vec3(-0.3, -0.2, -0.2)));
  s.cloths[0].initial_velocity = Vec3(2.0, 0.0, 0.0);
  s.gravity = Vec3::Zero();
  s.substeps = 50;
  Simulation sim(s);
  auto set = std::make_shared<ColliderSet>(1, shape(ShapeType::sphere, 0.1));
  Collider& ball = (*set)[0];
  ball.motion = [](double t) { return at(Vec3(0.3 - 1.0 * t, 0.0, 0.0)); };
  sim.add_stage(std::make_unique<BodyCollisionStage>(set));
  auto momentum = [&] {
    Vec3 p = Vec3::Zero();
    const auto& st = sim.cloths()[0]->state();
    for (int i = 0; i < st.size(); ++i) p += st.mass[i] * st.v[i];
    return p;
  };
  const Vec3 p0 = momentum();
  for (int f = 0; f < 18; ++f) sim.step_frame();
  const Vec3 dp = momentum() - p0;
  EXPECT_GT(dp.norm(), 0.05 * p0.norm());  // the collision happened
  EXPECT_LT((dp + ball.reaction_impulse).norm(), 1e-9 * dp.norm());
  EXPECT_GT(ball.reaction_impulse.x(), 0.0);  // the cloth pushes the ball along +x
}

// A capsule (radius 2 cm, thinner than the 5 cm grid spacing) fired at 30 m/s through a hanging sheet.
// Tracked every step: no vertex inside the capsule, and where the upper sheet (rows 4-12: between the pins
// and the axis) is pulled across the axis's height (edges with one end above and one below the axis, within
// the middle of the capsule), it is ahead of the capsule: nothing slipped through.
void capsule_shot(int threads, cloth::Vec3s* final_x) {
  SimulationSetup s = loom::test::symplectic_setup();
  s.cloths.push_back(sheet(13, 0.6, cloth::GridPlane::kXY, Vec3(-0.3, 0.7, 0.0)));
  for (int i = 0; i < 13; ++i) s.cloths[0].pins.push_back({s.cloths[0].mesh->grid_index(i, 12), {}, {}, {}});
  s.substeps = 200;
  s.threads = threads;
  Simulation sim(s);
  auto set = std::make_shared<ColliderSet>(1, shape(ShapeType::capsule, 0.02, 0.15));
  const double speed = 30.0, z_start = -0.3;
  (*set)[0].motion = [&](double t) { return at(Vec3(0.01, 0.87, z_start + speed * t), M_PI / 2); };
  sim.add_stage(std::make_unique<BodyCollisionStage>(set));
  long checked = 0;
  double carried = 0.0;  // m, farthest the sheet's middle got pushed
  sim.add_stage(std::make_unique<CheckStage>([&](cloth::StageContext& ctx) {
    const auto& st = ctx.cloths[0]->state();
    const Collider& c = (*set)[0];
    const Vec3 cc = c.curr.translation();
    carried = std::max(carried, st.x[4 * 13 + 6].z());
    EXPECT_GT(worst_gap(st, *set, 0.0), -1e-6) << "t=" << ctx.t;
    for (const auto& e : ctx.cloths[0]->mesh().edges()) {
      // The upper sheet (rows 4-12, above the axis, held by the pins) is what the capsule must carry; the
      // free lower part may slide under the capsule and trail behind it.
      if (e.i / 13 < 4 && e.j / 13 < 4) continue;
      const Vec3 &a = st.x[e.i], &b = st.x[e.j];
      if ((a.y() - cc.y()) * (b.y() - cc.y()) >= 0.0) continue;
      const double s = (cc.y() - a.y()) / (b.y() - a.y());
      const Vec3 p = a + s * (b - a);
      if (std::abs(p.x() - cc.x()) > 0.08)
        continue;  // the middle of the capsule (the sheet may slide off its ends)
      ++checked;
      EXPECT_GT(p.z(), cc.z()) << "edge " << e.i << "-" << e.j << " behind the capsule at t=" << ctx.t;
    }
  }));
  for (int f = 0; f < 3; ++f) sim.step_frame();
  EXPECT_GT(checked, 50);
  EXPECT_GT(carried, 0.3);  // the sheet was carried along before it slid off
  if (final_x) *final_x = sim.cloths()[0]->state().x;
}

TEST(BodyCollision, CapsuleAt30MetresPerSecondNeverPassesThroughTheSheet) { capsule_shot(1, nullptr); }

// A pinch: a sheet wedged into the crease of two overlapping capsules that meet at a joint, 40 degrees
// apart (a sharply bent knee: thigh and shin capsules overlap around it). Projecting a vertex out of one
// pushes it into the other; after the passes it leaves the union along the sum of the normals: every free
// vertex ends every step at least the thickness outside both capsules.
TEST(BodyCollision, VertexInTheCreaseOfTwoCapsulesEndsOutsideBoth) {
  SimulationSetup s = loom::test::symplectic_setup();
  // 3 x 3 nodes, 4 cm, centred on the crease's plane x = 0, its middle row 1.5 cm inside both capsules.
  s.cloths.push_back(sheet(3, 0.04, cloth::GridPlane::kXZ, Vec3(-0.02, 0.11, -0.02)));
  s.gravity = Vec3(0, -9.81, 0);
  s.substeps = 4;
  Simulation sim(s);
  const double r = 0.05, half = 0.15, tilt = 20.0 * M_PI / 180.0;  // m, m, rad
  auto set = std::make_shared<ColliderSet>();
  for (double sign : {1.0, -1.0}) {
    Collider c = shape(ShapeType::capsule, r, half);
    const Vec3 axis(-sign * std::sin(tilt), std::cos(tilt), 0.0);  // from the joint at the origin, upwards
    c.prev = c.curr = at(half * axis, sign * tilt);
    c.thickness = 0.001;
    set->push_back(c);
  }
  // Both capsules contain the middle row at the start (distance to each axis < r).
  EXPECT_LT(signed_distance((*set)[0], (*set)[0].curr, Vec3(0, 0.11, 0), nullptr), -0.01);
  EXPECT_LT(signed_distance((*set)[1], (*set)[1].curr, Vec3(0, 0.11, 0), nullptr), -0.01);
  sim.add_stage(std::make_unique<BodyCollisionStage>(set));
  double worst = HUGE_VAL;
  sim.add_stage(std::make_unique<CheckStage>([&](cloth::StageContext& ctx) {
    worst = std::min(worst, worst_gap(ctx.cloths[0]->state(), *set, 0.001));
  }));
  for (int f = 0; f < 10; ++f) sim.step_frame();
  EXPECT_GT(worst, -1e-9);
}

// Runs a body stage on `set` once (one 240 Hz step) and returns its counter `name` (-1 if it has none).
double run_once(std::vector<std::unique_ptr<cloth::Cloth>>& cloths, const std::shared_ptr<ColliderSet>& set,
                const std::string& name) {
  BodyCollisionStage stage(set);
  cloth::StageContext ctx{cloths, 0.0, 1.0 / 240.0, 1};
  stage.run(ctx);
  for (const auto& [k, v] : stage.counters())
    if (k == name) return v;
  return -1.0;
}

// A capsule threaded through a cloth triangle (a hand through a coarse skirt): inside the triangle (v0 v1 v2)
// near its 45-degree corner v0, touching both edges v0-v1 and v0-v2 from inside. Corrected, the two edges
// would go to opposite sides and pull v1 and v2 apart. They are left alone (counter threaded_edges) and no
// edge gets longer. The same capsule under the sheet, where the edges cross it from one side (cloth draped
// over a limb), is still corrected.
TEST(BodyCollision, CapsuleThreadedThroughATriangleDoesNotTearItsEdgesApart) {
  for (bool threaded : {true, false}) {
    auto mesh =
        cloth::ClothMesh::from_triangles({Vec3(0, 0, 0), Vec3(0.3, 0, 0), Vec3(0.3, 0, 0.3), Vec3(0, 0, 0.3)},
                                         {{0, 1, 2}, {0, 2, 3}}, {}, "square");
    std::vector<std::unique_ptr<cloth::Cloth>> cloths;
    cloths.push_back(std::make_unique<cloth::Cloth>("square", mesh, cloth::material_preset("cotton")));
    auto& st = cloths[0]->state();
    st.x_prev = st.x;
    auto set = std::make_shared<ColliderSet>();
    Collider c = shape(ShapeType::capsule, 0.015, 0.1);
    c.thickness = 0.001;
    if (threaded) {
      // Vertical, 1 cm from the edge z = 0 and 1.2 cm from the diagonal z = x, 3 cm from v0.
      c.prev = c.curr = at(Vec3(0.028, 0, 0.01));
    } else {
      // Along x, axis 1 cm below the sheet: the edges v0-v3, v0-v2 and v1-v2 cross it 6 mm deep, from above.
      c = shape(ShapeType::capsule, 0.015, 0.2);
      c.thickness = 0.001;
      c.prev = c.curr = at(Vec3(0.15, -0.01, 0.1), -M_PI / 2);
    }
    set->push_back(c);
    std::vector<double> before;
    for (const auto& e : mesh->edges()) before.push_back((st.x[e.i] - st.x[e.j]).norm());
    const double threaded_edges = run_once(cloths, set, "threaded_edges");
    double stretch = 0.0;
    for (size_t e = 0; e < mesh->edges().size(); ++e)
      stretch = std::max(stretch, (st.x[mesh->edges()[e].i] - st.x[mesh->edges()[e].j]).norm() - before[e]);
    if (threaded) {
      EXPECT_GT(threaded_edges, 0.0);
      EXPECT_LT(stretch, 1e-12) << "edge corrections from both sides of the capsule stretched the cloth";
    } else {
      EXPECT_EQ(threaded_edges, 0.0);
      // Draped: every edge ends outside the capsule (thickness 1 mm).
      for (const auto& e : mesh->edges()) {
        double sp = 0.0;
        Vec3 n;
        EXPECT_GT(segment_capsule_distance((*set)[0], (*set)[0].curr, st.x[e.i], st.x[e.j], &sp, &n), 0.0)
            << "edge " << e.i << "-" << e.j;
      }
    }
    EXPECT_TRUE(st.is_finite());
  }
}

// KNOWN GAP, disabled. The threaded test compares each corrected edge's normal with the vertex's *first*
// capsule correction only. Here v0's first corrected edge (v0-v1) lies on a limb below the sheet (capsule A),
// and a second capsule B is threaded through triangle (v0 v2 v3) near v0, reaching edges v0-v2 and v0-v3 from
// opposite sides: B's two edges are corrected and pull v2 and v3 apart. Comparing every two edges of a vertex
// per capsule (and dropping only that capsule's edges) passes this test, but makes layered garments on a
// mocap clip faster and more strained than the first-normal test does, so it is not in.
TEST(BodyCollision, DISABLED_ThreadedCapsuleIsFoundBehindAnotherCollidersEdge) {
  auto mesh =
      cloth::ClothMesh::from_triangles({Vec3(0, 0, 0), Vec3(0.3, 0, 0), Vec3(0.3, 0, 0.3), Vec3(0, 0, 0.3)},
                                       {{0, 1, 2}, {0, 2, 3}}, {}, "square");
  ASSERT_EQ(mesh->edges()[0].i, 0);
  ASSERT_EQ(mesh->edges()[0].j, 1);  // v0's first edge in the stage's order is A's
  std::vector<std::unique_ptr<cloth::Cloth>> cloths;
  cloths.push_back(std::make_unique<cloth::Cloth>("square", mesh, cloth::material_preset("cotton")));
  auto& st = cloths[0]->state();
  st.x_prev = st.x;
  for (Vec3& p : st.x_prev) p.y() += 0.01;  // the sheet comes down 1 cm onto A (and along B's axis)
  const Vec3s start = st.x;
  auto set = std::make_shared<ColliderSet>();
  Collider b = shape(ShapeType::capsule, 0.015, 0.1);  // vertical, 1 cm from x = 0 and 1.3 cm from z = x
  b.thickness = 0.001;
  b.prev = b.curr = at(Vec3(0.01, 0, 0.028));
  set->push_back(b);
  Collider a = shape(ShapeType::capsule, 0.015, 0.1);  // along x from 0.05 to 0.25, 1.1 cm from edge v0-v1
  a.thickness = 0.001;
  a.prev = a.curr = at(Vec3(0.15, -0.01, -0.005), -M_PI / 2);
  set->push_back(a);
  const double threaded_edges = run_once(cloths, set, "threaded_edges");
  EXPECT_GT(threaded_edges, 0.0);
  EXPECT_TRUE(st.is_finite());
  // v2 and v3 are on no corrected edge: they stay where they were, so B did not pull them apart.
  EXPECT_EQ((st.x[2] - start[2]).norm(), 0.0);
  EXPECT_EQ((st.x[3] - start[3]).norm(), 0.0);
  // A's edge was corrected out of A.
  double sp = 0.0;
  Vec3 n;
  EXPECT_GT(segment_capsule_distance(a, a.curr, st.x[0], st.x[1], &sp, &n), 0.0);
  EXPECT_GT((st.x[0] - start[0]).norm(), 1e-3);
}

// One vertex (P) on three edges that cross a capsule below the sheet at different depths, each of its three
// partners (Q1-Q3) on that one corrected edge only; Q3, on the deepest, also holds a hem edge Q3-R that
// touches nothing. Scaled per end, Q3 would take its whole inverse-mass share of a 1.6 cm deficit while P
// took the mean, and Q3 alone would jump away from R. Both ends of an edge take the same fraction: the edge
// is moved along the normal, not swung about P.
TEST(BodyCollision, EdgeCorrectionMovesBothEndsAlikeAndSparesTheirOtherEdges) {
  const Vec3 p(0, 0, 0), q1(0, 0, 0.1), q2(0.1, 0, 0.1), q3(-0.1, 0, 0.1), r(-0.2, 0, 0.15);
  auto mesh =
      cloth::ClothMesh::from_triangles({p, q1, q2, q3, r}, {{0, 2, 1}, {0, 1, 3}, {3, 1, 4}}, {}, "fan");
  std::vector<std::unique_ptr<cloth::Cloth>> cloths;
  cloths.push_back(std::make_unique<cloth::Cloth>("fan", mesh, cloth::material_preset("cotton")));
  auto& st = cloths[0]->state();
  st.x_prev = st.x;
  // Along x under the line z = 0.05, tilted: its axis 5 mm below the sheet at x = -0.05, 15 mm at x = 0.05.
  Collider c = shape(ShapeType::capsule, 0.02, 0.3);
  c.thickness = 0.001;
  c.prev = c.curr = at(Vec3(0, -0.01, 0.05), -M_PI / 2 - std::atan(0.1));
  auto set = std::make_shared<ColliderSet>(1, c);
  const double rest = (q3 - r).norm();
  BodyCollisionStage stage(set);
  cloth::StageContext ctx{cloths, 0.0, 1.0 / 240.0, 1};
  stage.run(ctx);
  EXPECT_TRUE(st.is_finite());
  // The capsule reached all three edges of P (deficits 0.6-1.6 cm) and moved them out.
  for (const auto& e : mesh->edges()) {
    double sp = 0.0;
    Vec3 n;
    EXPECT_GT(segment_capsule_distance(c, c.curr, st.x[e.i], st.x[e.j], &sp, &n), -0.002)
        << "edge " << e.i << "-" << e.j;
  }
  EXPECT_GT((st.x[0] - p).norm(), 0.003);
  // Q3 moves no farther than P (1.4 vs 1.8 cm; scaled per end 2.1 vs 1.1 cm), and its hem edge stretches by
  // less than 1.8% (1.3%; scaled per end 2.5%).
  EXPECT_LE((st.x[3] - q3).norm(), (st.x[0] - p).norm() + 1e-12);
  EXPECT_LT((st.x[3] - st.x[4]).norm() / rest - 1.0, 0.018);
}

TEST(BodyCollision, OneAndTwoThreadsBitIdentical) {
  cloth::Vec3s a, b;
  capsule_shot(1, &a);
  capsule_shot(2, &b);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i], b[i]) << i;
}

// A sheet thrown down at 20 m/s (0.33 m per frame, 10x the box's 4 cm thickness per step at 1 substep)
// onto a thin static box: it lands on top, nothing gets inside or below.
TEST(BodyCollision, FastFallingSheetLandsOnAThinBox) {
  SimulationSetup s = loom::test::symplectic_setup();
  s.cloths.push_back(sheet(9, 0.4, cloth::GridPlane::kXZ, Vec3(-0.2, 0.5, -0.2)));
  s.cloths[0].initial_velocity = Vec3(0, -20.0, 0);
  s.substeps = 20;
  Simulation sim(s);
  auto set = std::make_shared<ColliderSet>(1, shape(ShapeType::box, 0, 0, Vec3(0.5, 0.02, 0.5)));
  (*set)[0].thickness = 0.003;
  auto stage = std::make_unique<BodyCollisionStage>(set);
  BodyCollisionStage* body = stage.get();
  sim.add_stage(std::move(stage));
  sim.add_stage(std::make_unique<CheckStage>([&](cloth::StageContext& ctx) {
    EXPECT_GT(worst_gap(ctx.cloths[0]->state(), *set, 0.003), -1e-9);
    EXPECT_LE(body->max_deficit(), 1e-9);
  }));
  for (int f = 0; f < 20; ++f) sim.step_frame();
  for (const Vec3& x : sim.cloths()[0]->state().x) EXPECT_GT(x.y(), 0.02);
  double ccd = 0;
  for (const auto& [name, value] : body->counters())
    if (name == "ccd_hits") ccd = value;
  EXPECT_GT(ccd, 0);
}

}  // namespace
}  // namespace loom::collision
