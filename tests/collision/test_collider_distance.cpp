// signed_distance of every shape against analytic values and brute force; normals against the gradient;
// poses; the swept point test against dense sampling (no false negatives).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "loom/collision/ColliderDistance.h"
#include "loom/collision/ColliderGeometry.h"
#include "loom/collision/Distance.h"
#include "loom/collision/SweptCollider.h"

namespace loom::collision {
namespace {

Collider make(ShapeType type, double radius = 0.0, double half_height = 0.0,
              Vec3 half_extents = Vec3::Zero()) {
  Collider c;
  c.shape.type = type;
  c.shape.radius = radius;
  c.shape.half_height = half_height;
  c.shape.half_extents = half_extents;
  return c;
}

Transform pose(const Vec3& t, const Vec3& axis, double angle) {
  Transform p = Transform::Identity();
  p.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  p.translation() = t;
  return p;
}

// Brute-force distance to a surface given as a dense point sample, signed by `inside`.
template <class Inside>
double brute(const std::vector<Vec3>& surface, const Vec3& q, Inside inside) {
  double best = HUGE_VAL;
  for (const Vec3& s : surface) best = std::min(best, (s - q).norm());
  return inside(q) ? -best : best;
}

std::vector<Vec3> cylinder_surface(double r, double hh, int n) {
  std::vector<Vec3> out;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double a = 2 * M_PI * i / n, y = -hh + 2 * hh * j / n;
      out.emplace_back(r * std::cos(a), y, r * std::sin(a));
    }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double a = 2 * M_PI * i / n, rr = r * j / n;
      out.emplace_back(rr * std::cos(a), hh, rr * std::sin(a));
      out.emplace_back(rr * std::cos(a), -hh, rr * std::sin(a));
    }
  return out;
}

TEST(ColliderDistance, AnalyticShapesMatchClosedFormValues) {
  Vec3 n;
  const Collider plane = make(ShapeType::plane);
  EXPECT_DOUBLE_EQ(signed_distance(plane, Transform::Identity(), Vec3(3, -0.25, 1), &n), -0.25);
  EXPECT_TRUE(n.isApprox(Vec3(0, 1, 0)));
  const Collider sphere = make(ShapeType::sphere, 0.5);
  EXPECT_NEAR(signed_distance(sphere, Transform::Identity(), Vec3(0, 0, 2), &n), 1.5, 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3(0, 0, 1)));
  EXPECT_NEAR(signed_distance(sphere, Transform::Identity(), Vec3(0.1, 0, 0), &n), -0.4, 1e-15);
  const Collider capsule = make(ShapeType::capsule, 0.1, 0.5);
  EXPECT_NEAR(signed_distance(capsule, Transform::Identity(), Vec3(0.3, 0.2, 0), &n), 0.2, 1e-15);
  EXPECT_NEAR(signed_distance(capsule, Transform::Identity(), Vec3(0, 0.9, 0), &n), 0.3, 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3(0, 1, 0)));
  const Collider box = make(ShapeType::box, 0, 0, Vec3(1, 2, 3));
  EXPECT_NEAR(signed_distance(box, Transform::Identity(), Vec3(2, 3, 0), &n), std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(signed_distance(box, Transform::Identity(), Vec3(0.5, 0, 0), &n), -0.5, 1e-15);
  EXPECT_TRUE(n.isApprox(Vec3(1, 0, 0)));
  const Collider cyl = make(ShapeType::cylinder, 0.5, 1.0);
  EXPECT_NEAR(signed_distance(cyl, Transform::Identity(), Vec3(0, 0, 0.2), &n), -0.3, 1e-15);
  EXPECT_NEAR(signed_distance(cyl, Transform::Identity(), Vec3(0, 0.9, 0), &n), -0.1, 1e-15);
  EXPECT_NEAR(signed_distance(cyl, Transform::Identity(), Vec3(1.5, 2.0, 0), &n), std::sqrt(2.0), 1e-15);
}

