// SelfCollisionStage: continuous response, impact zones, thread-count determinism, normal-cone
// culling (flat sheets culled, pairs between layers never), friction per material pair, the profile counters.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>

#include "loom/cloth/Cloth.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/collision/BodyCollisionStage.h"
#include "loom/collision/ExactPredicates.h"
#include "loom/collision/IntersectionCensus.h"
#include "loom/collision/MultiClothCensus.h"
#include "loom/collision/SelfCollisionStage.h"

namespace {

using loom::cloth::Cloth;
using loom::cloth::ClothMesh;
using loom::cloth::Vec3;
using loom::cloth::Vec3s;
using namespace loom::collision;

using Cloths = std::vector<std::unique_ptr<Cloth>>;

std::unique_ptr<Cloth> one_triangle(const Vec3& a, const Vec3& b, const Vec3& c, const std::string& name) {
  auto mesh = ClothMesh::from_triangles({a, b, c}, {{0, 1, 2}}, {}, name);
  return std::make_unique<Cloth>(name, mesh, loom::cloth::Material());
}

// Runs one stage step: every cloth moves from its current x (x_prev) to x + dx[c] (its candidate).
void step(SelfCollisionStage& stage, Cloths& cloths, const std::vector<Vec3s>& dx, double h, int threads) {
  for (size_t c = 0; c < cloths.size(); ++c) {
    auto& s = cloths[c]->state();
    s.x_prev = s.x;
    for (int i = 0; i < s.size(); ++i) {
      s.x[i] += dx[c][i];
      s.v[i] = dx[c][i] / h;
    }
  }
  loom::cloth::StageContext ctx{cloths, 0.0, h, threads};
  stage.run(ctx);
}

long census(const Cloths& cloths) {
  std::vector<CensusInput> in;
  for (const auto& c : cloths) in.push_back({&c->mesh(), &c->state().x});
  return count_all_intersections(in);
}

// Two triangles (two cloths, and the same two triangles as one cloth) approaching at 60 m/s (1 m per
// step against a 1 mm gap): after the stage the fast one is still above the other and nothing intersects.
TEST(SelfCollision, FastTrianglesNeverPassThrough) {
  for (bool one_cloth : {false, true}) {
    for (double speed : {1.0, 1e-3, 30.0}) {
      Cloths cloths;
      const Vec3 a(0, 0, 0), b(0.1, 0, 0), c(0, 0, 0.1);
      const Vec3 up(0.01, 0.001, 0.01);
      if (one_cloth) {
        auto mesh =
            ClothMesh::from_triangles({a, b, c, a + up, b + up, c + up}, {{0, 1, 2}, {3, 4, 5}}, {}, "pair");
        cloths.push_back(std::make_unique<Cloth>("pair", mesh, loom::cloth::Material()));
      } else {
        cloths.push_back(one_triangle(a, b, c, "low"));
        cloths.push_back(one_triangle(a + up, b + up, c + up, "high"));
      }
      SelfCollisionSettings set;
      set.thickness = {2e-4, 2e-4};
      SelfCollisionStage stage(set);
      std::vector<Vec3s> dx;
      if (one_cloth) {
        const Vec3 d(0, -speed, 0);
        dx.push_back({Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), d, d, d});
      } else {
        dx.push_back(Vec3s(3, Vec3::Zero()));
        dx.push_back(Vec3s(3, Vec3(0, -speed, 0)));
      }
      step(stage, cloths, dx, 1.0 / 60.0, 1);
      EXPECT_EQ(census(cloths), 0) << "one_cloth " << one_cloth << " speed " << speed;
      // The first vertex of the falling triangle is the one above the lower triangle: it stays above it.
      const Vec3s& hi = cloths.back()->state().x;
      const Vec3s& lo = cloths.front()->state().x;
      const int first = one_cloth ? 3 : 0;
      EXPECT_EQ(orient3d(lo[0], lo[1], lo[2], hi[first]), orient3d(a, b, c, a + up))
          << "passed through, speed " << speed;
      EXPECT_GT((hi[first] - lo[0]).y(), 0.0);
      EXPECT_TRUE(cloths.back()->state().is_finite());
    }
  }
}

