#include "loom/bullet/Compare.h"

#include <btBulletDynamicsCommon.h>
#include <BulletSoftBody/btSoftBody.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>

#include <chrono>
#include <cmath>
#include <memory>

#include "BulletConvert.h"
#include "ShapeDistance.h"
#include "TwinAccess.h"
#include "loom/bullet/BulletCloth.h"
#include "loom/cloth/Error.h"

namespace loom::bullet {

namespace {

using collision::RigidBodySpec;
using collision::ShapeType;
using Clock = std::chrono::steady_clock;

// Rigid bodies of a scene inside one world; removed before the world goes.
struct Bodies {
  btDiscreteDynamicsWorld* world = nullptr;
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btDefaultMotionState>> states;
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  const std::vector<RigidBodySpec>* specs = nullptr;

  Bodies(btDiscreteDynamicsWorld* w, const std::vector<RigidBodySpec>& s) : world(w), specs(&s) {
    for (const RigidBodySpec& b : s) {
      std::unique_ptr<btCollisionShape> shape;
      switch (b.shape.type) {
        case ShapeType::plane: shape = std::make_unique<btStaticPlaneShape>(btVector3(0, 1, 0), 0); break;
        case ShapeType::sphere: shape = std::make_unique<btSphereShape>(btScalar(b.shape.radius)); break;
        case ShapeType::capsule:
          shape = std::make_unique<btCapsuleShape>(btScalar(b.shape.radius), btScalar(2 * b.shape.half_height));
          break;
        case ShapeType::box: shape = std::make_unique<btBoxShape>(to_bt(b.shape.half_extents)); break;
        case ShapeType::cylinder:
          shape = std::make_unique<btCylinderShape>(
              btVector3(btScalar(b.shape.radius), btScalar(b.shape.half_height), btScalar(b.shape.radius)));
          break;
        default: throw Error("", "bodies", b.name + ": shape not supported for rigid bodies");
      }
      const bool kinematic = static_cast<bool>(b.motion);
      const btTransform start = to_bt(kinematic ? b.motion(0.0) : b.pose);
      states.push_back(std::make_unique<btDefaultMotionState>(start));
      btVector3 inertia(0, 0, 0);
      if (b.mass > 0) shape->calculateLocalInertia(btScalar(b.mass), inertia);
      btRigidBody::btRigidBodyConstructionInfo info(btScalar(b.mass), states.back().get(), shape.get(), inertia);
      info.m_friction = btScalar(b.friction);
      info.m_restitution = btScalar(b.restitution);
      auto body = std::make_unique<btRigidBody>(info);
      if (kinematic) {
        body->setCollisionFlags(body->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
        body->setActivationState(DISABLE_DEACTIVATION);
      }
      if (b.mass > 0) {
        body->setLinearVelocity(to_bt(b.velocity));
        body->setAngularVelocity(to_bt(b.angular_velocity));
      }
      world->addRigidBody(body.get());
      shapes.push_back(std::move(shape));
      bodies.push_back(std::move(body));
    }
  }
  ~Bodies() {
    for (auto& b : bodies) world->removeRigidBody(b.get());
  }
  // Kinematic targets for the end of the frame that ends at time t.
  void drive(double t) {
    for (size_t k = 0; k < bodies.size(); ++k)
      if ((*specs)[k].motion) bodies[k]->getMotionState()->setWorldTransform(to_bt((*specs)[k].motion(t)));
  }
  // Deepest vertex inside any body (m, >= 0).
  double penetration(const cloth::Vec3s& x) const {
    double worst = 0.0;
    for (size_t k = 0; k < bodies.size(); ++k) {
      collision::Transform pose = to_eigen(bodies[k]->getWorldTransform());
      for (const Vec3& p : x) worst = std::max(worst, -shape_signed_distance((*specs)[k].shape, nullptr, pose, p, nullptr));
    }
    return worst;
  }
};

// Strain over structural springs: max (l/L - 1, 0) and mean |l/L - 1|.
void strain(const cloth::ClothMesh& mesh, const cloth::Vec3s& x, double& max_s, double& mean_s) {
  max_s = 0.0;
  double sum = 0.0;
  int n = 0;
  for (const auto& s : mesh.springs()) {
    if (s.kind != cloth::SpringKind::kStructural) continue;
    const double r = (mesh.rest_positions()[s.i] - mesh.rest_positions()[s.j]).norm();
    const double e = (x[s.i] - x[s.j]).norm() / r - 1.0;
    max_s = std::max(max_s, e);
    sum += std::abs(e);
    ++n;
  }
  mean_s = n ? sum / n : 0.0;
}

struct Tally {
  double max_strain = 0.0, mean_sum = 0.0, pen = 0.0, ms = 0.0;
  bool diverged = false;
  int frames = 0;
  void add(const cloth::ClothMesh& mesh, const cloth::Vec3s& x, double pen_now, double ms_now) {
    double mx = 0.0, mn = 0.0;
    bool finite = true;
    for (const Vec3& p : x) finite &= p.allFinite();
    strain(mesh, x, mx, mn);
    if (!finite || !std::isfinite(mx) || mx > 10.0) diverged = true;
    max_strain = std::max(max_strain, std::isfinite(mx) ? mx : HUGE_VAL);
    mean_sum += mn;
    pen = std::max(pen, pen_now);
    ms += ms_now;
    ++frames;
  }
  void fill(SystemMetrics& m, const cloth::Vec3s& x) const {
    m.ms_per_frame = frames ? ms / frames : 0.0;
    m.max_strain = max_strain;
    m.mean_strain = frames ? mean_sum / frames : 0.0;
    m.max_penetration = pen;
    m.diverged = diverged;
    for (const Vec3& p : x) m.final_positions.insert(m.final_positions.end(), {p.x(), p.y(), p.z()});
  }
};

}  // namespace

SystemMetrics run_loom_in_bullet(const CompareInput& in) {
  SystemMetrics m;
  m.system = "loom";
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  world.setGravity(to_bt(in.setup.gravity));
  Bodies bodies(&world, in.bodies);
  BulletClothSettings s;
  s.fixed_dt = in.setup.frame_dt / in.bullet_substeps;
  s.cloth_substeps = std::max(1, (in.setup.substeps + in.bullet_substeps - 1) / in.bullet_substeps);
  BulletCloth cloth(in.setup, s);
  for (size_t k = 0; k < in.bodies.size(); ++k)
    for (const collision::BodyAttachment& a : in.bodies[k].attachments) cloth.attach(a.cloth, a.vertex, bodies.bodies[k].get());
  cloth.add_to(&world);
  const cloth::Cloth& c0 = *cloth.simulation().cloths()[0];
  Tally tally;
  for (int f = 1; f <= in.frames; ++f) {
    const auto t0 = Clock::now();
    bodies.drive(f * in.setup.frame_dt);
    world.stepSimulation(btScalar(in.setup.frame_dt), in.bullet_substeps + 1, btScalar(s.fixed_dt));
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    tally.add(c0.mesh(), c0.state().x, bodies.penetration(c0.state().x), ms);
    if (tally.diverged) break;
  }
  tally.fill(m, c0.state().x);
  cloth.remove_from(&world);
  if (!cloth.warnings().empty()) m.note = "unsupported shapes: " + cloth.warnings()[0];
  return m;
}

SystemMetrics run_bullet_twin(const CompareInput& in, TwinKind kind) {
  SystemMetrics m;
  m.system = system_name(kind);
  if (kind == TwinKind::kDeformable && !in.bodies.empty()) {
    m.available = false;
    m.note = "the deformable twin is not coupled to rigid bodies here (reference/bullet.md §3: it produced "
             "NaN nodes against a rigid sphere)";
    return m;
  }
  cloth::SimulationSetup one = in.setup;
  one.cloths.resize(1);
  cloth::Simulation sim(one);
  TwinSettings ts;
  ts.frame_dt = in.setup.frame_dt;
  ts.substeps = in.bullet_substeps;
  BulletTwin twin(kind, make_twin_cloth(*sim.cloths()[0], in.setup.gravity), ts);
  btDiscreteDynamicsWorld* world = TwinAccess::world(twin);
  btSoftBody* body = TwinAccess::body(twin);
  if (kind == TwinKind::kClassic) {
    // bullet.md §3: the settings under which the classic soft body collides accurately at all.
    body->getCollisionShape()->setMargin(btScalar(std::max(0.005, in.setup.cloths[0].material.thickness)));
    body->m_cfg.kKHR = 1;
    body->m_cfg.kCHR = 1;
    TwinAccess::info(twin)->m_sparsesdf.setDefaultVoxelsz(0.05);
    TwinAccess::info(twin)->m_sparsesdf.Reset();
  }
  Bodies bodies(world, in.bodies);
  for (size_t k = 0; k < in.bodies.size(); ++k)
    for (const collision::BodyAttachment& a : in.bodies[k].attachments)
      if (a.cloth == 0) body->appendAnchor(a.vertex, bodies.bodies[k].get(), false, 1);
  const cloth::ClothMesh& mesh = sim.cloths()[0]->mesh();
  Tally tally;
  cloth::Vec3s x;
  for (int f = 1; f <= in.frames; ++f) {
    const auto t0 = Clock::now();
    bodies.drive(f * in.setup.frame_dt);
    twin.step_frame();
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    twin.positions(x);
    tally.add(mesh, x, bodies.penetration(x), ms);
    if (!twin.simulating()) tally.diverged = true;
    if (tally.diverged) break;
  }
  tally.fill(m, x);
  return m;
}

}  // namespace loom::bullet
