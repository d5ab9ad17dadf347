// The bodies-through criterion of ClothSide.h on synthetic motions: a 1 m curtain in the xy plane hanging
// from its top edge (y = 1) swings about that edge; a body centre passing through its middle meets the
// surface, one passing under its raised hem does not (though its side by a ray along the rest normal
// changes: the criterion ClothSide.h used before).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "ClothSide.h"

namespace loom::test {
namespace {

using cloth::Vec3;

constexpr int kN = 9;

std::shared_ptr<const cloth::ClothMesh> curtain_mesh() {
  cloth::GridSpec g;
  g.nodes_u = g.nodes_v = kN;
  g.size_u = g.size_v = 1.0;
  g.plane = cloth::GridPlane::kXY;
  g.origin = Vec3(-0.5, 0.0, 0.0);
  return cloth::ClothMesh::grid(g);
}

// The curtain's vertices swung by `angle` (rad) about its top edge, the hem moving towards +z.
cloth::Vec3s swung(const cloth::ClothMesh& m, double angle) {
  cloth::Vec3s x = m.rest_positions();
  for (Vec3& p : x) {
    const double r = 1.0 - p.y();  // m, distance from the top edge
    p = Vec3(p.x(), 1.0 - r * std::cos(angle), r * std::sin(angle));
  }
  return x;
}

// Crossings of the ray from -> from + 10 dir with the triangles (Moller and Trumbore 1997); the side is
// this mod 2.
int ray_crossings(const cloth::ClothMesh& m, const cloth::Vec3s& x, const Vec3& from, const Vec3& dir) {
  int k = 0;
  for (const cloth::Tri& t : m.triangles()) {
    const Vec3 e1 = x[t[1]] - x[t[0]], e2 = x[t[2]] - x[t[0]];
    const Vec3 p = dir.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-12) continue;
    const Vec3 s = from - x[t[0]];
    const double u = s.dot(p) / det;
    const Vec3 q = s.cross(e1);
    const double v = dir.dot(q) / det, d = e2.dot(q) / det;
    if (u >= 0 && v >= 0 && u + v <= 1 && d >= 0 && d <= 10.0) ++k;
  }
  return k;
}

TEST(ClothSide, CentreThroughTheMiddleMeetsTheSurface) {
  const auto mesh = curtain_mesh();
  const cloth::ClothMesh& m = *mesh;
  const cloth::Vec3s rest = m.rest_positions();
  // Straight through a hanging curtain, and through one swinging from 0 to 30 degrees.
  EXPECT_TRUE(centre_meets_cloth(m, rest, rest, Vec3(0.03, 0.51, -0.3), Vec3(0.03, 0.51, 0.3)));
  EXPECT_TRUE(centre_meets_cloth(m, rest, swung(m, M_PI / 6), Vec3(0.03, 0.51, -0.3), Vec3(0.03, 0.51, 0.6)));
  // Beside it, and stopping short of it: no.
  EXPECT_FALSE(centre_meets_cloth(m, rest, rest, Vec3(0.7, 0.51, -0.3), Vec3(0.7, 0.51, 0.3)));
  EXPECT_FALSE(centre_meets_cloth(m, rest, rest, Vec3(0.03, 0.51, -0.3), Vec3(0.03, 0.51, -0.05)));
}

TEST(ClothSide, CentreUnderASwungHemDoesNotMeetTheSurface) {
  const auto mesh = curtain_mesh();
  const cloth::ClothMesh& m = *mesh;
  const cloth::Vec3s rest = m.rest_positions(), up = swung(m, 80.0 * M_PI / 180.0);
  const Vec3 a(0.03, 0.47, -0.3), b(0.03, 0.47, 0.5), n(0, 0, 1);
  // The curtain swings up to 80 degrees (hem at y = 0.83) while the body waits in front of it; then the
  // body moves under the hem to the far side.
  EXPECT_FALSE(centre_meets_cloth(m, rest, up, a, a));
  EXPECT_FALSE(centre_meets_cloth(m, up, up, a, b));
  // Its side by a ray along the rest normal changed all the same: the ray from a hits the curtain hanging,
  // the ray from b passes under the raised hem.
  EXPECT_EQ(ray_crossings(m, rest, a, n) % 2, 1);
  EXPECT_EQ(ray_crossings(m, up, b, n) % 2, 0);
}

}  // namespace
}  // namespace loom::test