TEST(ColliderDistance, CylinderAndCapsuleMatchBruteForce) {
  const double r = 0.3, hh = 0.4;
  const std::vector<Vec3> surf = cylinder_surface(r, hh, 300);
  const Collider cyl = make(ShapeType::cylinder, r, hh);
  const Collider cap = make(ShapeType::capsule, r, hh);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 200; ++k) {
    const Vec3 q(u(rng), u(rng), u(rng));
    const double bf =
        brute(surf, q, [&](const Vec3& p) { return std::hypot(p.x(), p.z()) < r && std::abs(p.y()) < hh; });
    EXPECT_NEAR(signed_distance(cyl, Transform::Identity(), q, nullptr), bf, 3e-3) << q.transpose();
    // Capsule: distance to the axis segment minus r (brute force over 4001 axis samples).
    double axis = HUGE_VAL;
    for (int j = 0; j <= 4000; ++j) axis = std::min(axis, (q - Vec3(0, -hh + 2 * hh * j / 4000.0, 0)).norm());
    EXPECT_NEAR(signed_distance(cap, Transform::Identity(), q, nullptr), axis - r, 1e-6);
  }
}

// Normals are the gradient of the distance (central differences away from the medial axis), under a pose.
TEST(ColliderDistance, NormalIsTheGradientUnderAnyPose) {
  std::vector<Collider> shapes = {make(ShapeType::sphere, 0.4), make(ShapeType::capsule, 0.2, 0.3),
                                  make(ShapeType::box, 0, 0, Vec3(0.3, 0.2, 0.1)),
                                  make(ShapeType::cylinder, 0.3, 0.2)};
  const Transform p = pose(Vec3(0.3, -0.2, 0.5), Vec3(1, 2, 3), 0.7);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const Collider& c : shapes)
    for (int k = 0; k < 100; ++k) {
      const Vec3 q = p * Vec3(u(rng), u(rng), u(rng));
      Vec3 n;
      const double d = signed_distance(c, p, q, &n);
      // Same value as the local query.
      EXPECT_NEAR(d, local_signed_distance(c.shape, nullptr, p.inverse() * q, nullptr), 1e-12);
      Vec3 g;
      const double eps = 1e-6;
      for (int a = 0; a < 3; ++a)
        g[a] = (signed_distance(c, p, q + eps * Vec3::Unit(a), nullptr) -
                signed_distance(c, p, q - eps * Vec3::Unit(a), nullptr)) /
               (2 * eps);
      if (std::abs(g.norm() - 1.0) > 1e-4) continue;  // on a medial surface: no gradient
      EXPECT_NEAR((g - n).norm(), 0.0, 1e-5) << shape_type_name(c.shape.type) << " " << q.transpose();
    }
}

// A convex hull of a box's corners (plus interior points Qhull must drop) equals the closed-form box.
TEST(ColliderDistance, ConvexHullMatchesBoxAndBruteForce) {
  Collider hull = make(ShapeType::convex);
  const Vec3 e(0.3, 0.2, 0.1);
  for (int k = 0; k < 8; ++k)
    hull.shape.vertices.emplace_back((k & 1) ? e.x() : -e.x(), (k & 2) ? e.y() : -e.y(),
                                     (k & 4) ? e.z() : -e.z());
  hull.shape.vertices.emplace_back(0.01, 0.02, 0.0);
  hull.shape.vertices.emplace_back(-0.1, 0.0, 0.05);
  prepare_collider(hull);
  ASSERT_TRUE(hull.geometry);
  EXPECT_EQ(hull.geometry->hull_vertices.size(), 8u);
  EXPECT_EQ(hull.geometry->hull_triangles.size(), 12u);
  const Collider box = make(ShapeType::box, 0, 0, e);
  const Transform p = pose(Vec3(1, 2, 3), Vec3(0, 1, 1), 0.4);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  for (int k = 0; k < 300; ++k) {
    const Vec3 q = p * Vec3(u(rng), u(rng), u(rng));
    Vec3 nh, nb;
    const double dh = signed_distance(hull, p, q, &nh), db = signed_distance(box, p, q, &nb);
    EXPECT_NEAR(dh, db, 1e-6) << q.transpose();
    if (std::abs(db) > 1e-3) {
      EXPECT_NEAR(nh.dot(nb), 1.0, 1e-3) << q.transpose();
    }
  }
  // A random hull: outside distances = brute force over the hull's triangles.
  Collider blob = make(ShapeType::convex);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int k = 0; k < 60; ++k) blob.shape.vertices.push_back(Vec3(g(rng), g(rng), g(rng)).normalized() * 0.5);
  prepare_collider(blob);
  const auto& geo = *blob.geometry;
  for (int k = 0; k < 200; ++k) {
    const Vec3 q(2 * u(rng), 2 * u(rng), 2 * u(rng));
    double bf = HUGE_VAL;
    for (const Tri& t : geo.hull_triangles)
      bf = std::min(bf, std::sqrt(point_triangle_closest(q, geo.hull_vertices[t[0]], geo.hull_vertices[t[1]],
                                                         geo.hull_vertices[t[2]])
                                      .distance_squared));
    double inside = -HUGE_VAL;
    for (const auto& pl : geo.hull_planes) inside = std::max(inside, pl.head<3>().dot(q) - pl[3]);
    EXPECT_NEAR(signed_distance(blob, Transform::Identity(), q, nullptr), inside > 0 ? bf : -bf, 1e-6)
        << q.transpose();
  }
}