// Seven single-triangle layers 0.5 mm apart, every other one thrown down / up by 5 mm in one step, with a
// single impulse pass: the impact-zone fail-safe has to resolve the rest. Layer order must be kept and
// no two layers intersect.
TEST(SelfCollision, ImpactZonesResolveCrushedStack) {
  Cloths cloths;
  const int layers = 7;
  std::vector<Vec3s> dx;
  for (int l = 0; l < layers; ++l) {
    const Vec3 o(0.002 * l, 5e-4 * l, 0.001 * l);
    cloths.push_back(one_triangle(o, o + Vec3(0.1, 0, 0), o + Vec3(0, 0, 0.1), "layer" + std::to_string(l)));
    const double d = (l % 2 ? -5e-3 : 5e-3) * (1.0 + 0.1 * l);
    dx.push_back({Vec3(0, d, 0), Vec3(0, 0.7 * d, 0), Vec3(0, 1.2 * d, 0)});
  }
  SelfCollisionSettings set;
  set.thickness.assign(layers, 1e-4);
  set.passes = 1;
  SelfCollisionStage stage(set);
  step(stage, cloths, dx, 1.0 / 60.0, 1);
  EXPECT_EQ(census(cloths), 0);
  double zones = 0;
  for (const auto& [k, v] : stage.counters())
    if (k == "impact_zones") zones = v;
  EXPECT_GT(zones, 0.0);
  // Order of the layers along y at the common point (0.01, *, 0.01) is kept.
  auto height = [&](int l) {
    const Vec3s& x = cloths[l]->state().x;
    return (x[0].y() * 0.8 + x[1].y() * 0.1 + x[2].y() * 0.1);
  };
  for (int l = 1; l < layers; ++l) EXPECT_LT(height(l - 1), height(l)) << "layers " << l - 1 << " and " << l;
}

// The same stack with the impact zones' work bound at 1 feature per vertex: the step still ends free of
// intersections (one rigid zone) and reports the bound by name; at the default bound it reports nothing.
TEST(SelfCollision, ImpactZonesPastTheirWorkBoundGoRigidAndSaySo) {
  for (double per_vertex : {1.0, SelfCollisionSettings().zone_features_per_vertex}) {
    Cloths cloths;
    const int layers = 7;
    std::vector<Vec3s> dx;
    for (int l = 0; l < layers; ++l) {
      const Vec3 o(0.002 * l, 5e-4 * l, 0.001 * l);
      cloths.push_back(
          one_triangle(o, o + Vec3(0.1, 0, 0), o + Vec3(0, 0, 0.1), "layer" + std::to_string(l)));
      const double d = (l % 2 ? -5e-3 : 5e-3) * (1.0 + 0.1 * l);
      dx.push_back({Vec3(0, d, 0), Vec3(0, 0.7 * d, 0), Vec3(0, 1.2 * d, 0)});
    }
    SelfCollisionSettings set;
    set.thickness.assign(layers, 1e-4);
    set.passes = 1;
    set.zone_features_per_vertex = per_vertex;
    SelfCollisionStage stage(set);
    step(stage, cloths, dx, 1.0 / 60.0, 1);
    EXPECT_EQ(census(cloths), 0) << per_vertex;
    double unresolved = 0;
    for (const auto& [k, v] : stage.counters())
      if (k == "unresolved") unresolved = v;
    if (per_vertex == 1.0) {
      EXPECT_NE(stage.violation().find("self-collision: the impact zones tested "), std::string::npos)
          << stage.violation();
      EXPECT_NE(stage.violation().find("more than 1 per cloth vertex"), std::string::npos)
          << stage.violation();
      EXPECT_EQ(unresolved, 1.0);
    } else {
      EXPECT_EQ(stage.violation(), "");
      EXPECT_EQ(unresolved, 0.0);
    }
  }
}

