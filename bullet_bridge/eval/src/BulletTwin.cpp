#include "loom/bullet/BulletTwin.h"

#include <BulletSoftBody/btDeformableBodySolver.h>
#include <BulletSoftBody/btDeformableGravityForce.h>
#include <BulletSoftBody/btDeformableMassSpringForce.h>
#include <BulletSoftBody/btDeformableMultiBodyConstraintSolver.h>
#include <BulletSoftBody/btDeformableMultiBodyDynamicsWorld.h>
#include <BulletSoftBody/btSoftBody.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <map>

#include "BulletConvert.h"
#include "TwinAccess.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/SpringSet.h"

namespace loom::bullet {

// Internal to this file; a named namespace because BulletTwin::Impl holds these types (GCC warns about an
// anonymous-namespace member type when the file is compiled inside a unity build).
namespace twin_internal {

// btDeformableMassSpringForce with one stiffness per link (Loom's k, N/m) instead of Bullet's two (elastic,
// bending). Same formulas as Bullet 3.24's btDeformableMassSpringForce.h: f = k (|d| - r) d̂ and its full
// Hessian, which includes the (|d| - r)/|d| term; only the per-link k differs.
class PerLinkMassSpringForce final : public btDeformableMassSpringForce {
 public:
  PerLinkMassSpringForce(std::vector<btScalar> k, btScalar damping)
      : btDeformableMassSpringForce(1, damping, true), k_(std::move(k)) {}

  void addScaledElasticForce(btScalar scale, TVStack& force) override {
    for (int i = 0; i < m_softBodies.size(); ++i) {
      const btSoftBody* psb = m_softBodies[i];
      if (!psb->isActive()) continue;
      for (int j = 0; j < psb->m_links.size(); ++j) {
        const btSoftBody::Link& link = psb->m_links[j];
        const btVector3 dir = link.m_n[1]->m_q - link.m_n[0]->m_q;
        const btVector3 dn = dir.norm() > SIMD_EPSILON ? dir.normalized() : btVector3(0, 0, 0);
        const btVector3 f = scale * k_[j] * (dir - dn * link.m_rl);
        force[link.m_n[0]->index] += f;
        force[link.m_n[1]->index] -= f;
      }
    }
  }

  void addScaledElasticForceDifferential(btScalar scale, const TVStack& dx, TVStack& df) override {
    for (int i = 0; i < m_softBodies.size(); ++i) {
      const btSoftBody* psb = m_softBodies[i];
      if (!psb->isActive()) continue;
      for (int j = 0; j < psb->m_links.size(); ++j) {
        const btSoftBody::Link& link = psb->m_links[j];
        const size_t id1 = link.m_n[0]->index, id2 = link.m_n[1]->index;
        const btVector3 dir = link.m_n[0]->m_q - link.m_n[1]->m_q;
        const btScalar len = dir.norm();
        if (len <= SIMD_EPSILON) continue;
        const btVector3 dn = dir / len;
        const btVector3 dxd = dx[id1] - dx[id2];
        const btScalar k = scale * k_[j];
        const btScalar ratio = (len - link.m_rl) / len;
        btVector3 d = -k * dn.dot(dxd) * dn + k * dn.dot(dxd) * ratio * dn - k * ratio * dxd;
        df[id1] += d;
        df[id2] -= d;
      }
    }
  }

  double totalElasticEnergy(btScalar) override {
    double e = 0.0;
    for (int i = 0; i < m_softBodies.size(); ++i) {
      const btSoftBody* psb = m_softBodies[i];
      for (int j = 0; j < psb->m_links.size(); ++j) {
        const btSoftBody::Link& link = psb->m_links[j];
        const double s = (link.m_n[1]->m_q - link.m_n[0]->m_q).norm() - link.m_rl;
        e += 0.5 * k_[j] * s * s;
      }
    }
    return e;
  }

 private:
  std::vector<btScalar> k_;  // N/m, per link in psb->m_links order
};

// btDeformableBodySolver with the Newton iteration count exposed (3.24 has no setter; default 1).
class NewtonSolver final : public btDeformableBodySolver {
 public:
  explicit NewtonSolver(int iterations) { m_maxNewtonIterations = iterations; }
};

}  // namespace twin_internal

using twin_internal::NewtonSolver;
using twin_internal::PerLinkMassSpringForce;

const char* system_name(TwinKind kind) {
  return kind == TwinKind::kClassic ? "bullet_classic" : "bullet_deformable";
}

TwinCloth make_twin_cloth(const cloth::Cloth& c, const cloth::Vec3& gravity) {
  TwinCloth t;
  t.mesh = c.mesh_ptr();
  t.springs = cloth::make_springs(c.mesh(), c.material());
  t.masses = c.state().mass;
  for (const cloth::Pin& p : c.pins()) {
    if (!p.times.empty())
      throw Error("", "bullet twin",
                  "pin of vertex " + std::to_string(p.vertex) + " moves; only fixed pins are bridged");
    t.pinned.push_back(p.vertex);
  }
  t.start = c.state().x;
  t.gravity = gravity;
  return t;
}

struct BulletTwin::Impl {
  TwinSettings settings;
  // Declaration order = reverse destruction order: the world goes before what it points to.
  std::unique_ptr<btSoftBodyRigidBodyCollisionConfiguration> config;
  std::unique_ptr<btCollisionDispatcher> dispatcher;
  std::unique_ptr<btDbvtBroadphase> broadphase;
  std::unique_ptr<btSequentialImpulseConstraintSolver> rigid_solver;              // classic
  std::unique_ptr<NewtonSolver> deformable_solver;                                // deformable
  std::unique_ptr<btDeformableMultiBodyConstraintSolver> deformable_constraints;  // deformable
  std::unique_ptr<btSoftRigidDynamicsWorld> classic_world;
  std::unique_ptr<btDeformableMultiBodyDynamicsWorld> deformable_world;
  std::unique_ptr<btSoftBody> body;
  std::unique_ptr<PerLinkMassSpringForce> spring_force;
  std::unique_ptr<btDeformableGravityForce> gravity_force;

