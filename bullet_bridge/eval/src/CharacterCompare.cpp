#include "loom/bullet/CharacterCompare.h"

#include <BulletSoftBody/btSoftBody.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <btBulletDynamicsCommon.h>

#include <chrono>
#include <cmath>
#include <memory>

#include "BulletConvert.h"
#include "ShapeDistance.h"
#include "TwinAccess.h"
#include "loom/cloth/Error.h"

namespace loom::bullet {

namespace {

using Clock = std::chrono::steady_clock;

// The same figures for both systems, gathered at every frame end.
struct CharacterTally {
  const CharacterCompareInput* in = nullptr;
  double max_strain = 0.0, mean_sum = 0.0, pen = 0.0, track = 0.0, ms = 0.0;
  long inside = 0;
  bool diverged = false;
  std::string why;  // the first cause of `diverged`, with its frame
  int frames = 0;
  std::vector<std::vector<Vec3>> targets;  // per body attachment: the vertex in the body's frame at t = 0

  explicit CharacterTally(const CharacterCompareInput& input, const std::vector<const cloth::Vec3s*>& x0)
      : in(&input) {
    for (const KinematicBody& b : input.bodies) {
      targets.emplace_back();
      const Transform p0 = b.motion(0.0);
      for (const collision::BodyAttachment& a : b.attachments)
        targets.back().push_back(p0.inverse() * (*x0[a.cloth])[a.vertex]);
    }
  }

  // Marks the run diverged at the frame being added; the first cause is kept.
  void stop(const std::string& cause) {
    if (why.empty())  // a simulation's failure names its frame already
      why = cause.find(" in frame ") != std::string::npos ? cause
                                                          : cause + " in frame " + std::to_string(frames + 1);
    diverged = true;
  }

  // x[c]: positions of garment c at time t (s); meshes[c] its mesh.
  void add(double t, const std::vector<const cloth::ClothMesh*>& meshes,
           const std::vector<const cloth::Vec3s*>& x, double ms_now) {
    double mean = 0.0;
    long springs = 0, inside_now = 0;
    for (size_t c = 0; c < meshes.size(); ++c) {
      const cloth::ClothMesh& mesh = *meshes[c];
      for (int si : mesh.strain_springs()) {
        const auto& s = mesh.springs()[si];
        const double r = (mesh.rest_positions()[s.i] - mesh.rest_positions()[s.j]).norm();
        const double e = ((*x[c])[s.i] - (*x[c])[s.j]).norm() / r - 1.0;
        if (!std::isfinite(e)) {
          stop("an edge's strain became non-finite");
          continue;
        }
        max_strain = std::max(max_strain, e);
        mean += std::abs(e);
        ++springs;
      }
    }
    std::vector<Transform> poses;
    for (const KinematicBody& b : in->bodies) poses.push_back(b.motion(t));
    for (size_t c = 0; c < x.size(); ++c)
      for (const Vec3& p : *x[c]) {
        if (!p.allFinite()) {
          stop("a vertex position became non-finite");
          continue;
        }
        double depth = 0.0;
        for (size_t k = 0; k < in->bodies.size(); ++k)
          if (in->bodies[k].collides)
            depth =
                std::max(depth, -shape_signed_distance(in->bodies[k].shape, nullptr, poses[k], p, nullptr));
        pen = std::max(pen, depth);
        inside_now += depth > 0.0;
      }
    for (size_t k = 0; k < in->bodies.size(); ++k)
      for (size_t j = 0; j < in->bodies[k].attachments.size(); ++j) {
        const collision::BodyAttachment& a = in->bodies[k].attachments[j];
        track = std::max(track, ((*x[a.cloth])[a.vertex] - poses[k] * targets[k][j]).norm());
      }
    inside = std::max(inside, inside_now);
    if (max_strain > 10.0) stop("the strain exceeded 10 (max l/L - 1 = " + std::to_string(max_strain) + ")");
    mean_sum += springs ? mean / springs : 0.0;
    ms += ms_now;
    ++frames;
  }