// A sheet crumpled by random large displacements: the result is bit-identical with 1 and 2 threads and
// free of intersections.
TEST(SelfCollision, ThreadCountDeterminismAndNoIntersections) {
  loom::cloth::GridSpec g;
  g.nodes_u = g.nodes_v = 17;
  g.size_u = g.size_v = 0.2;
  auto mesh = ClothMesh::grid(g);
  Vec3s result[2];
  for (int threads : {1, 2}) {
    Cloths cloths;
    cloths.push_back(std::make_unique<Cloth>("sheet", mesh, loom::cloth::Material()));
    // Start: a fold (intersection-free), the sheet bent over at u = 0.1 with 3 mm between the halves.
    auto& s = cloths[0]->state();
    for (Vec3& p : s.x) {
      if (p.x() > 0.1) p = Vec3(0.2 - p.x(), 0.003, p.z());
    }
    ASSERT_EQ(count_intersecting_pairs(*mesh, s.x), 0);
    SelfCollisionSettings set;
    set.thickness = {1e-3};
    SelfCollisionStage stage(set);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-4e-3, 4e-3);
    for (int k = 0; k < 5; ++k) {
      Vec3s dx(s.size());
      for (int i = 0; i < s.size(); ++i)
        dx[i] = Vec3(u(rng), u(rng) + (s.x[i].y() > 0.001 ? -2e-3 : 2e-3), u(rng));
      step(stage, cloths, {dx}, 1.0 / 120.0, threads);
      ASSERT_EQ(count_intersecting_pairs(*mesh, s.x), 0) << "step " << k << " threads " << threads;
    }
    result[threads - 1] = s.x;
  }
  for (size_t i = 0; i < result[0].size(); ++i) ASSERT_EQ(result[0][i], result[1][i]) << "vertex " << i;
}

double counter(const SelfCollisionStage& st, const std::string& key) {
  for (const auto& [k, v] : st.counters())
    if (k == key) return v;
  ADD_FAILURE() << "no counter " << key;
  return 0.0;
}

std::shared_ptr<const ClothMesh> flat_sheet(double size, int nodes, double y) {
  loom::cloth::GridSpec g;
  g.nodes_u = g.nodes_v = nodes;
  g.size_u = g.size_v = size;
  g.origin = Vec3(0, y, 0);
  return ClothMesh::grid(g);
}

// Two flat sheets (two cloths, layers) 1 mm apart; the upper one is thrown 5 mm down through the lower one.
// Each sheet alone is flat, so normal cones cull its self pairs whole; the pairs between the layers must
// never be culled: the stage keeps them apart.
TEST(SelfCollision, NormalConesCullFlatSheetsButNeverPairsBetweenLayers) {
  Cloths cloths;
  cloths.push_back(std::make_unique<Cloth>("lower", flat_sheet(0.2, 9, 0.0), loom::cloth::Material()));
  cloths.push_back(std::make_unique<Cloth>("upper", flat_sheet(0.2, 9, 0.001), loom::cloth::Material()));
  SelfCollisionSettings set;
  set.thickness = {5e-4, 5e-4};
  ASSERT_TRUE(set.normal_cones);
  SelfCollisionStage stage(set);
  std::vector<Vec3s> dx{Vec3s(81, Vec3::Zero()), Vec3s(81, Vec3(0, -0.005, 0))};
  step(stage, cloths, dx, 1.0 / 60.0, 2);
  EXPECT_EQ(census(cloths), 0);
  for (int i = 0; i < 81; ++i) EXPECT_GT(cloths[1]->state().x[i].y(), cloths[0]->state().x[i].y()) << i;
  EXPECT_GE(counter(stage, "culled_nodes"), 2.0);  // each sheet's root (twice: proximity and first pass)
  EXPECT_GT(counter(stage, "candidate_pairs"), 100.0);
  EXPECT_GT(counter(stage, "contacts"), 0.0);
  EXPECT_GE(counter(stage, "passes"), 1.0);
}