// A wavy n x n patch of a mesh collider: vertex (i, j) at (i s, a sin(fi i) cos(fj j), j s), prepared.
Collider wavy_mesh(int n, double s, double a, double fi, double fj) {
  Collider mesh = make(ShapeType::mesh);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      mesh.shape.vertices.emplace_back(i * s, a * std::sin(i * fi) * std::cos(j * fj), j * s);
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int k = j * n + i;
      mesh.shape.triangles.push_back({k, k + 1, k + n});
      mesh.shape.triangles.push_back({k + 1, k + n + 1, k + n});
    }
  prepare_collider(mesh);
  return mesh;
}

TEST(ColliderDistance, MeshIsTwoSidedDistanceToNearestTriangle) {
  const Collider mesh = wavy_mesh(12, 0.1, 0.05, 0.7, 0.5);
  const Transform p = pose(Vec3(-0.5, 1.0, 0.2), Vec3(1, 0, 0), 0.3);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.3, 1.4);
  for (int k = 0; k < 200; ++k) {
    const Vec3 ql(u(rng), 0.5 * u(rng) - 0.2, u(rng));
    double bf = HUGE_VAL;
    for (const Tri& t : mesh.shape.triangles)
      bf = std::min(bf, std::sqrt(point_triangle_closest(ql, mesh.shape.vertices[t[0]],
                                                         mesh.shape.vertices[t[1]], mesh.shape.vertices[t[2]])
                                      .distance_squared));
    Vec3 nrm;
    const double d = signed_distance(mesh, p, p * ql, &nrm);
    EXPECT_NEAR(d, bf, 1e-9) << ql.transpose();
    EXPECT_NEAR(nrm.norm(), 1.0, 1e-12);
    // The normal points from the surface to the point: stepping back along it reaches the surface.
    EXPECT_NEAR(signed_distance(mesh, p, p * ql - 0.5 * d * nrm, nullptr), 0.5 * d, 1e-6 + 0.01 * d);
  }
}

// The mesh search is warm-started from the last triangle found (per thread): points next to the surface
// still get the brute-force distance, and the answer (distance and normal) is bit-identical whatever was
// queried before it (forward and reverse order, interleaved with far points).
TEST(ColliderDistance, MeshDistanceDoesNotDependOnQueryOrder) {
  const int n = 20;
  const Collider mesh = wavy_mesh(n, 0.05, 0.04, 0.9, 0.6);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 0.95), off(-1e-3, 1e-3);
  std::vector<Vec3> pts;
  for (int k = 0; k < 300; ++k) {
    // On or within 1 mm of the surface (a random vertex of the wavy patch, moved a little), or far.
    const Vec3& v = mesh.shape.vertices[std::uniform_int_distribution<int>(0, n * n - 1)(rng)];
    pts.push_back(k % 3 == 2 ? Vec3(u(rng), 2.0 * u(rng) - 1.0, u(rng))
                             : Vec3(v + Vec3(off(rng), off(rng), off(rng))));
  }
  std::vector<double> d(pts.size());
  std::vector<Vec3> nrm(pts.size());
  for (size_t k = 0; k < pts.size(); ++k) {
    d[k] = signed_distance(mesh, Transform::Identity(), pts[k], &nrm[k]);
    double bf = HUGE_VAL;
    for (const Tri& t : mesh.shape.triangles)
      bf = std::min(bf, std::sqrt(point_triangle_closest(pts[k], mesh.shape.vertices[t[0]],
                                                         mesh.shape.vertices[t[1]], mesh.shape.vertices[t[2]])
                                      .distance_squared));
    EXPECT_NEAR(d[k], bf, 1e-12) << k;
  }
  for (size_t r = pts.size(); r-- > 0;) {
    Vec3 nr;
    const double dr = signed_distance(mesh, Transform::Identity(), pts[r], &nr);
    EXPECT_EQ(dr, d[r]) << r;
    EXPECT_EQ(nr, nrm[r]) << r;
  }
}

