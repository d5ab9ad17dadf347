#pragma once
// GarmentInstance: the engine-facing facade of a skinned garment, for a game loop:
//   GarmentInstance g(mesh.positions, mesh.triangles, mesh.skin, settings, bind_pose);
//   each frame:  g.set_pose(bone_globals);  g.step(frame_dt);  g.write_positions(vertex_buffer, stride);
// The cloth is simulated with fixed steps of `fixed_dt` behind an accumulator (Fiedler 2004, "Fix your
// timestep!"): any frame time (30, 60, 144 Hz, jittering) runs the same steps at the same simulated times,
// with skinned targets interpolated between the poses of the frames around each step: the skinned mesh in the
// character's frame, the frame's origin and its rotation (as rotation vectors relative to the middle pose) by
// the quadratic through the last three poses in time (linear after a reset or a zero-length frame). The
// positions handed out are those at (frame time - fixed_dt), interpolated between the last two steps, so a
// frame rate changes nothing but the sampling.
//
// One fixed step [t, t + h]:
//   1. inertia: the character's frame F moves from F(t) to F(t + h) (origin o, rotation R). The cloth is
//      carried by (1 - linear_inertia) of the origin's motion and (1 - angular_inertia) of the rotation's
//      angle about the origin, velocities turned with it. 1 = world-space simulation; 0 = simulation in the
//      character's frame (the cloth feels the frame's motion only through its skinned targets and gravity).
//   2. skinned targets p(t + h) and normals n(t + h); vertices whose max distance is 0 become kinematic (pins
//      with velocity (p - x) / h, Solver.h's contract); the others keep their mass.
//   3. solver: `substeps` steps of h / substeps of `solver` (default fast_xpbd, the real-time tier's XPBD,
//      Macklin, Müller, Chentanez 2016, in small steps with one iteration each: Macklin et al. 2019) with
//      `iterations` sweeps, gravity, the model's springs and optional wind drag (AirDragTerm.h). The solver's
//      float rounding is done in the character's frame (Solver::set_frame), so the motion does not depend
//      on where the character stands or which way it faces.
//   4. SkinConstraints (drive, max distance, backstop; SkinConstraints.h).
//   5. external colliders, when set_colliders gave some: the real-time body contact (RealtimeBodyContact.h)
//      pushes the free vertices out of them; it runs last, so a collider wins over the max distance and the
//      backstop where they disagree (a wall pressed into the cape).
// Teleports: when the frame's origin moves farther than `teleport_distance` or turns by more than
// `teleport_rotation` between two set_pose calls (or after teleport()), the whole cloth state is carried
// rigidly by that frame change and the step interpolates only the pose's motion relative to the frame.
//
// Sleep (GarmentSleepSettings, off by default): when every vertex's speed relative to the character's frame
// stays below `speed` for `settle_time` of simulated time, the cloth is put at rest (velocities zeroed) and
// sleeps: step() advances the clocks but runs no solver step, set_pose() compares the bones with those at
// the moment it fell asleep and skins nothing. It wakes when a bone (or the frame) has moved farther than
// `wake_distance` or turned more than `wake_rotation` since then, on wake(), and on notify_contact() with a
// box that overlaps the cloth's bounding box. Sleep disabled runs exactly the steps of a build without it.
//
// Rate LOD: set_step_stride(k) (or set_lod(distance, visible) through GarmentLodSettings) runs steps of
// k * fixed_dt on the same accumulator (the simulated time stays a whole number of fixed_dt), so a far or
// off-screen garment costs 1/k of the solver work. The state carries over unchanged when k changes, but the
// render positions lag the clock by one step (k * fixed_dt): at the first step of a new stride the rendered
// positions keep those of the frame before and the difference fades out linearly over lod.blend_time.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "loom/characters/Skin.h"
#include "loom/cloth/AirDragTerm.h"
#include "loom/cloth/Cloth.h"
#include "loom/cloth/SkinConstraints.h"
#include "loom/cloth/Solver.h"
#include "loom/collision/RealtimeBodyContact.h"