  CharacterMetrics fill(const std::string& system) const {
    CharacterMetrics r;
    r.m.system = system;
    r.m.ms_per_frame = frames ? ms / frames : 0.0;
    r.m.max_strain = max_strain;
    r.m.mean_strain = frames ? mean_sum / frames : 0.0;
    r.m.max_penetration = pen;
    r.m.diverged = diverged;
    r.m.diverged_why = why;
    r.penetrating_vertices = inside;
    r.max_attachment_error = track;
    return r;
  }
};

}  // namespace

CharacterMetrics run_loom_character(cloth::Simulation& sim, const CharacterCompareInput& in) {
  std::vector<const cloth::ClothMesh*> meshes;
  std::vector<const cloth::Vec3s*> x;
  for (const auto& c : sim.cloths()) {
    meshes.push_back(&c->mesh());
    x.push_back(&c->state().x);
  }
  CharacterTally tally(in, x);
  for (int f = 1; f <= in.frames; ++f) {
    const auto t0 = Clock::now();
    const cloth::FrameStats s = sim.step_frame();
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (!s.finite)
      tally.stop(sim.failure().empty() ? std::string("the state became non-finite") : sim.failure());
    tally.add(sim.time(), meshes, x, ms);
    if (tally.diverged) break;
  }
  CharacterMetrics r = tally.fill("loom");
  for (const Vec3& p : *x[0]) r.m.final_positions.insert(r.m.final_positions.end(), {p.x(), p.y(), p.z()});
  return r;
}

CharacterMetrics run_bullet_character(const CharacterCompareInput& in) {
  // Each garment is a classic twin (its own btSoftRigidDynamicsWorld: Bullet's classic soft bodies do not
  // collide with each other through vertex-face tests, docs/bullet.md) with every capsule in its world.
  cloth::Simulation sim(in.setup);  // the Loom cloths: masses, springs, start positions
  struct Garment {
    std::unique_ptr<BulletTwin> twin;
    std::vector<std::unique_ptr<btCollisionShape>> shapes;
    std::vector<std::unique_ptr<btDefaultMotionState>> states;
    std::vector<std::unique_ptr<btRigidBody>> bodies;
    cloth::Vec3s x;
    ~Garment() {
      if (!twin) return;
      for (auto& b : bodies) TwinAccess::world(*twin)->removeRigidBody(b.get());
    }
  };
  std::vector<std::unique_ptr<Garment>> garments;
  TwinSettings ts;
  ts.frame_dt = in.setup.frame_dt;
  ts.substeps = in.bullet_substeps;
  for (size_t c = 0; c < sim.cloths().size(); ++c) {
    auto g = std::make_unique<Garment>();
    TwinCloth tc = make_twin_cloth(*sim.cloths()[c], in.setup.gravity);
    tc.pinned.clear();  // attached vertices hang on anchors, not on fixed pins
    tc.masses = sim.cloths()[c]->state().mass;
    for (size_t i = 0; i < tc.masses.size(); ++i)
      if (!(tc.masses[i] > 0.0)) throw Error("", "bullet twin", "garment vertex without mass");
    g->twin = std::make_unique<BulletTwin>(TwinKind::kClassic, tc, ts);
    btSoftBody* body = TwinAccess::body(*g->twin);
    btDiscreteDynamicsWorld* world = TwinAccess::world(*g->twin);
    // The settings under which the classic soft body collides accurately at all (docs/bullet.md).
    body->getCollisionShape()->setMargin(btScalar(std::max(0.005, in.thickness)));
    body->m_cfg.kKHR = 1;
    body->m_cfg.kCHR = 1;
    body->m_cfg.kAHR = 1;  // anchors as hard as Bullet allows
    TwinAccess::info(*g->twin)->m_sparsesdf.setDefaultVoxelsz(0.05);
    TwinAccess::info(*g->twin)->m_sparsesdf.Reset();
    for (const KinematicBody& kb : in.bodies) {
      std::unique_ptr<btCollisionShape> shape;
      if (kb.collides)
        shape =
            std::make_unique<btCapsuleShape>(btScalar(kb.shape.radius), btScalar(2 * kb.shape.half_height));
      else
        shape = std::make_unique<btSphereShape>(btScalar(0.01));
      g->states.push_back(std::make_unique<btDefaultMotionState>(to_bt(kb.motion(0.0))));
      btRigidBody::btRigidBodyConstructionInfo info(0, g->states.back().get(), shape.get(),
                                                    btVector3(0, 0, 0));
      info.m_friction = btScalar(kb.friction);
      auto rb = std::make_unique<btRigidBody>(info);
      rb->setCollisionFlags(rb->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
      rb->setActivationState(DISABLE_DEACTIVATION);
      if (kb.collides)
        world->addRigidBody(rb.get());
      else
        world->addRigidBody(rb.get(), 0, 0);  // an anchor frame: collides with nothing
      for (const collision::BodyAttachment& a : kb.attachments)
        if (a.cloth == static_cast<int>(c)) body->appendAnchor(a.vertex, rb.get(), !kb.collides, 1);
      g->shapes.push_back(std::move(shape));
      g->bodies.push_back(std::move(rb));
    }
    g->twin->positions(g->x);
    garments.push_back(std::move(g));
  }
  std::vector<const cloth::ClothMesh*> meshes;
  std::vector<const cloth::Vec3s*> x;
  for (size_t c = 0; c < garments.size(); ++c) {
    meshes.push_back(&sim.cloths()[c]->mesh());
    x.push_back(&garments[c]->x);
  }
  CharacterTally tally(in, x);
  for (int f = 1; f <= in.frames; ++f) {
    const double t = f * in.setup.frame_dt;
    const auto t0 = Clock::now();
    for (auto& g : garments) {
      for (size_t k = 0; k < in.bodies.size(); ++k)
        g->states[k]->setWorldTransform(to_bt(in.bodies[k].motion(t)));
      g->twin->step_frame();
    }
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    bool simulating = true;
    for (auto& g : garments) {
      g->twin->positions(g->x);
      simulating = simulating && g->twin->simulating();
    }
    tally.add(t, meshes, x, ms);
    if (in.on_frame) in.on_frame(f, x);
    if (!simulating) tally.stop("Bullet's soft body stopped simulating (a non-finite node)");
    if (tally.diverged) break;
  }
  CharacterMetrics r = tally.fill("bullet_classic");
  for (const Vec3& p : garments.empty() ? cloth::Vec3s{} : garments[0]->x)
    r.m.final_positions.insert(r.m.final_positions.end(), {p.x(), p.y(), p.z()});
  return r;
}

}  // namespace loom::bullet
