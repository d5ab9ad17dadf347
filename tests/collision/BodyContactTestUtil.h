#pragma once
// Shared by the body-contact tests (BodyCollisionStage, RealtimeBodyContactStage): a stage that runs a check
// after every step, sheets, collider shapes and poses, and the worst signed gap over free vertices.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "loom/cloth/Simulation.h"
#include "loom/collision/ColliderDistance.h"

namespace loom::collision::test {

using cloth::Simulation;
using cloth::SimulationSetup;

// A stage that runs a check after every step (appended after body_collision).
class CheckStage final : public cloth::Stage {
 public:
  explicit CheckStage(std::function<void(cloth::StageContext&)> f) : f_(std::move(f)) {}
  const char* name() const override { return "check"; }
  void run(cloth::StageContext& ctx) override { f_(ctx); }

 private:
  std::function<void(cloth::StageContext&)> f_;
};

inline cloth::ClothSetup sheet(int n, double size, cloth::GridPlane plane, const Vec3& origin) {
  cloth::ClothSetup c;
  cloth::GridSpec g;
  g.nodes_u = g.nodes_v = n;
  g.size_u = g.size_v = size;
  g.plane = plane;
  g.origin = origin;
  c.mesh = cloth::ClothMesh::grid(g);
  c.material = cloth::material_preset("cotton");
  c.material.areal_density = 0.2;
  return c;
}

inline Collider shape(ShapeType type, double radius = 0, double half_height = 0, Vec3 he = Vec3::Zero()) {
  Collider c;
  c.shape.type = type;
  c.shape.radius = radius;
  c.shape.half_height = half_height;
  c.shape.half_extents = he;
  return c;
}

inline Transform at(const Vec3& p, double angle_z = 0.0) {
  Transform t = Transform::Identity();
  t.linear() = Eigen::AngleAxisd(angle_z, Vec3::UnitZ()).toRotationMatrix();
  t.translation() = p;
  return t;
}

// Worst (most negative) signed distance minus thickness over free vertices; fails the test on NaN.
inline double worst_gap(const cloth::ClothState& s, const ColliderSet& set, double thickness) {
  double worst = HUGE_VAL;
  for (int i = 0; i < s.size(); ++i) {
    EXPECT_TRUE(s.x[i].allFinite());
    if (s.inv_mass[i] == 0.0) continue;
    for (const Collider& c : set)
      worst = std::min(worst, signed_distance(c, c.curr, s.x[i], nullptr) - thickness);
  }
  return worst;
}

}  // namespace loom::collision::test