namespace loom::characters {

struct GarmentSleepSettings {
  bool enabled = false;
  double speed = 0.01;           // m/s, >= 0: rest when every vertex is slower (relative to the frame)
  double settle_time = 0.5;      // s, >= 0: simulated time at rest before sleeping
  double wake_distance = 0.005;  // m, >= 0: a bone (or the frame) moved farther than this wakes it
  double wake_rotation = 0.02;   // rad, >= 0: a bone (or the frame) turned more than this wakes it
};

struct GarmentLodSettings {
  double full_rate_distance = 5.0;  // m, > 0: set_lod(d) steps at stride ceil(d / full_rate_distance)
  int max_stride = 8;               // >= 1, <= kMaxStride: the stride of the farthest garments
  int offscreen_stride = 16;        // >= 1, <= kMaxStride: the stride when not visible
  double blend_time = 0.2;          // s, >= 0: render blend after a stride change (see set_step_stride)
};

struct GarmentSettings {
  cloth::Material material;                   // fabric (Material.h)
  std::string model = "springs";              // elastic model (Model.h)
  double fixed_dt = 1.0 / 240.0;              // s, simulation step
  std::string solver = "fast_xpbd";           // one of cloth::solver_names() that takes `iterations`
  int substeps = 4;                           // >= 1, <= 1000: solver steps per fixed step
  int iterations = 1;                         // >= 1: solver sweeps per solver step
  cloth::Vec3 gravity{0.0, -9.81, 0.0};       // m/s²
  cloth::SkinConstraintSettings constraints;  // per-vertex maps over the garment's vertices
  double linear_inertia = 1.0;                // 1, in [0, 1]
  double angular_inertia = 1.0;               // 1, in [0, 1]
  double teleport_distance = 1.0;             // m per frame, > 0 (∞: never)
  double teleport_rotation = 1.0;             // rad per frame, > 0 (∞: never)
  int max_steps_per_frame = 32;               // >= 1; a longer frame drops the excess time (the clock slips)
  std::optional<cloth::DragSettings> wind;    // air drag with wind; absent = no drag term
  GarmentSleepSettings sleep;                 // off by default
  GarmentLodSettings lod;                     // used by set_lod
};

class GarmentInstance {
 public:
  static constexpr int kMaxStride = 64;  // largest step stride (steps of kMaxStride * fixed_dt)

  // `bind_positions` (m, the skin's bind space) and `triangles` make the cloth's rest shape; the cloth starts
  // on the skinned mesh at `pose` (one global transform per skin bone). The character's frame is the rigid
  // part of bone 0 unless set_pose is given one. Throws loom::Error(source, field, problem) for invalid
  // settings (fixed_dt, solver.method, substeps, iterations, linear_inertia, angular_inertia,
  // teleport_distance, teleport_rotation, max_steps_per_frame, sleep.*, lod.*, the constraint maps), a skin
  // of another vertex count, an invalid mesh or pose.
  GarmentInstance(const cloth::Vec3s& bind_positions, const std::vector<cloth::Tri>& triangles, Skin skin,
                  GarmentSettings settings, const std::vector<Affine>& pose,
                  const std::string& source = "garment");

  // The pose at the end of the next step() call: bone global transforms (world, m) and the character's frame
  // (rigid). Throws loom::Error(source, "pose[b]", ...) for a non-finite transform or a wrong bone count.
  void set_pose(const std::vector<Affine>& bones);
  void set_pose(const std::vector<Affine>& bones, const Eigen::Isometry3d& frame);
  // Advances the clock by frame_dt (s, >= 0, finite) and runs the fixed steps that fall within it.
  void step(double frame_dt);
  // The next set_pose carries the cloth rigidly with the frame, whatever the thresholds.
  void teleport() { teleport_requested_ = true; }
  // Puts the cloth on the skinned mesh of the current pose, at rest.
  void reset();
  // Puts the cloth at positions x (m, world) with velocities v (m/s), one per vertex, as the state after the
  // last step and the render positions (no interpolation, no blend): a coarse-mesh LOD switch carries the
  // state of another mesh over (GarmentMeshLod.h). Throws loom::Error(source, "state", ...) for a wrong size
  // or a non-finite value.
  void set_state(const cloth::Vec3s& x, const cloth::Vec3s& v);
  // Global multiplier of the max distances (SkinConstraintSettings): 0 fully skinned, ∞ fully simulated.
  void set_max_distance_multiplier(double s);

  // Sleep (see above). wake() wakes the cloth and restarts its settle time; notify_contact(lo, hi) does so
  // when the box [lo, hi] (m, world) overlaps the cloth's bounding box (returns whether it overlaps; an awake
  // cloth only restarts its settle time). Throws loom::Error(source, "contact", ...) for a non-finite or
  // inverted box.
  void wake();
  bool notify_contact(const cloth::Vec3& lo, const cloth::Vec3& hi);
  bool asleep() const { return asleep_; }
  // Rate LOD: steps of k * fixed_dt from the next step() on, k in [1, kMaxStride] (throws loom::Error(source,
  // "step_stride", ...) otherwise). set_lod picks k from the camera distance (m, >= 0, finite) and visibility
  // with GarmentLodSettings (throws naming "distance").
  void set_step_stride(int k);
  void set_lod(double distance, bool visible = true);
  int step_stride() const { return stride_; }

  // External colliders (Collider.h): a Bullet world's bodies (loom::bullet::BulletGarment), a game's own
  // shapes, the character's capsules. Each fixed step [t, t + h] (t = time()) ends with the real-time contact
  // against them (step 5 above): a collider with a `motion` is sampled at t and t + h, the others are used at
  // their prev/curr poses as the owner set them; the reactions are summed into each collider's
  // reaction_impulse (the owner clears them). Kinematic vertices (max distance 0) are not moved. nullptr
  // removes them. Throws loom::Error(source, "contact.thickness" / "contact.passes", ...) for a negative or
  // non-finite thickness or passes < 1.
  void set_colliders(collision::ColliderSetPtr colliders,
                     const collision::RealtimeContactSettings& contact = {});
  const collision::ColliderSetPtr& colliders() const { return colliders_; }