  ~Impl() {
    // Remove the body (and the forces' references to it) before anything is freed.
    if (classic_world && body) classic_world->removeSoftBody(body.get());
    if (deformable_world && body) deformable_world->removeSoftBody(body.get());
  }
};

BulletTwin::BulletTwin(TwinKind kind, const TwinCloth& c, const TwinSettings& s)
    : kind_(kind), impl_(new Impl) {
  if (!c.mesh) throw Error("", "bullet twin", "no mesh");
  const int n = c.mesh->num_vertices();
  if (static_cast<int>(c.masses.size()) != n) throw Error("", "bullet twin", "needs one mass per vertex");
  if (c.springs.size() != c.mesh->springs().size())
    throw Error("", "bullet twin", "needs one spring per mesh spring definition (make_springs)");
  for (int p : c.pinned)
    if (p < 0 || p >= n)
      throw Error("", "bullet twin", "pinned vertex " + std::to_string(p) + " out of range");
  if (s.substeps < 1) throw Error("", "bullet.substeps", "must be >= 1");
  if (s.iterations < 1) throw Error("", "bullet.iterations", "must be >= 1");
  if (!(s.stiffness > 0.0)) throw Error("", "bullet.stiffness", "must be > 0");
  if (kind == TwinKind::kClassic && s.stiffness > 1.0)
    throw Error("", "bullet.stiffness", "classic kLST must be in (0, 1]");
  if (!(s.frame_dt > 0.0)) throw Error("", "bullet.frame_dt", "must be > 0");
  Impl& m = *impl_;
  m.settings = s;
  m.config = std::make_unique<btSoftBodyRigidBodyCollisionConfiguration>();
  m.dispatcher = std::make_unique<btCollisionDispatcher>(m.config.get());
  m.broadphase = std::make_unique<btDbvtBroadphase>();
  const btVector3 g = to_bt(c.gravity);
  btSoftBodyWorldInfo* info = nullptr;
  if (kind == TwinKind::kClassic) {
    m.rigid_solver = std::make_unique<btSequentialImpulseConstraintSolver>();
    m.classic_world = std::make_unique<btSoftRigidDynamicsWorld>(m.dispatcher.get(), m.broadphase.get(),
                                                                 m.rigid_solver.get(), m.config.get());
    m.classic_world->setGravity(g);
    info = &m.classic_world->getWorldInfo();
  } else {
    m.deformable_solver = std::make_unique<NewtonSolver>(s.iterations);
    m.deformable_constraints = std::make_unique<btDeformableMultiBodyConstraintSolver>();
    m.deformable_constraints->setDeformableSolver(m.deformable_solver.get());
    m.deformable_world = std::make_unique<btDeformableMultiBodyDynamicsWorld>(
        m.dispatcher.get(), m.broadphase.get(), m.deformable_constraints.get(), m.config.get(),
        m.deformable_solver.get());
    m.deformable_world->setGravity(g);
    info = &m.deformable_world->getWorldInfo();
  }
  info->m_gravity = g;
  info->m_sparsesdf.Initialize();

  // Nodes with Loom's masses; pinned nodes get mass 0 (inverse mass 0 = kinematic in both solvers).
  const cloth::Vec3s& x0 = c.start.empty() ? c.mesh->rest_positions() : c.start;
  if (static_cast<int>(x0.size()) != n) throw Error("", "bullet twin", "needs one start position per vertex");
  std::vector<btVector3> x(n);
  std::vector<btScalar> mass(n);
  for (int i = 0; i < n; ++i) {
    x[i] = to_bt(x0[i]);
    mass[i] = btScalar(c.masses[i]);
  }
  m.body = std::make_unique<btSoftBody>(info, n, x.data(), mass.data());
  btSoftBody& b = *m.body;
  for (int p : c.pinned) b.setMass(p, 0);

  // Links = Loom's springs (structural, shear, bend), same rest lengths (from the start positions).
  double k_structural = 0.0;
  for (const cloth::Spring& sp : c.springs) k_structural = std::max(k_structural, sp.k);
  std::map<double, btSoftBody::Material*> materials;
  std::vector<btScalar> link_k;
  const auto& defs = c.mesh->springs();
  for (size_t k = 0; k < c.springs.size(); ++k) {
    const cloth::Spring& sp = c.springs[k];
    if (kind == TwinKind::kClassic) {
      // PBD links have no N/m: kLST scales each link's correction; stiffness ratios follow Loom's k.
      const double kl = std::clamp(s.stiffness * sp.k / k_structural, 1e-6, 1.0);
      auto it = materials.find(kl);
      if (it == materials.end()) {
        btSoftBody::Material* mat = b.appendMaterial();
        mat->m_kLST = btScalar(kl);
        it = materials.emplace(kl, mat).first;
      }
      b.appendLink(sp.i, sp.j, it->second);
    } else {
      b.appendLink(sp.i, sp.j);
      link_k.push_back(btScalar(s.stiffness * sp.k));
    }
    b.m_links[b.m_links.size() - 1].m_rl = btScalar(sp.rest_length);
    b.m_links[b.m_links.size() - 1].m_bbending = defs[k].kind == cloth::SpringKind::kBend ? 1 : 0;
  }
  for (const cloth::Tri& t : c.mesh->triangles()) b.appendFace(t[0], t[1], t[2]);

  if (kind == TwinKind::kClassic) {
    b.m_cfg.piterations = s.iterations;
    b.m_cfg.kDP = btScalar(s.damping);
    m.classic_world->addSoftBody(&b);
  } else {
    // Deformable set-up as in examples/DeformableDemo (docs/bullet.md) with implicit + projection.
    b.m_cfg.kKHR = 1;
    b.m_cfg.kCHR = 1;
    b.m_cfg.kDF = 0;
    b.m_cfg.collisions =
        btSoftBody::fCollision::SDF_RD | btSoftBody::fCollision::SDF_RDF | btSoftBody::fCollision::SDF_RDN;
    b.setSelfCollision(false);
    m.deformable_world->addSoftBody(&b);
    m.spring_force = std::make_unique<PerLinkMassSpringForce>(std::move(link_k), btScalar(s.damping));
    m.gravity_force = std::make_unique<btDeformableGravityForce>(g);
    m.deformable_world->addForce(&b, m.spring_force.get());
    m.deformable_world->addForce(&b, m.gravity_force.get());
    m.deformable_world->setImplicit(s.implicit);
    m.deformable_world->setUseProjection(s.implicit);
  }
}

BulletTwin::~BulletTwin() = default;

void BulletTwin::step_frame() {
  const TwinSettings& s = impl_->settings;
  const btScalar fixed = btScalar(s.frame_dt / s.substeps);
  btDiscreteDynamicsWorld* w = impl_->classic_world
                                   ? static_cast<btDiscreteDynamicsWorld*>(impl_->classic_world.get())
                                   : static_cast<btDiscreteDynamicsWorld*>(impl_->deformable_world.get());
  // maxSubSteps one above the nominal count so float round-off in m_localTime never drops time
  // (docs/bullet.md).
  w->stepSimulation(btScalar(s.frame_dt), s.substeps + 1, fixed);
}

int BulletTwin::num_nodes() const { return impl_->body->m_nodes.size(); }
int BulletTwin::num_links() const { return impl_->body->m_links.size(); }

void BulletTwin::positions(cloth::Vec3s& x) const {
  const auto& nodes = impl_->body->m_nodes;
  x.resize(nodes.size());
  for (int i = 0; i < nodes.size(); ++i)
    x[i] = cloth::Vec3(nodes[i].m_x.x(), nodes[i].m_x.y(), nodes[i].m_x.z());
}

void BulletTwin::velocities(cloth::Vec3s& v) const {
  const auto& nodes = impl_->body->m_nodes;
  v.resize(nodes.size());
  for (int i = 0; i < nodes.size(); ++i)
    v[i] = cloth::Vec3(nodes[i].m_v.x(), nodes[i].m_v.y(), nodes[i].m_v.z());
}

double BulletTwin::node_mass(int i) const { return impl_->body->getMass(i); }
bool BulletTwin::is_pinned(int i) const { return impl_->body->m_nodes[i].m_im == 0; }
bool BulletTwin::simulating() const { return impl_->body->getActivationState() != DISABLE_SIMULATION; }

btDiscreteDynamicsWorld* TwinAccess::world(BulletTwin& t) {
  return t.impl_->classic_world ? static_cast<btDiscreteDynamicsWorld*>(t.impl_->classic_world.get())
                                : static_cast<btDiscreteDynamicsWorld*>(t.impl_->deformable_world.get());
}
btSoftBody* TwinAccess::body(BulletTwin& t) { return t.impl_->body.get(); }
btSoftBodyWorldInfo* TwinAccess::info(BulletTwin& t) {
  return t.impl_->classic_world ? &t.impl_->classic_world->getWorldInfo()
                                : &t.impl_->deformable_world->getWorldInfo();
}

}  // namespace loom::bullet