// A sheet whose edges (2.2 mm) are about its thickness (2 mm), as the 50k-triangle twisting bench: a vertex
// and the triangle across its quad's diagonal are 1.6 mm apart at rest. Such rest neighbours are one patch of
// cloth, not a contact: compressing the flat sheet by 5% gives no impulse and leaves every vertex where the
// solver put it (before their thickness was capped, every one of them got a repulsion impulse every step).
// The same sheet folded onto itself, 1.2 mm between the halves (far apart in the rest mesh), does get its
// contacts: repulsion pushes the halves apart, nothing intersects. Normal cones off: the flat sheet would
// otherwise be culled whole.
TEST(SelfCollision, RestNeighboursAreNoContactButAFoldOfTheSameSheetIs) {
  const int nodes = 17;
  const double edge = 0.0022, size = edge * (nodes - 1), mid = 0.5 * size;
  const auto mesh = flat_sheet(size, nodes, 0.0);
  SelfCollisionSettings set;
  set.thickness = {0.002};
  set.normal_cones = false;
  {
    Cloths cloths;
    cloths.push_back(std::make_unique<Cloth>("flat", mesh, loom::cloth::Material()));
    SelfCollisionStage stage(set);
    const auto& s = cloths[0]->state();
    Vec3s dx(s.size());
    for (int i = 0; i < s.size(); ++i) dx[i] = -0.05 * Vec3(s.x[i].x() - mid, 0.0, s.x[i].z() - mid);
    for (int k = 0; k < 3; ++k) {
      const Vec3s start = s.x;
      step(stage, cloths, {dx}, 1.0 / 240.0, 1);
      for (int i = 0; i < s.size(); ++i)
        ASSERT_EQ(s.x[i], Vec3(start[i] + dx[i])) << "vertex " << i << " step " << k;
    }
    EXPECT_GT(counter(stage, "features"), 0.0);  // the rest neighbours are still tested (continuous passes)
    EXPECT_EQ(counter(stage, "contacts"), 0.0);
  }
  {
    Cloths cloths;
    cloths.push_back(std::make_unique<Cloth>("folded", mesh, loom::cloth::Material()));
    auto& s = cloths[0]->state();
    const double gap = 0.0012;
    for (Vec3& p : s.x)
      if (p.x() > mid + 1e-9) p = Vec3(2.0 * mid - p.x(), gap, p.z());
    ASSERT_EQ(count_intersecting_pairs(*mesh, s.x), 0);
    SelfCollisionStage stage(set);
    Vec3s dx(s.size(), Vec3::Zero());
    double candidate = 0.0, upper = 0.0;
    int n_upper = 0;
    for (int i = 0; i < s.size(); ++i)
      if (s.x[i].y() > 0.5 * gap) dx[i] = Vec3(0, -3e-4, 0), candidate += s.x[i].y() - 3e-4, ++n_upper;
    step(stage, cloths, {dx}, 1.0 / 240.0, 1);
    EXPECT_EQ(count_intersecting_pairs(*mesh, s.x), 0);
    EXPECT_GT(counter(stage, "contacts"), 0.0);
    for (int i = 0; i < s.size(); ++i)
      if (dx[i].y() < 0.0) upper += s.x[i].y();
    EXPECT_GT(upper / n_upper, candidate / n_upper + 1e-5);  // m: repulsion pushed the upper half back up
  }
}

// Cloth-cloth friction per material pair: a small sheet resting on a pinned sheet, gravity tilted by theta
// with tan(theta) = 0.45. The pair's coefficients (mu_s = 0.5) hold it; the same scene with a slippery pair
// (0.05) slides it down nearly freely (a = g (sin - 0.05 cos)), whatever the global coefficients say
// (0.9/1.0).
double cloth_incline(double mu_k, double mu_s) {
  Cloths cloths;
  cloths.push_back(std::make_unique<Cloth>("base", flat_sheet(0.4, 9, 0.0), loom::cloth::Material()));
  cloths.push_back(std::make_unique<Cloth>("top", flat_sheet(0.1, 3, 0.0008), loom::cloth::Material()));
  auto& base = cloths[0]->state();
  for (int i = 0; i < base.size(); ++i) base.inv_mass[i] = 0.0;  // pinned
  for (auto& p : cloths[1]->state().x) p += Vec3(0.151, 0, 0.153);
  SelfCollisionSettings set;
  set.thickness = {1e-3, 1e-3};
  set.friction = 0.9, set.static_friction = 1.0;  // global: would always stick
  FrictionPair fp;
  fp.cloth = 1, fp.other_cloth = 0, fp.friction = mu_k, fp.static_friction = mu_s;
  set.friction_pairs.push_back(fp);
  SelfCollisionStage stage(set);
  const double theta = std::atan(0.45), h = 1.0 / 600.0;
  const Vec3 g = 9.81 * Vec3(std::sin(theta), -std::cos(theta), 0.0);
  auto& top = cloths[1]->state();
  const Vec3 start = top.x[4];
  std::vector<Vec3s> dx(2);
  dx[0] = Vec3s(base.size(), Vec3::Zero());
  for (int k = 0; k < 300; ++k) {  // 0.5 s; the stage turns dx into the new velocity
    dx[1].assign(top.size(), Vec3::Zero());
    for (int i = 0; i < top.size(); ++i) dx[1][i] = h * (top.v[i] + h * g);
    step(stage, cloths, dx, h, 1);
    for (int i = 0; i < top.size(); ++i) top.v[i] = (top.x[i] - top.x_prev[i]) / h;
    if (k % 50 == 49) {
      EXPECT_EQ(census(cloths), 0) << "step " << k;
    }
  }
  return top.x[4].x() - start.x();
}

