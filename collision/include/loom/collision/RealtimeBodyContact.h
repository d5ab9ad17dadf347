#pragma once
// RealtimeBodyContactStage ("realtime_contact"): the real-time tier's cloth-vs-body contact, for any set of
// generic colliders (Collider.h: a character's capsules, a scene's shapes, a Bullet world's bodies). Run
// after the solver at every (small) substep, it is discrete with cheap culling and continuous only where
// needed:
//   1. colliders with a scene `motion` are sampled at t and t + h into prev/curr; each collider gets a world
//      bounding box over both poses, inflated by its contact thickness (per bone for a rig), and a bound on
//      how far any of its surface points moves in the step;
//   2. culling: colliders whose box misses the cloth's box are skipped; the others are listed in the cells of
//      a coarse grid over the cloth's box (about 10 cm cells); a vertex is tested against the colliders of
//      its cell, and only when it lies inside the collider's box;
//   3. continuous, only where the motion relative to the collider (a bound: the vertex's step plus the
//      collider's motion bound) could carry the vertex past the collider's middle, where the discrete test
//      would push it out on the wrong side (sphere and capsule: the radius; box: its smallest half extent;
//      other shapes: the thickness), and the vertex started outside within reach: the path
//      x_prev -> x against the moving collider (swept_point, conservative advancement, SweptCollider.h); on a
//      hit the vertex is put at the contact point carried with the body to the step's end;
//   4. discrete: up to `passes` passes over the vertex's candidate colliders; a vertex closer than the
//      thickness t to a collider at curr is projected to distance t along the outward normal (closed forms
//      for plane, sphere and capsule, ColliderDistance.h for the others); its inward velocity relative to the
//      surface (incl. the collider's rotation) is removed and Coulomb friction acts on the tangential part
//      (Bridson, Fedkiw, Anderson 2002, Sec. 7.2: stick if |v_t| <= μ_s Δv_n, else v_t *= 1 - μ_k
//      Δv_n/|v_t|).
//   5. the reaction -m Δv of every velocity change, and its moment about curr's origin, is added to the
//      collider's reaction_impulse / reaction_angular_impulse (two-way coupling).
//   0. faces (`faces`, off by default; before steps 3-5, not in a positions-only stage): the collider
//   features of FeatureContact.h
//      (sphere centres, capsule axes, box, cylinder and hull edges) against cloth triangles, one face phase
//      of FeatureContactStage (FeatureContactSettings::vertices off), so a box corner or a capsule's end
//      cannot pass through a coarse triangle whose three vertices are all outside the body; its impulses go
//      to the colliders' reactions as in step 5. It acts once a feature is nearer a triangle than its radius
//      + half the thickness (FeatureContactSettings::face_slack 0.5: a garment wrapped round a capsule at the
//      thickness, whose triangles' middles sag towards it by less than that, is left to the vertex steps).
//      The vertex steps follow and keep the last word.
// Postcondition: a vertex left inside colliders after the passes (a pinch between two) is moved along the
// sum of their normals until outside all of them; one still inside after 8 rounds is counted in
// `unresolved`. Vertices are visited in index order on one
// thread: results do not depend on the thread count.
#include <memory>
#include <optional>
#include <vector>

#include "loom/cloth/Stage.h"
#include "loom/cloth/StrainLimitStage.h"
#include "loom/collision/Collider.h"
#include "loom/collision/FeatureContact.h"

namespace loom::collision {

struct RealtimeContactSettings {
  double thickness = 0.0;         // m; contact offset where a collider gives none (0: the cloth material's)
  double friction = -1.0;         // 1; kinetic coefficient for every collider (< 0: the collider's own)
  double static_friction = -1.0;  // 1; static coefficient for every collider (< 0: the collider's own)
  int passes = 3;                 // discrete passes per vertex per step (overlapping colliders)
  bool continuous = true;         // the swept test of step 3
  bool faces = false;             // step 0 (collider features against cloth triangles); off by default
  // Positions only (steps 1, 2 and 4's projection; no velocity change, no friction, no reactions, no swept
  // test): a last pass after a constraint pass that may have moved vertices into a collider.
  bool positions_only = false;
  // Positions only: the strain limit (its max_stretch) and this projection in turn (Gauss-Seidel over the
  // two), after the first projection: the limit, at most `sweeps` sweeps, with every vertex this stage
  // pushed out of a collider held (weight 0, its neighbour moves: StrainLimitStage.h, limit_stretch), then
  // the projection of the vertices the limit moved, which join the held ones; until the limit corrects
  // nothing or the projection moves nothing, at most `rounds` times. The projection keeps the last word;
  // the vertices the limit moved get v = (x - x_prev) / h.
  std::optional<cloth::StrainLimitSettings> strain_limit;
  int rounds = 8;
  int sweeps = 16;
};

class RealtimeBodyContactStage final : public cloth::Stage {
 public:
  RealtimeBodyContactStage(ColliderSetPtr colliders, RealtimeContactSettings settings = {});
  const char* name() const override {
    return settings_.positions_only ? "realtime_contact_final" : "realtime_contact";
  }
  void run(cloth::StageContext& ctx) override;
  // candidates (vertex-collider tests past the culling), contacts (responses), ccd_tests, ccd_hits,
  // unresolved (vertices left inside a collider after the passes, summed over steps), face_contacts (step 0's
  // responses); with a strain limit, strain_corrections (its spring projections).
  std::vector<std::pair<std::string, double>> counters() const override;
  const ColliderSetPtr& colliders() const { return colliders_; }
  // A positions-only stage after a constraint pass: `earlier` is the contact stage that ran before that
  // pass on the same colliders in the same step; vertices it left where they still are (not moved by the
  // pass) are skipped, they are outside every collider by its projection.
  void set_earlier(const RealtimeBodyContactStage* earlier) { earlier_ = earlier; }

