// A 1 m cloth tied at its four corners in a btDiscreteDynamicsWorld, with a 10 cm ball dropped on it.
// Draws nothing: it checks its own result and exits 0 when every cloth position is finite and the ball
// rests on the cloth (above it, not through it).
#include <btBulletDynamicsCommon.h>

#include <cmath>
#include <cstdio>
#include <memory>

#include "loom/bullet/BulletCloth.h"
#include "loom/cloth/ClothMesh.h"

int main() {
  using namespace loom;
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  world.setGravity(btVector3(0, -9.81f, 0));

  // The cloth: a 21 x 21 grid of cotton, 1 m square at 1 m height, its corners pinned in place.
  cloth::SimulationSetup setup;
  cloth::ClothSetup sheet;
  cloth::GridSpec grid;
  grid.nodes_u = grid.nodes_v = 21;
  grid.origin = cloth::Vec3(-0.5, 1.0, -0.5);
  sheet.mesh = cloth::ClothMesh::grid(grid);
  sheet.material = cloth::material_preset("cotton");
  for (int corner : {0, 20, 420, 440}) sheet.pins.push_back(cloth::PinSpec{corner, {}, {}, {}});
  setup.cloths.push_back(sheet);
  // The bridge's defaults: the real-time tier (cloth and nearby bodies solved together in small XPBD steps).
  bullet::BulletCloth cloth(setup, bullet::BulletClothSettings{});
  cloth.add_to(&world);

  // The ball: 10 cm radius, 0.5 kg, dropped from 1.5 m onto the middle of the cloth.
  btSphereShape ball_shape(0.1f);
  btVector3 inertia;
  ball_shape.calculateLocalInertia(0.5f, inertia);
  btDefaultMotionState ball_motion(btTransform(btQuaternion::getIdentity(), btVector3(0.05f, 1.5f, 0.0f)));
  btRigidBody ball(btRigidBody::btRigidBodyConstructionInfo(0.5f, &ball_motion, &ball_shape, inertia));
  world.addRigidBody(&ball);

  for (int frame = 0; frame < 120; ++frame) world.stepSimulation(1.0f / 60.0f, 10, 1.0f / 240.0f);

  bool finite = true;
  for (const cloth::Vec3& p : cloth.simulation().cloths()[0]->state().x) finite = finite && p.allFinite();
  const btVector3 c = ball.getCenterOfMassPosition();
  const cloth::Vec3 centre(c.x(), c.y(), c.z());
  // The cloth must lie below the ball's centre: a ray straight down from it hits the cloth.
  const bullet::RayHit below = cloth.ray_test(centre, centre - cloth::Vec3(0, 2, 0));
  std::printf("bullet_world: ball at y = %.3f m, cloth %s below it, positions %s\n", centre.y(),
              below.hit ? "found" : "NOT found", finite ? "finite" : "NOT finite");
  world.removeRigidBody(&ball);
  cloth.remove_from(&world);
  return finite && below.hit && centre.y() > 0.3 ? 0 : 1;
}
