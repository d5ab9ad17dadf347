#pragma once
// BodyCoupling: cloth and dynamic rigid bodies solved together in small XPBD steps (the real-time tier of
// BulletCloth). Bullet-free: BulletCloth fills `bodies` from the world before each Bullet substep and
// writes their poses and velocities back after it.
//
// One cloth step of size h (Macklin, Storey, Lu et al. 2019, "Small steps in physics simulation": many
// steps, one iteration each; Müller, Macklin, Chentanez et al. 2020, "Detailed rigid body simulation with
// extended position based dynamics", Alg. 2):
//   predict (before the cloth solver): every dynamic body moves with its velocity, x += h v,
//     q += h/2 [w, 0] q (gravity is already in the velocity Bullet hands over at the substep's start);
//   the cloth solver predicts and projects its own springs (XPBD, one iteration);
//   solve (after the cloth solver), `iterations` times:
//     contacts: a cloth vertex closer than the thickness to a body is an inequality C = d - thickness >= 0
//       corrected with both generalized inverse masses (Müller et al. 2020, eqs. 2-3):
//         w_v = 1/m_v,  w_b = 1/M + (r x n)^T I^-1 (r x n),  dlambda = -C / (w_v + w_b),
//         x_v += w_v dlambda n,  the body gets the positional impulse -dlambda n at the contact point;
//       body features (sphere centres, capsule axes, box and hull edges; FeatureContact.h) against cloth
//       triangles likewise, the triangle's point weighted by barycentric coordinates (Bridson et al. 2002);
//     tethers (Kim, Chentanez, Müller-Fischer 2012, "Long range attachments"): each free vertex stays within
//       (1 + tether_stretch) of its rest distance to each of its nearest pinned vertices (0: the paper's
//       inextensible tether, with which a cloth tied at four corners cannot sag at all and the bodies' weight
//       is held by limits that Gauss-Seidel leaves violated; at the edges' 10 % and a large slack a heavy
//       body sinks the cloth until the curved path to the anchor stretches its edges past 10 % before the
//       straight tether binds);
//     strain limit (Provot 1995): structural and shear edges no longer than (1 + max_stretch) L.
//     In tethers and edges a vertex in contact that would move into its body moves the body with it: along
//     the contact normal n its inverse mass is that of the pair, w_c = w_v w_b / (w_v + w_b), and the body
//     receives the share w_v / (w_v + w_b) of the normal impulse. So a 1 kg box resting on vertices of
//     0.3 g is carried by the tethers and edges at once instead of pushing the light vertices aside one
//     step at a time (the mass-ratio failure of Gauss-Seidel position projection);
//     friction (Macklin, Müller, Chentanez, Kim 2014, "Unified particle physics for real-time applications",
//       Sec. 6.1): the relative tangential displacement of vertex and body point over the step is undone
//       fully if below mu_s times the normal correction, else by mu_k times it, with both inverse masses;
//   velocities: v = (x - x_prev) / h for cloth vertices; for bodies v = (x - x0) / h and
//     w = 2 vec(q q0^-1) / h (Müller et al. 2020, Alg. 2);
//   inelastic contacts (Müller et al. 2020, Sec. 3.6, eq. 34, restitution 0): a vertex still touching its
//     body (or a static or kinematic collider) ends the step with the body point's normal velocity, by an
//     equal and opposite impulse -v_n / (w_v + w_b) on the pair. Without it a position correction of a
//     millimetre in a step of a few hundred microseconds leaves the vertex moving at metres per second
//     against the body, which the next step's contact undoes: a period-two jitter that also drives the
//     adaptive step count (BulletClothSettings::step_motion);
//   no rebound from a cloth with pinned vertices (restitution 0, Müller et al. 2020, Sec. 3.6 with e = 0;
//     a free cloth is left alone, so the pair's momentum stays exact): the change the step
//     made to a body's velocity, dv = v - v_pred along d = dv / |dv|, may stop the body along d but not throw
//     it faster than the cloth's anchors move: v.d is cut to max(0, v_pred.d, max_a u_a.d), u_a the velocity
//     of pinned vertex a over the step (a cape on a moving character carries a crate at its pins' speed; a
//     cloth tied to fixed points gives none); likewise the angular velocity w against w_pred alone (a
//     contact's rotation of the body stays in its pose but does not become spin: w = 2 dtheta / h of a step
//     of a few hundred microseconds turned millimetre corrections into tens of rad/s; so the cloth can stop
//     a body's spin but not start one). The position correction beyond that moves the body without giving it
//     velocity, as split-impulse penetration recovery does in rigid-body solvers (Bullet's
//     btContactSolverInfo::m_splitImpulse). Without it, a limit left violated at a step's end (a heavy
//     body pressing the light cloth past its limit, which Gauss-Seidel corrects over many steps) becomes
//     velocity: the cloth acts as a stiff undamped spring on the body and throws it back out of the bag.
// Every correction between cloth and body is an equal and opposite positional impulse, so the pair
// conserves linear and angular momentum exactly; with pinned vertices the no-rebound rule takes velocity
// from a body the cloth would throw (the pins, external, absorb it). Static and kinematic bodies have
// infinite mass (w_b = 0).
#include <memory>
#include <vector>

