// Collider tessellation (ColliderMesh.h): every vertex lies on the shape's surface (the collision code's
// own signed distance is 0 there), vertex normals are the surface's outward normals, triangles wind
// outward (the enclosed volume is positive and converges to the solid's volume), closed shapes have no
// open edge, and a pose moves vertices and turns normals.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <utility>

#include "loom/collision/ColliderDistance.h"
#include "loom/collision/ColliderGeometry.h"
#include "loom/collision/ColliderMesh.h"

namespace lc = loom::collision;
using lc::Vec3;

namespace {

constexpr double kPi = 3.14159265358979323846;

lc::Shape shape(lc::ShapeType type) {
  lc::Shape s;
  s.type = type;
  s.radius = 0.3;
  s.half_height = 0.5;
  s.half_extents = Vec3(0.4, 0.2, 0.7);
  // An irregular convex point cloud: an octahedron with extra points inside and a few on top.
  s.vertices = {Vec3(1, 0, 0),       Vec3(-0.8, 0, 0),    Vec3(0, 1.2, 0),
                Vec3(0, -0.5, 0),    Vec3(0, 0, 0.9),     Vec3(0, 0, -1),
                Vec3(0.1, 0.1, 0.1), Vec3(0.2, 0.5, 0.2), Vec3(-0.2, -0.1, 0.3)};
  return s;
}

// Signed volume enclosed by the triangles (divergence theorem); positive when they wind outward.
double volume(const lc::ColliderMesh& m) {
  double v = 0.0;
  for (const auto& t : m.triangles) v += m.vertices[t[0]].dot(m.vertices[t[1]].cross(m.vertices[t[2]])) / 6.0;
  return v;
}

// Closed surface: every edge, keyed by its end positions (the seams duplicate vertices), is used once in
// each direction.
bool closed(const lc::ColliderMesh& m) {
  auto key = [&](int i) { return std::make_tuple(m.vertices[i].x(), m.vertices[i].y(), m.vertices[i].z()); };
  std::map<std::pair<std::tuple<double, double, double>, std::tuple<double, double, double>>, int> count;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) {
      const auto a = key(t[k]), b = key(t[(k + 1) % 3]);
      if (a == b) return false;  // degenerate triangle
      ++count[{a, b}];
    }
  for (const auto& [e, n] : count) {
    const auto it = count.find({e.second, e.first});
    if (n != 1 || it == count.end() || it->second != 1) return false;
  }
  return true;
}

}  // namespace

TEST(ColliderMesh, VerticesOnTheSurfaceWithOutwardNormalsAndWinding) {
  const lc::ShapeType types[] = {lc::ShapeType::sphere, lc::ShapeType::capsule, lc::ShapeType::cylinder,
                                 lc::ShapeType::box, lc::ShapeType::convex};
  for (lc::ShapeType type : types) {
    const lc::Shape s = shape(type);
    const auto geometry = lc::build_collider_geometry(s);
    const lc::ColliderMesh m = lc::tessellate(s, geometry.get());
    SCOPED_TRACE(lc::shape_type_name(type));
    ASSERT_EQ(m.vertices.size(), m.normals.size());
    ASSERT_GT(m.triangles.size(), 4u);
    for (size_t i = 0; i < m.vertices.size(); ++i) {
      Vec3 n;
      double d = 0.0;
      if (type == lc::ShapeType::convex) {
        // On the hull: the largest face-plane distance is 0 (GJK is not asked about points on the surface).
        d = -1e300;
        for (const Eigen::Vector4d& pl : geometry->hull_planes) {
          const double di = pl.head<3>().dot(m.vertices[i]) - pl[3];
          if (di > d) d = di, n = pl.head<3>();
        }
      } else {
        d = lc::local_signed_distance(s, geometry.get(), m.vertices[i], &n);
      }
      ASSERT_NEAR(d, 0.0, 1e-12) << "vertex " << i << " at " << m.vertices[i].transpose();
      EXPECT_NEAR(m.normals[i].norm(), 1.0, 1e-12);
      // On smooth parts the normal is the distance gradient; on edges and corners (box, cylinder rim,
      // hull) the gradient is one of the adjacent faces' normals, so the vertex normal is within 90°.
      if (type == lc::ShapeType::sphere || type == lc::ShapeType::capsule) {
        EXPECT_GT(m.normals[i].dot(n), 1.0 - 1e-9);
      } else if (type == lc::ShapeType::convex) {  // the vertex normal's plane supports the hull
        for (const Vec3& p : geometry->hull_vertices) EXPECT_LE(m.normals[i].dot(p - m.vertices[i]), 1e-12);
      } else {
        EXPECT_GE(m.normals[i].dot(n), -1e-12);
      }
    }
    for (const auto& t : m.triangles) {  // geometric normal agrees with the vertex normals
      const Vec3 g = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
      for (int k = 0; k < 3; ++k) EXPECT_GT(g.dot(m.normals[t[k]]), 0.0);
    }
    EXPECT_TRUE(closed(m));
  }
}

