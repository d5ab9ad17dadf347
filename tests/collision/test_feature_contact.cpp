// FeatureContactStage's face phase (collider features against cloth triangles): where it acts with and
// without its slack, and its settings refused when out of range.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <utility>

#include "BodyContactTestUtil.h"
#include "SymplecticSetup.h"
#include "loom/cloth/Error.h"
#include "loom/collision/FeatureContact.h"

namespace loom::collision {
namespace {

using namespace loom::collision::test;

// One step of a face-only stage: a 2 x 2 node sheet (two 0.4 m triangles, y = 0) over a 2 cm sphere whose
// centre lies under the first triangle's centroid, `gap` (m) nearer than radius + thickness. Returns the
// height of the triangle's point over the centre after the step minus the radius (its clearance) and the
// face contacts.
std::pair<double, double> face_step(double gap, double slack) {
  SimulationSetup s = loom::test::symplectic_setup();
  s.cloths.push_back(sheet(2, 0.4, cloth::GridPlane::kXZ, Vec3(-0.2, 0.0, -0.2)));
  Simulation sim(s);
  cloth::Cloth& cl = *sim.cloths()[0];
  cl.state().x_prev = cl.state().x;
  const double thickness = cl.material().thickness;
  const cloth::Tri& t = cl.mesh().triangles()[0];
  const Vec3 centroid = (cl.state().x[t[0]] + cl.state().x[t[1]] + cl.state().x[t[2]]) / 3.0;
  auto set = std::make_shared<ColliderSet>();
  set->push_back(shape(ShapeType::sphere, 0.02));
  set->back().prev = set->back().curr = at(centroid - Vec3(0, 0.02 + thickness - gap, 0));
  FeatureContactSettings fs;
  fs.vertices = false;
  fs.iterations = 1;
  fs.face_slack = slack;
  FeatureContactStage stage(set, fs);
  cloth::StageContext ctx{sim.cloths(), 0.0, 1.0 / 240.0, 1};
  stage.run(ctx);
  // The triangle's point over the centre (the centroid: the correction is vertical, so x and z stay).
  const auto& x = cl.state().x;
  const double height = (x[t[0]].y() + x[t[1]].y() + x[t[2]].y()) / 3.0 - set->back().curr.translation().y();
  double contacts = 0.0;
  for (const auto& [k, v] : stage.counters())
    if (k == "face_contacts") contacts = v;
  return {height - 0.02, contacts};
}

TEST(FeatureContact, FaceSlackActsOnlyPastItsShareOfTheThickness) {
  const double thickness = cloth::material_preset("cotton").thickness;
  // 0.3 thickness inside the reach: slack 0 pushes the triangle back to the thickness, slack 0.5 leaves it.
  auto [c0, n0] = face_step(0.3 * thickness, 0.0);
  EXPECT_EQ(n0, 1.0);
  EXPECT_NEAR(c0, thickness, 1e-9);
  auto [c1, n1] = face_step(0.3 * thickness, 0.5);
  EXPECT_EQ(n1, 0.0);
  EXPECT_NEAR(c1, 0.7 * thickness, 1e-9);
  // 0.7 thickness inside: both act and push it to the full thickness.
  auto [c2, n2] = face_step(0.7 * thickness, 0.5);
  EXPECT_EQ(n2, 1.0);
  EXPECT_NEAR(c2, thickness, 1e-9);
}

TEST(FeatureContact, FaceSlackOutOfRangeRefusedNamingTheField) {
  for (double bad : {-0.1, 1.0, std::nan("")}) {
    FeatureContactSettings fs;
    fs.face_slack = bad;
    try {
      FeatureContactStage stage(std::make_shared<ColliderSet>(), fs);
      ADD_FAILURE() << "accepted face_slack " << bad;
    } catch (const loom::Error& e) {
      EXPECT_NE(std::string(e.what()).find("face_slack"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace loom::collision