TEST(SelfCollision, FrictionPerMaterialPair) {
  const double theta = std::atan(0.45);
  const double free_slide = 0.5 * 9.81 * (std::sin(theta) - 0.05 * std::cos(theta)) * 0.25;
  // Held: creeps by less than 1% of the free slide (impulses are averaged over a vertex's contacts, so the
  // static stop is not exact per vertex).
  EXPECT_LT(std::abs(cloth_incline(0.4, 0.5)), 0.01 * free_slide);
  EXPECT_NEAR(cloth_incline(0.05, 0.05), free_slide, 0.15 * free_slide);
}

// A pinned vertex (a garment's attached waist) moving at 2.4 m/s into a free triangle of another cloth, next
// to the triangle's vertex b0 that rests on a floor (the body stage leaves it near a collider, so the self
// stage counts it 1000 times heavier). The contact point is 90 % at b0: sharing the velocity change by those
// weights inside the triangle moved the point by flicking the two far vertices at ~9x the contact's speed
// (20.7 m/s with Bridson's shares unbounded, max_share 0). With the shares capped at max_share (1: no vertex
// changes faster than the contact) the triangle gives way as a whole: no vertex of it is faster than the pin,
// nothing passes through, b0 does not go into the floor. Both the proximity impulse (start gap 0.5 mm) and
// the continuous pass (2 mm).
// The bounded shares: the constraint sum_k w_k beta_k = 1 holds wherever some movable vertex is below the
// bound, and no share exceeds it. Where held vertices leave the movable ones at the bound, the features move
// as blocks: a vertex with w_k = 0 (closest point on a triangle's edge) moves with its feature, on its
// feature's side whatever the sign of the zero.
TEST(SelfCollision, CappedSharesKeepTheBoundAndMoveFeaturesAsBlocks) {
  auto constraint = [](const double w[4], const double b[4]) {
    return w[0] * b[0] + w[1] * b[1] + w[2] * b[2] + w[3] * b[3];
  };
  double beta[4];
  {  // free contact, equal masses: Bridson's shares are within the bound and kept
    const double w[4] = {1.0, -0.2, -0.3, -0.5}, im[4] = {1.0, 1.0, 1.0, 1.0};
    ASSERT_TRUE(capped_shares(w, im, 1, 1.0, beta));
    EXPECT_NEAR(constraint(w, beta), 1.0, 1e-12);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(beta[k], w[k] / 1.38, 1e-12) << k;
  }
  {  // a heavy point (held near a body): the light far vertex alone would take 1/0.1 = 10x; capped at 1
    const double w[4] = {1.0, -0.9, -0.1, 0.0}, im[4] = {1e-3, 1e-3, 1.0, 1.0};
    ASSERT_TRUE(capped_shares(w, im, 1, 1.0, beta));
    for (int k = 0; k < 4; ++k) EXPECT_LE(std::abs(beta[k]), 1.0 + 1e-9) << k;
    EXPECT_NEAR(constraint(w, beta), 1.0, 1e-9);
    EXPECT_EQ(beta[3], 0.0);
  }
  {  // held point and vertex (inverse mass 0): the movable t1 and t2 (w = +0, on the edge t0-t1) take the
     // bound on the triangle's side
    const double w[4] = {1.0, -0.5, -0.5, 0.0}, im[4] = {0.0, 0.0, 1.0, 1.0};
    ASSERT_TRUE(capped_shares(w, im, 1, 1.0, beta));
    EXPECT_EQ(beta[0], 0.0);
    EXPECT_EQ(beta[1], 0.0);
    EXPECT_EQ(beta[2], -1.0);
    EXPECT_EQ(beta[3], -1.0);
  }
  {  // a tight bound (0.3 < 1 / sum|w_k|) and masses that cap one vertex per round: the fourth round caps the
     // last vertex, and the fifth finds none left below the bound; none may end beyond it
    const double w[4] = {1.0, -0.4, -0.35, -0.25}, im[4] = {1.0, 1e-2, 1e-4, 1e-6};
    ASSERT_TRUE(capped_shares(w, im, 1, 0.3, beta));
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(std::abs(beta[k]), 0.3, 1e-12) << k;
  }
  {  // nothing can move
    const double w[4] = {1.0, -1.0, 0.0, 0.0}, im[4] = {0.0, 0.0, 0.0, 0.0};
    EXPECT_FALSE(capped_shares(w, im, 1, 1.0, beta));
  }
}