  int num_vertices() const { return static_cast<int>(bind_.size()); }
  // Writes the render positions (xyz as floats) into dst[i * stride + 0..2]; stride >= 3 floats. No
  // allocation.
  void write_positions(float* dst, size_t stride) const;
  // Writes unit area-weighted vertex normals of the render positions, as write_positions. No allocation after
  // the first call (uses an internal buffer: not for concurrent calls on one instance).
  void write_normals(float* dst, size_t stride) const;

  const cloth::Vec3s& positions() const { return cloth_->state().x; }   // m, state after the last step
  const cloth::Vec3s& velocities() const { return cloth_->state().v; }  // m/s, state after the last step
  const cloth::Vec3s& skinned() const { return skinned_curr_; }  // m, skinned mesh at the last set_pose
  const cloth::Vec3s& targets() const { return target_; }        // m, skinned targets of the last step
  const cloth::Vec3s& target_normals() const { return target_normal_; }
  const cloth::SkinConstraints& constraints() const { return constraints_; }
  double time() const { return static_cast<double>(ticks_) * settings_.fixed_dt; }  // s, simulated
  double clock() const { return clock_; }                                           // s, frame time
  long steps() const { return ticks_; }                // simulated time in fixed steps (fixed_dt)
  long solver_steps() const { return solver_steps_; }  // fixed steps the solver ran (none while asleep)
  long teleports() const { return teleports_; }

 private:
  void fixed_step(int stride);
  void run_contacts(double h);  // step 5 (the contact stage sees the cloth through a one-cloth list)
  void render_positions(cloth::Vec3s& out) const;  // interpolated between the last two steps, plus the blend
  void settle(const Eigen::Isometry3d& from, const Eigen::Isometry3d& to, double h);
  void fall_asleep();
  bool pose_moved(const std::vector<Affine>& bones, const Eigen::Isometry3d& frame) const;
  void carry(const Eigen::Isometry3d& from, const Eigen::Isometry3d& to, double linear, double angular);
  static void vertex_normals(const std::vector<cloth::Tri>& tris, const cloth::Vec3s& x, cloth::Vec3s& n);

  std::string source_;
  GarmentSettings settings_;
  Skin skin_;
  cloth::Vec3s bind_;
  std::vector<cloth::Tri> tris_;
  std::unique_ptr<cloth::Cloth> cloth_;
  std::unique_ptr<cloth::Solver> solver_;
  cloth::SkinConstraints constraints_;
  std::vector<Affine> matrices_;
  cloth::Vec3s skinned_curr_;  // m, world skinned mesh at the last set_pose
  // m, skinned mesh in the character's frame at clock_prev2_, clock_prev_ and clock_
  cloth::Vec3s local_prev2_, local_prev_, local_curr_;
  cloth::Vec3s target_, target_normal_, render_prev_;
  cloth::Vec3s step_start_;  // m, positions at the start of the fixed step (substeps > 1)
  mutable cloth::Vec3s scratch_, scratch_normals_;
  std::vector<double> mass_;
  Eigen::Isometry3d frame_prev2_ = Eigen::Isometry3d::Identity(), frame_prev_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d frame_curr_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d frame_sim_ = Eigen::Isometry3d::Identity();  // frame at time()
  double clock_prev2_ = 0.0, clock_prev_ = 0.0, clock_ = 0.0;    // s, frame times of the last three poses
  long ticks_ = 0;                                               // simulated time in units of fixed_dt
  long solver_steps_ = 0;                                        // solver steps run
  long teleports_ = 0;
  int stride_ = 1;       // fixed_dt per step
  int last_stride_ = 1;  // fixed_dt in the last step (render interpolation)
  bool asleep_ = false;
  cloth::Vec3s blend_offset_;  // m, render offset at blend_start_ after a stride change
  double blend_start_ = -1.0;  // s, clock at the stride change (< 0: no blend)
  double rest_time_ = 0.0;     // s, simulated time every vertex has been below sleep.speed
  std::vector<Affine> bones_, sleep_bones_;
  Eigen::Isometry3d sleep_frame_ = Eigen::Isometry3d::Identity();
  cloth::Vec3 box_lo_ = cloth::Vec3::Zero(), box_hi_ = cloth::Vec3::Zero();  // m, the cloth's box asleep
  bool teleport_requested_ = false;
  collision::ColliderSetPtr colliders_;                           // set_colliders (null: none)
  std::unique_ptr<collision::RealtimeBodyContactStage> contact_;  // step 5, with colliders_
  std::vector<std::unique_ptr<cloth::Cloth>> contact_cloths_;     // holds cloth_ while step 5 runs
};

}  // namespace loom::characters