// Swept point against a moving, rotating collider: every path that a dense sampling finds within the
// separation is reported, and no later than the first sampled time.
// Edge contacts against a box: a segment just under the middle of the top face is an end's contact 3 mm
// deep (not a push across the box from its far edge); a segment cutting the box's edge leaves along the
// edge's bisector by its distance to the edge; a segment above the face is at its distance to the nearest
// edge.
TEST(ColliderDistance, SegmentBoxTakesTheShortestWayOut) {
  const Collider box = make(ShapeType::box, 0, 0, Vec3(0.3, 0.1, 0.3));
  const Transform id = Transform::Identity();
  double s = -1.0;
  Vec3 n;
  EXPECT_NEAR(
      segment_box_edges_distance(box, id, Vec3(-0.09, 0.097, -0.157), Vec3(-0.06, 0.0985, -0.157), &s, &n),
      -0.003, 1e-12);
  EXPECT_EQ(s, 0.0);
  EXPECT_NEAR((n - Vec3(0, 1, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(segment_box_edges_distance(box, id, Vec3(0, 0.11, 0.27), Vec3(0, 0.07, 0.31), &s, &n),
              -0.02 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(s, 0.5, 1e-12);
  EXPECT_NEAR((n - Vec3(0, 1, 1).normalized()).norm(), 0.0, 1e-12);
  EXPECT_NEAR(segment_box_edges_distance(box, id, Vec3(-0.05, 0.105, 0), Vec3(0.1, 0.105, 0), &s, &n),
              std::hypot(0.2, 0.005), 1e-12);
  EXPECT_NEAR(s, 1.0, 1e-12);
}

// A cloth edge slid 1.5 cm into a wall 5 mm above the wall's bottom face: the shortest way out is down
// (5 mm), but the edge came from the side, so with its past it leaves sideways, also when the wall moved
// onto it.
TEST(ColliderDistance, SegmentBoxLeavesOnTheSideItCameFrom) {
  const Collider wall = make(ShapeType::box, 0, 0, Vec3(0.05, 0.2, 0.3));
  const Transform id = Transform::Identity();
  const Vec3 a(-0.035, -0.195, 0), b(-0.075, -0.195, 0);
  double s = -1.0;
  Vec3 n;
  EXPECT_NEAR(segment_box_edges_distance(wall, id, a, b, &s, &n), -0.005, 1e-12);
  EXPECT_NEAR((n - Vec3(0, -1, 0)).norm(), 0.0, 1e-12);
  const SegmentPast slid{a - Vec3(0.03, 0, 0), b - Vec3(0.03, 0, 0), id};
  EXPECT_NEAR(segment_box_edges_distance(wall, id, a, b, &s, &n, &slid), -0.015, 1e-12);
  EXPECT_NEAR((n - Vec3(-1, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_EQ(s, 0.0);  // the end inside is the vertex phase's
  Transform before = id;
  before.translation() = Vec3(0.03, 0, 0);
  const SegmentPast wall_moved{a, b, before};
  EXPECT_NEAR(segment_box_edges_distance(wall, id, a, b, &s, &n, &wall_moved), -0.015, 1e-12);
  EXPECT_NEAR((n - Vec3(-1, 0, 0)).norm(), 0.0, 1e-12);
}

// For random segments through a posed box: moving the segment by the returned depth along the returned
// normal takes every point of it out of the box, and that depth is no more than the way out along any face
// normal.
TEST(ColliderDistance, SegmentBoxDepthIsAWayOutAndNoLongerThanAFaceNormal) {
  const Collider box = make(ShapeType::box, 0, 0, Vec3(0.3, 0.1, 0.2));
  const Transform p = pose(Vec3(0.1, -0.2, 0.3), Vec3(1, 2, 3), 0.7);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  int through = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Vec3 a = p * Vec3(u(rng), u(rng), u(rng)), b = p * Vec3(u(rng), u(rng), u(rng));
    double s = 0.0;
    Vec3 n;
    const double d = segment_box_edges_distance(box, p, a, b, &s, &n);
    double deepest = HUGE_VAL;
    for (int k = 0; k <= 100; ++k)
      deepest = std::min(deepest, signed_distance(box, p, a + k / 100.0 * (b - a), nullptr));
    if (deepest >= 0.0) continue;
    ++through;
    ASSERT_LT(d, 0.0) << trial;
    EXPECT_NEAR(n.norm(), 1.0, 1e-12);
    for (int k = 0; k <= 100; ++k)
      EXPECT_GT(signed_distance(box, p, a + k / 100.0 * (b - a) - (d - 1e-9) * n, nullptr), -1e-9) << trial;
    const Vec3 A = p.inverse(Eigen::Isometry) * a, B = p.inverse(Eigen::Isometry) * b;
    for (int axis = 0; axis < 3; ++axis) {
      const double e = box.shape.half_extents[axis];
      const double face = std::min(e - std::min(A[axis], B[axis]), std::max(A[axis], B[axis]) + e);
      EXPECT_LE(-d, face + 1e-12) << trial;
    }
  }
  EXPECT_GT(through, 500);
}

TEST(SweptCollider, NoFalseNegativesAgainstDenseSampling) {
  std::vector<Collider> shapes = {make(ShapeType::sphere, 0.2), make(ShapeType::capsule, 0.05, 0.3),
                                  make(ShapeType::box, 0, 0, Vec3(0.3, 0.02, 0.2)),
                                  make(ShapeType::cylinder, 0.1, 0.3)};
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int positives = 0;
  for (Collider c : shapes)
    for (int k = 0; k < 300; ++k) {
      c.prev = pose(0.3 * Vec3(u(rng), u(rng), u(rng)), Vec3(u(rng), u(rng), u(rng)), 0.5 * u(rng));
      c.curr = pose(c.prev.translation() + 0.3 * Vec3(u(rng), u(rng), u(rng)), Vec3(u(rng), u(rng), u(rng)),
                    0.8 * u(rng));
      const Vec3 p0 = 0.8 * Vec3(u(rng), u(rng), u(rng)), p1 = 0.8 * Vec3(u(rng), u(rng), u(rng));
      const double sep = 0.002;
      const SweptHit hit = swept_point(c, p0, p1, sep);
      double first = -1.0;
      for (int j = 0; j <= 2000; ++j) {
        const double t = j / 2000.0;
        const Transform T = interpolate_pose(c.prev, c.curr, t);
        if (signed_distance(c, T, (1 - t) * p0 + t * p1, nullptr) <= sep) {
          first = t;
          break;
        }
      }
      if (first >= 0.0) {
        ++positives;
        ASSERT_TRUE(hit.hit) << shape_type_name(c.shape.type) << " k=" << k;
        EXPECT_LE(hit.toi, first + 1e-12);
      }
      if (hit.hit) {  // a reported contact is real up to the slack (1.1 x separation)
        const Transform T = interpolate_pose(c.prev, c.curr, hit.toi);
        EXPECT_LE(signed_distance(c, T, (1 - hit.toi) * p0 + hit.toi * p1, nullptr), 1.1 * sep + 1e-12);
      }
    }
  EXPECT_GT(positives, 50);
}

// A vertex that jumps clean through a thin plate in one step (both ends outside) is caught.
TEST(SweptCollider, ThinPlateDoesNotTunnel) {
  Collider plate = make(ShapeType::box, 0, 0, Vec3(1, 0.001, 1));
  const SweptHit hit = swept_point(plate, Vec3(0.1, 0.5, 0.2), Vec3(0.1, -0.5, 0.2), 0.0005);
  ASSERT_TRUE(hit.hit);
  EXPECT_NEAR(hit.toi, 0.4985, 1e-3);
  EXPECT_GT(hit.local.y(), 0.0);  // touched from above
  // A capsule moving at 30 m/s (0.5 m in a 1/60 s step) through a resting vertex.
  Collider cap = make(ShapeType::capsule, 0.03, 0.2);
  cap.prev = pose(Vec3(0, 0, -0.25), Vec3(0, 0, 1), M_PI / 2);
  cap.curr = pose(Vec3(0, 0, 0.25), Vec3(0, 0, 1), M_PI / 2);
  const SweptHit h2 = swept_point(cap, Vec3(0.05, 0.0, 0.0), Vec3(0.05, 0.0, 0.0), 0.001);
  ASSERT_TRUE(h2.hit);
  EXPECT_GT(h2.local.z(), 0.0);  // met by the capsule's front (ahead of its centre)
  // Edge vs capsule axis: the capsule passes between the two end vertices of a long edge.
  const SweptSegmentHit e = swept_segment_capsule(cap, Vec3(-0.5, 0.0, 0.0), Vec3(0.5, 0.0, 0.0),
                                                  Vec3(-0.5, 0.0, 0.0), Vec3(0.5, 0.0, 0.0), 0.001);
  ASSERT_TRUE(e.hit);
  EXPECT_NEAR(e.toi, (0.25 - 0.031) / 0.5, 2e-3);
}

}  // namespace
}  // namespace loom::collision