TEST(SelfCollision, ContactNextToANearBodyVertexDoesNotFlickTheFarVertices) {
  for (double gap : {5e-4, 2e-3}) {
    const Vec3 b0(0, 0.0015, 0), b1(0.1, 0.0515, 0), b2(0, 0.0515, 0.1);
    const Vec3 n = (b1 - b0).cross(b2 - b0).normalized() * -1.0;  // the triangle's upper side (+y)
    const Vec3 p = b0 + 0.05 * (b1 - b0) + 0.05 * (b2 - b0);      // 90 % at b0
    const Vec3 a0 = p - gap * n;
    Cloths cloths;
    cloths.push_back(one_triangle(a0, a0 + Vec3(0, -0.3, -0.01), a0 + Vec3(-0.01, -0.3, 0), "pinned"));
    cloths.push_back(one_triangle(b0, b1, b2, "free"));
    for (double& w : cloths[0]->state().inv_mass) w = 0.0;
    const double h = 1.0 / 240.0, speed = 2.4;  // s, m/s
    for (size_t c = 0; c < cloths.size(); ++c) {
      auto& s = cloths[c]->state();
      s.x_prev = s.x;
      for (int i = 0; i < s.size(); ++i) {
        s.v[i] = c == 0 ? Vec3(speed * n) : Vec3::Zero();
        s.x[i] += h * s.v[i];
      }
    }
    auto set = std::make_shared<ColliderSet>();
    Collider floor;
    floor.shape.type = ShapeType::plane;
    floor.prev = floor.curr = Transform::Identity();
    floor.thickness = 0.001;
    set->push_back(floor);
    BodyCollisionStage body(set);
    SelfCollisionSettings settings;
    settings.thickness = {1e-3, 1e-3};
    SelfCollisionStage self(settings);
    self.set_body_stage(&body);
    loom::cloth::StageContext ctx{cloths, 0.0, h, 1};
    body.run(ctx);
    ASSERT_EQ((*body.near_collider(1))[0], 1) << "b0 should rest near the floor";
    self.run(ctx);
    const auto& s = cloths[1]->state();
    double fastest = 0.0;
    for (int i = 0; i < s.size(); ++i) fastest = std::max(fastest, s.v[i].norm());
    EXPECT_LE(fastest, 1.2 * speed) << "gap " << gap;
    EXPECT_GT(fastest, 0.5 * speed) << "gap " << gap << ": the triangle must give way";
    EXPECT_EQ(census(cloths), 0) << "gap " << gap;
    EXPECT_GT(s.x[0].y(), 0.5e-3) << "gap " << gap << ": b0 pushed into the floor";
  }
}

}  // namespace
