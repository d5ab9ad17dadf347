#pragma once
// BulletTwin: the same cloth as a Loom cloth (mesh, node masses, springs, pins, gravity), built inside Bullet
// for side-by-side runs (docs/bullet.md). Two systems:
//   kClassic    — a btSoftBody in a btSoftRigidDynamicsWorld (position-based links, Gauss-Seidel).
//   kDeformable — a body of a btDeformableMultiBodyDynamicsWorld with a btDeformableMassSpringForce whose
//                 per-link stiffness is Loom's spring k (N/m), backward Euler (implicit) + projection (CG).
// Settings under which each works at all: docs/bullet.md (classic: piterations >= 10 and 1/240
// steps; deformable: implicit with projection, 1/240 steps). Bullet headers stay inside src/.
#include <memory>
#include <string>
#include <vector>

#include "loom/cloth/Cloth.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Material.h"
#include "loom/cloth/SpringTerm.h"
#include "loom/cloth/Types.h"

namespace loom::bullet {

enum class TwinKind { kClassic, kDeformable };
// "bullet_classic" or "bullet_deformable" (the benchmark's `system` column).
const char* system_name(TwinKind kind);

// The Loom cloth to copy.
struct TwinCloth {
  std::shared_ptr<const cloth::ClothMesh> mesh;
  std::vector<cloth::Spring> springs;    // Loom's springs (make_springs), same order as mesh->springs()
  std::vector<double> masses;            // kg, Loom's lumped vertex masses (pinned vertices included)
  std::vector<int> pinned;               // vertices held fixed at their start position
  cloth::Vec3s start;                    // m, start positions (default: mesh rest positions)
  cloth::Vec3 gravity{0.0, -9.81, 0.0};  // m/s²
};

// The twin of a Loom cloth: its mesh, Loom's spring set for its material (make_springs), its lumped masses,
// its fixed pins and the current positions as start. Throws loom::Error for a pin with a path (moving
// attachments are not bridged).
TwinCloth make_twin_cloth(const cloth::Cloth& cloth, const cloth::Vec3& gravity);

// Knobs. Defaults are the settings under which each system works at all (docs/bullet.md).
struct TwinSettings {
  double frame_dt = 1.0 / 60.0;  // s, one step_frame() call
  int substeps = 4;              // Bullet fixed steps per frame: fixedTimeStep = frame_dt / substeps
  // classic: btSoftBody::Config::piterations (position solver sweeps per step);
  // deformable: Newton iterations of the backward-Euler solve (btDeformableBodySolver, Bullet's default 1).
  int iterations = 10;
  // classic: kLST of the structural links (0, 1]; shear and bend links get kLST * k_link / k_structural.
  // deformable: factor on every Loom spring stiffness (1 = the same N/m as Loom).
  double stiffness = 1.0;
  // deformable only: damping along the springs, N·s/m (btDeformableMassSpringForce's d); classic: kDP in
  // [0,1].
  double damping = 0.0;
  bool implicit = true;  // deformable only: backward Euler (true, with projection) or explicit
};

class BulletTwin {
 public:
  // Throws loom::Error for inconsistent input (sizes, pins out of range, settings out of range).
  BulletTwin(TwinKind kind, const TwinCloth& cloth, const TwinSettings& settings);
  ~BulletTwin();
  BulletTwin(const BulletTwin&) = delete;
  BulletTwin& operator=(const BulletTwin&) = delete;

  TwinKind kind() const { return kind_; }
  // Advances one frame (frame_dt) through btDynamicsWorld::stepSimulation(frame_dt, substeps + 1, frame_dt /
  // substeps).
  void step_frame();
  int num_nodes() const;
  int num_links() const;
  void positions(cloth::Vec3s& x) const;   // m
  void velocities(cloth::Vec3s& v) const;  // m/s
  double node_mass(int i) const;           // kg, Bullet's 1 / m_im (0 for pinned nodes, whose m_im is 0)
  bool is_pinned(int i) const;             // Bullet's inverse mass is 0
  // False once Bullet switched the body off (btCollisionWorld::updateSingleAabb sets DISABLE_SIMULATION when
  // the AABB explodes, docs/bullet.md): the run has diverged even if the positions look finite.
  bool simulating() const;

 private:
  friend struct TwinAccess;  // the bridge's own code (src/TwinAccess.h): world and body, for rigid bodies
  struct Impl;
  TwinKind kind_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace loom::bullet