  // What one collider is this step (world data for the closed-form distances); public for the helpers.
  struct Prepared {
    Vec3 lo, hi;                    // m, world box over prev and curr, inflated by the thickness
    Vec3 a0, b0, a1, b1;            // m, capsule axis ends (sphere: a = b = centre) at prev and curr
    double radius = 0.0;            // m, sphere and capsule
    Vec3 core_lo, core_hi;          // m, box over prev and curr of the axis ends (other shapes: origins)
    double reach = 0.0;             // m, the shape's extent beyond that box (radius; bounding radius)
    double motion = 0.0;            // m, bound on any surface point's displacement over the step
    double thickness = 0.0;         // m
    double swept_threshold = 0.0;   // m, relative motion above which step 3 runs
    double mu_s = 0.0, mu_k = 0.0;  // 1
    bool active = false;            // the box meets the cloth's box
  };

 private:
  struct ColliderGrid;  // the per-step collider grid over the cloth's box

  // unchanged: positions after the earlier stage (set_earlier), or null; unsettled: gets the vertices whose
  // last projection pass still moved them.
  void run_cloth(size_t index, cloth::Cloth& cloth, double h, const cloth::Vec3s* unchanged,
                 std::vector<int>& unsettled);
  // The rounds of settings_.strain_limit on one cloth after the first projection (`held`: the vertices it
  // moved); grid and prepared_ as for that projection.
  void limit_rounds(size_t index, cloth::Cloth& cloth, double h, const ColliderGrid& grid,
                    std::vector<int>& unsettled);
  // Fills the pose data of prepared_ (the same for every cloth of the step).
  void prepare_poses(const ColliderSet& set);
  // Fills the rest of prepared_ for every collider and active_ with those whose box meets the cloth's box
  // [lo, hi].
  void prepare_colliders(const ColliderSet& set, double material_thickness, const Vec3& lo, const Vec3& hi);
  ColliderGrid build_grid(const Vec3& lo, const Vec3& hi);
  // Writes into cand (kMaxCandidates at most) the active colliders whose box meets the box of the path
  // x0 -> x, in ascending order; their count.
  int gather_candidates(const ColliderGrid& grid, const Vec3& x, const Vec3& x0, int* cand) const;
  // The same set from the collider masks of cloth `index` (at most 64 colliders): refresh_masks() first in
  // the step, then per vertex i with its path x0 -> x.
  void refresh_masks(size_t index, int n);
  int masked_candidates(size_t index, int i, const Vec3& x, const Vec3& x0, int* cand);
  void sweep(const ColliderSet& set, const int* cand, int nc, const Vec3& x0, Vec3& x);
  bool project(ColliderSet& set, const int* cand, int nc, double m, const Vec3& x0, double h, Vec3& x,
               Vec3& v);
  void pinch_exit(const ColliderSet& set, const int* cand, int nc, Vec3& x);
  double thickness(const Collider& c, double material_thickness) const;
  bool limits_strain() const { return settings_.positions_only && settings_.strain_limit.has_value(); }

  ColliderSetPtr colliders_;
  RealtimeContactSettings settings_;
  std::vector<Prepared> prepared_;
  std::vector<int> active_;  // scratch: indices of active colliders
  std::vector<int> visit_;   // scratch: the vertices of a cloth this run visits
  std::vector<int> grid_start_, grid_items_,
      grid_fill_;  // scratch: the per-step collider grid (counting sort)
  // scratch: per grid entry its collider's box [lo, hi], one array per axis (tested two at a time); 2 spare
  // entries at the end
  std::vector<double> grid_lo_[3], grid_hi_[3];
  // Per cloth: the collider masks, a cache of which colliders may meet each vertex's path over several
  // steps. Collider k has a box B_k holding its box of the step (Prepared::lo/hi) inflated by a margin of a
  // few steps of its motion; vertex i a box V_i holding its path's box inflated by a few steps of its own
  // motion, and bit k of mask[i] says whether B_k meets V_i. While the step's box of k lies in B_k and the
  // path of i in V_i, k can meet the path only if bit k is set, so the candidates of i are the set bits
  // whose step box meets the path's box: the set the grid gives. A box that no longer holds its step box
  // is refitted and its bits recomputed (a collider: its bit in every vertex; a vertex: its mask).
  struct ColliderMasks {
    std::vector<double> lo[3], hi[3];  // m, per collider: B_k
    std::vector<Vec3> vlo, vhi;        // m, per vertex: V_i (NaN: none yet)
    std::vector<unsigned long long> mask;
  };
  std::vector<ColliderMasks> masks_;
  const RealtimeBodyContactStage* earlier_ = nullptr;
  std::unique_ptr<FeatureContactStage> faces_;  // step 0 (null: settings_.faces off or positions only)
  std::vector<cloth::Vec3s> after_;          // per cloth: positions at the end of this stage's last run (NaN:
                                             // a vertex its passes did not settle)
  std::vector<std::vector<int>> unsettled_;  // scratch: per cloth, vertices whose last pass moved them
  std::vector<std::vector<int>> limited_;    // per cloth: the strain limit's springs (limit_rounds)
  std::vector<char> held_;                   // scratch: per vertex of a cloth (limit_rounds)
  std::vector<int> limit_moved_;             // scratch: per vertex of a cloth (limit_rounds)
  long candidates_ = 0, contacts_ = 0, ccd_tests_ = 0, ccd_hits_ = 0, unresolved_ = 0;
  long strain_corrections_ = 0;
};

}  // namespace loom::collision
