#include "loom/bullet/Compare.h"

#include <BulletSoftBody/btSoftBody.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <btBulletDynamicsCommon.h>

#include <chrono>
#include <cmath>
#include <memory>

#include "BulletConvert.h"
#include "ShapeDistance.h"
#include "TwinAccess.h"
#include "loom/bullet/RigidBodies.h"
#include "loom/cloth/Error.h"

namespace loom::bullet {

namespace {

using collision::RigidBodySpec;
using Clock = std::chrono::steady_clock;

// Rigid bodies of a scene inside one world (RigidBodies.h), driven and measured per frame.
struct Bodies {
  RigidBodies rigid;
  std::vector<std::unique_ptr<btRigidBody>>& bodies = rigid.bodies;
  const std::vector<RigidBodySpec>* specs = nullptr;

  Bodies(btDiscreteDynamicsWorld* w, const std::vector<RigidBodySpec>& s) : rigid(*w), specs(&s) {
    for (size_t k = 0; k < s.size(); ++k) rigid.add(s[k], k);
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
      for (const Vec3& p : x)
        worst = std::max(worst, -shape_signed_distance((*specs)[k].shape, nullptr, pose, p, nullptr));
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
  std::string why;  // the first cause of `diverged`, with its frame
  int frames = 0;
  void add(const cloth::ClothMesh& mesh, const cloth::Vec3s& x, double pen_now, double ms_now) {
    double mx = 0.0, mn = 0.0;
    bool finite = true;
    for (const Vec3& p : x) finite &= p.allFinite();
    strain(mesh, x, mx, mn);
    if ((!finite || !std::isfinite(mx) || mx > 10.0) && !diverged)
      why = std::string(finite && std::isfinite(mx)
                            ? "the strain exceeded 10 (max l/L - 1 = " + std::to_string(mx) + ")"
                            : "a vertex position became non-finite") +
            " in frame " + std::to_string(frames + 1);
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
    if (m.diverged_why.empty()) m.diverged_why = why;
    for (const Vec3& p : x) m.final_positions.insert(m.final_positions.end(), {p.x(), p.y(), p.z()});
  }
};

}  // namespace

SystemMetrics run_loom_in_bullet(const CompareInput& in) {
  SystemMetrics m;
  m.system = "loom";
  BulletSceneOptions options = in.options;
  options.bullet_substeps = in.bullet_substeps;
  m.tier = tier_name(options);
  BulletScene scene(in.setup, in.bodies, options);
  if (in.prepare) in.prepare(scene.simulation());
  const cloth::Cloth& c0 = *scene.simulation().cloths()[0];
  Tally tally;
  FrameSample sample;
  auto report = [&](int f) {
    if (!in.on_frame) return;
    sample.frame = f;
    sample.x = &c0.state().x;
    sample.centres.clear();
    for (size_t k = 0; k < scene.num_bodies(); ++k) sample.centres.push_back(scene.body_position(k));
    in.on_frame(sample);
  };
  report(0);
  for (int f = 1; f <= in.frames; ++f) {
    const auto t0 = Clock::now();
    const cloth::FrameStats s = scene.step_frame();
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    tally.add(c0.mesh(), c0.state().x, scene.max_penetration(), ms);
    report(f);
    // The test `loom run` stops at: a frame the guard failed (the simulation holds the last good state) or
    // a non-finite body.
    if (!s.finite) {
      tally.diverged = true;
      m.diverged_why = scene.simulation().failure().empty()
                           ? "the state became non-finite in frame " + std::to_string(f)
                           : scene.simulation().failure();
    }
    for (size_t k = 0; m.diverged_why.empty() && k < scene.num_bodies(); ++k)
      if (!scene.body_position(k).allFinite() || !scene.body_velocity(k).allFinite()) {
        tally.diverged = true;
        m.diverged_why = "body '" + in.bodies[k].name + "' became non-finite in frame " + std::to_string(f);
      }
    if (tally.diverged) break;
  }
  tally.fill(m, c0.state().x);
  if (!scene.warnings().empty()) m.note = "unsupported shapes: " + scene.warnings()[0];
  return m;
}

SystemMetrics run_bullet_twin(const CompareInput& in, TwinKind kind) {
  SystemMetrics m;
  m.system = system_name(kind);
  if (kind == TwinKind::kDeformable && !in.bodies.empty()) {
    m.available = false;
    m.note =
        "the deformable twin is not coupled to rigid bodies here (docs/bullet.md: it produced "
        "NaN nodes against a rigid sphere)";
    return m;
  }
  cloth::SimulationSetup one = in.setup;
  one.cloths.resize(1);
  cloth::Simulation sim(one);
  if (in.prepare) in.prepare(sim);
  TwinSettings ts;
  ts.frame_dt = in.setup.frame_dt;
  ts.substeps = in.bullet_substeps;
  BulletTwin twin(kind, make_twin_cloth(*sim.cloths()[0], in.setup.gravity), ts);
  btDiscreteDynamicsWorld* world = TwinAccess::world(twin);
  btSoftBody* body = TwinAccess::body(twin);
  if (kind == TwinKind::kClassic) {
    // The settings under which the classic soft body collides accurately at all (docs/bullet.md, "Twins").
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
  auto report = [&](int f) {
    if (!in.on_frame) return;
    FrameSample sample;
    sample.frame = f;
    sample.x = &x;
    for (const auto& b : bodies.bodies) sample.centres.push_back(to_eigen(b->getCenterOfMassPosition()));
    in.on_frame(sample);
  };
  if (in.on_frame) {
    twin.positions(x);
    report(0);
  }
  for (int f = 1; f <= in.frames; ++f) {
    const auto t0 = Clock::now();
    bodies.drive(f * in.setup.frame_dt);
    twin.step_frame();
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    twin.positions(x);
    tally.add(mesh, x, bodies.penetration(x), ms);
    report(f);
    if (!twin.simulating() && !tally.diverged) {
      tally.diverged = true;
      tally.why = "Bullet's soft body stopped simulating (a non-finite node) in frame " + std::to_string(f);
    }
    if (tally.diverged) break;
  }
  tally.fill(m, x);
  return m;
}

}  // namespace loom::bullet