TEST(ColliderMesh, VolumesConvergeToTheSolids) {
  const double r = 0.3, hh = 0.5;
  const double sphere = 4.0 / 3.0 * kPi * r * r * r, capsule = sphere + kPi * r * r * 2 * hh,
               cylinder = kPi * r * r * 2 * hh;
  struct Case {
    lc::ShapeType type;
    double exact;
  };
  for (const Case& c : {Case{lc::ShapeType::sphere, sphere}, Case{lc::ShapeType::capsule, capsule},
                        Case{lc::ShapeType::cylinder, cylinder}}) {
    SCOPED_TRACE(lc::shape_type_name(c.type));
    // Inscribed polyhedra: below the solid, error falling like segments^-2.
    const double e16 = c.exact - volume(lc::tessellate(shape(c.type), nullptr, {16, 1.0}));
    const double e64 = c.exact - volume(lc::tessellate(shape(c.type), nullptr, {64, 1.0}));
    EXPECT_GT(e16, 0.0);
    EXPECT_GT(e64, 0.0);
    EXPECT_LT(e16 / c.exact, 0.07);
    EXPECT_LT(e64, e16 / 10.0);
  }
  EXPECT_NEAR(volume(lc::tessellate(shape(lc::ShapeType::box))), 8 * 0.4 * 0.2 * 0.7, 1e-15);
  // The hull of the octahedron's six points (the inner points add nothing): 1/6 |x-span| |y-span| |z-span| *
  // 8 / 8.
  EXPECT_NEAR(volume(lc::tessellate(shape(lc::ShapeType::convex))), (1.8 * 1.7 * 1.9) / 6.0, 1e-12);
}

TEST(ColliderMesh, PlaneSquareMeshCopyAndPose) {
  lc::Shape plane = shape(lc::ShapeType::plane);
  const lc::ColliderMesh p = lc::tessellate(plane, nullptr, {32, 3.0});
  ASSERT_EQ(p.vertices.size(), 4u);
  for (const Vec3& v : p.vertices) {
    EXPECT_EQ(v.y(), 0.0);
    EXPECT_EQ(std::abs(v.x()), 3.0);
  }
  for (const auto& t : p.triangles)
    EXPECT_GT((p.vertices[t[1]] - p.vertices[t[0]]).cross(p.vertices[t[2]] - p.vertices[t[0]]).y(), 0.0);

  lc::Shape mesh;
  mesh.type = lc::ShapeType::mesh;
  mesh.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 0, -1)};
  mesh.triangles = {{0, 1, 2}};
  const lc::ColliderMesh m = lc::tessellate(mesh);
  EXPECT_EQ(m.vertices, mesh.vertices);
  EXPECT_EQ(m.triangles, mesh.triangles);
  for (const Vec3& n : m.normals) EXPECT_NEAR((n - Vec3(0, 1, 0)).norm(), 0.0, 1e-15);

  // A posed capsule: vertices on the capsule at that pose, normals turned with it.
  lc::Collider c;
  c.shape = shape(lc::ShapeType::capsule);
  c.curr = lc::Transform(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  c.curr.translation() = Vec3(0.5, 1.0, -2.0);
  const lc::ColliderMesh local = lc::tessellate(c.shape);
  const lc::ColliderMesh world = lc::transformed(local, c.curr);
  for (size_t i = 0; i < world.vertices.size(); ++i) {
    Vec3 n;
    EXPECT_NEAR(lc::signed_distance(c, c.curr, world.vertices[i], &n), 0.0, 1e-12);
    EXPECT_NEAR(world.normals[i].dot(n), 1.0, 1e-9);
  }
}