#include "loom/cloth/Stage.h"
#include "loom/collision/Collider.h"

namespace loom::bullet {

using Vec3 = collision::Vec3;
using Transform = collision::Transform;
using Mat3 = Eigen::Matrix3d;

struct CoupledBody {
  double inv_mass = 0.0;                    // 1/kg (0: static or kinematic, pose set from outside)
  Vec3 inv_inertia_local = Vec3::Zero();    // 1/(kg m²), principal, in the body frame
  Transform pose = Transform::Identity();   // centre-of-mass frame now
  Transform pose0 = Transform::Identity();  // at the cloth step's start
  Vec3 v = Vec3::Zero(), w = Vec3::Zero();  // m/s, rad/s
  Mat3 inv_inertia = Mat3::Zero();          // 1/(kg m²), world frame at `pose`
  bool touched = false;                     // a contact moved it in the current Bullet substep
  Vec3 v_pred = Vec3::Zero();               // m/s, v at the cloth step's start (after predict: unchanged)
  Vec3 w_pred = Vec3::Zero();               // rad/s, w at the cloth step's start
  // m/s, rad/s: the velocity changes of the step's inelastic-contact pass (added to those from the poses)
  Vec3 dv = Vec3::Zero(), dw = Vec3::Zero();
  long version = 0;  // counts the changes of `pose` (the coupling's pose caches)
  bool dynamic() const { return inv_mass > 0.0; }
};

struct BodyCouplingSettings {
  double thickness = 0.005;       // m, contact offset
  double max_stretch = 0.1;       // 1, edges at most (1 + max_stretch) times their rest length
  double tether_stretch = 0.015;  // 1, tethers at most (1 + tether_stretch) times their rest distance
  int iterations = 3;             // alternations of contacts, tethers and edges per cloth step
  int tether_anchors = 4;        // pinned vertices each free vertex is tethered to (nearest at rest); 0: none
  bool features = true;          // body features against cloth triangles
  double friction = 0.3;         // 1, kinetic
  double static_friction = 0.4;  // 1
};

class BodyCoupling {
 public:
  BodyCoupling(collision::ColliderSetPtr colliders, BodyCouplingSettings settings);
  ~BodyCoupling();

  // Filled by the owner before each Bullet substep: the bodies, and per collider of the ColliderSet the
  // body it belongs to (index into bodies, -1: not coupled, its poses set by the owner) and its pose in the
  // body frame.
  std::vector<CoupledBody> bodies;
  std::vector<int> collider_body;
  std::vector<Transform> collider_local;

  // The owner refilled the ColliderSet (shapes or bodies may differ): the colliders' features are rebuilt at
  // the next step (they are kept from step to step otherwise).
  void colliders_changed();

  std::unique_ptr<cloth::Stage> make_predict_stage();  // before the solver
  std::unique_ptr<cloth::Stage> make_solve_stage();    // after the solver

  // Deepest penetration (m, >= 0) below a body's surface, before correction, in the last cloth step.
  double last_penetration() const { return last_penetration_; }
  const BodyCouplingSettings& settings() const { return settings_; }

 private:
  class Predict;
  class Solve;
  struct Work;
  void predict(double h);
  void solve(cloth::Cloth& cloth, size_t index, double h);
  // The body collider k belongs to (nullptr: not coupled) and its current pose.
  CoupledBody* body_of(int k);
  // Collider k's pose now and its inverse; with placed_features also its features in world and their box
  // (cached until its body moves).
  struct Placed;
  const Placed& placed(int k);
  const Placed& placed_features(int k);
  double effective_inv_mass(const cloth::ClothState& s, int i, const Vec3& m);
  void move_vertex(cloth::ClothState& s, int i, double lam, const Vec3& m);
  // The cloth's limited edges, its tethers and its vertex-to-triangle lists (once per cloth).
  void build_limits(const cloth::Cloth& cloth, size_t index);
  // Vertex-collider and triangle-collider candidate pairs of this step, and the colliders' features.
  void find_candidates(const cloth::Cloth& cloth, size_t index);
  void solve_vertex_contacts(cloth::ClothState& s, int it);
  void solve_feature_contacts(cloth::Cloth& cloth, int it);
  // Tethers, then edges in alternating sweep order.
  void solve_limits(cloth::ClothState& s, size_t index, int it);
  void apply_friction(cloth::ClothState& s);
  // Inelastic contacts: the relative normal velocity of each vertex still touching its body set to zero.
  void contact_velocities(cloth::ClothState& s, double h);
  // Body velocities from the pose change of the step, then the no-rebound cut (see above).
  void update_body_velocities(double h);

  collision::ColliderSetPtr colliders_;
  BodyCouplingSettings settings_;
  std::unique_ptr<Work> work_;
  double last_penetration_ = 0.0;
  bool anchored_ = false;          // some cloth has pinned (or attached) vertices
  bool features_current_ = false;  // work_->features match the colliders (colliders_changed)
  long vertex_contacts_ = 0, face_contacts_ = 0;
};

}  // namespace loom::bullet
