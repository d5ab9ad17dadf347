#pragma once
// BodyCollisionStage: cloth against rigid colliders (docs/collision.md, "Colliders"),
// the pipeline stage "body_collision" (after the solver). Each step:
//   1. colliders with a scene `motion` are sampled at t and t + h into prev/curr (others are moved by their
//      owner: a character rig, the Bullet bridge);
//   2. broad phase: FCL's dynamic AABB tree of swept collider boxes (ColliderBroadPhase) against chunks of
//      cloth vertices, then each vertex's swept box (x_prev -> x, inflated by the thickness);
//   3. cloth edges against capsule axes (discrete and continuous) and box edges (discrete), so coarse cloth
//      cannot slip between capsules or fold over a box edge; corrections split by inverse mass along the edge
//      (Bridson et al. 2002, Sec. 7.1);
//   4. per vertex, up to `max_passes` passes over its candidate colliders:
//      - continuous: the path x_prev -> x against the moving collider (swept_point, conservative
//        advancement: nothing tunnels); on a hit the vertex is carried with the body from the contact point
//        to the end of the step,
//      - proximity: a vertex closer than the thickness to the collider at curr is projected to the surface +
//        thickness, its inward normal velocity relative to the surface (incl. the collider's rotation) is
//        removed, and Coulomb friction acts on the tangential relative velocity with a static and a kinetic
//        coefficient (Bridson, Fedkiw, Anderson 2002, "Robust treatment of collisions, contact and friction
//        for cloth animation", Sec. 7.2: stick if |v_t| <= mu_s dv_n, else v_t *= 1 - mu_k dv_n / |v_t|);
//      - pinch: when the passes end with the vertex still inside one of two overlapping capsules (a crease),
//        it is moved along the sum of their normals until it is outside all of them (exit_pinch);
//      The vertex phase runs last, so its postcondition (no vertex closer than the thickness) holds at the
//      end;
//   5. the reaction -m dv of every velocity change, and its moment about curr's origin, is added to the
//      collider's reaction_impulse / reaction_angular_impulse.
// Vertices are independent (colliders do not move during the stage), so the vertex phase is a parallel loop;
// impulses are gathered in vertex order, so results are bit-identical for any thread count.
#include <optional>
#include <vector>

#include "loom/cloth/Stage.h"
#include "loom/collision/Collider.h"
#include "loom/collision/ColliderBroadPhase.h"
#include "loom/collision/FrictionPair.h"

namespace loom::collision {

struct BodyCollisionSettings {
  double thickness = 0.0;          // m; contact offset where a collider gives none (0: the cloth material's)
  std::optional<double> friction;  // 1; kinetic coefficient for every collider (else the collider's)
  std::optional<double> static_friction;  // 1; static coefficient for every collider (else the collider's)
  int max_passes = 4;                     // passes per vertex (and of the edge phase) per step
  double ccd_separation = 0.5;            // 1; the swept test's separation, as a fraction of the thickness
  bool edges = true;                      // cloth edges vs capsule axes and box edges
  // Leave ClothState::contact_normal for the vertices held against a collider in the next solve: only when
  // the solver reads them (implicit solvers with `solver.contact_filter`); else it stays empty and costs
  // nothing.
  bool contact_normals = false;
  std::vector<FrictionPair> friction_pairs;  // per (cloth, collider) pair (entries with collider >= 0): win
                                             // over the collider's and the two above
};

class BodyCollisionStage final : public cloth::Stage {
 public:
  BodyCollisionStage(ColliderSetPtr colliders, BodyCollisionSettings settings = {});
  const char* name() const override { return "body_collision"; }
  void run(cloth::StageContext& ctx) override;
  // candidate_vertices (vertex-collider pairs past the broad phase), contacts (responses), ccd_hits,
  // edge_contacts, threaded_edges (edge corrections dropped: a capsule threaded through the cloth, see
  // run_edges), passes (the most any vertex needed in a step, summed over steps), revisit_contacts
  // (responses given through revisit_vertex), unresolved (vertices the vertex phase left inside a collider:
  // a cloth pinched between two colliders, summed over steps; as RealtimeBodyContactStage's).
  std::vector<std::pair<std::string, double>> counters() const override;

  const ColliderSetPtr& colliders() const { return colliders_; }
  const BodyCollisionSettings& settings() const { return settings_; }
  // Contact thickness (m) of collider k against a cloth of material thickness `material_thickness`.
  double thickness(int k, double material_thickness) const;
  // After the last step: the largest (thickness - signed distance) over free candidate vertices, m (<= 0:
  // every vertex at least one thickness away from every collider).
  double max_deficit() const { return max_deficit_; }
  // After the last step: per vertex of cloth `c`, 1 if it ended within two thicknesses of a collider (the
  // self-collision stage makes these vertices heavy, so that cloth-cloth impulses push the other layer away
  // instead of pushing them into the body); null before the first step.
  const std::vector<char>* near_collider(int c) const {
    return c < static_cast<int>(near_.size()) ? &near_[c] : nullptr;
  }

  // A velocity change given to the cloth by collider `collider` (its reaction is minus this).
  struct Reaction {
    int collider;
    Vec3 impulse;  // N s, given to the cloth
    Vec3 point;    // m, where
  };
  // For a stage after this one in the same step that moved free vertex x of cloth `cloth_index` (the
  // self-collision stage): path x0 -> x, velocity v (m/s), mass m (kg); x_body is where this stage left it.
  // If x moved at least a quarter thickness from x_body and its path now crosses a collider (the continuous
  // test) or it ends closer than `fraction` x the thickness to one, step 4 is done again for it (x and v
  // replaced, responses appended to `out`) and true is returned. Const and thread-safe; hand `out` to
  // add_reactions afterwards, in a fixed order.
  bool revisit_vertex(int cloth_index, const Vec3& x0, const Vec3& x_body, Vec3& x, Vec3& v, double m,
                      double fraction, std::vector<Reaction>& out) const;
  void add_reactions(const std::vector<Reaction>& reactions);

 private:
  struct Pair {                     // what one collider is to one cloth this step
    double thickness = 0.0;         // m
    double mu_s = 0.0, mu_k = 0.0;  // 1
  };
  void run_cloth(cloth::Cloth& cloth, int cloth_index, double h, int threads);
  struct EdgeCorrection;
  void run_edges(cloth::Cloth& cloth, double h, int threads, std::vector<Reaction>& records);
  // One pass's correction of every edge against the first of `edge_colliders` (capsules and boxes) that its
  // interior touches; returns how many edges have one.
  long find_edge_corrections(const cloth::Cloth& cloth, double h, int threads,
                             const std::vector<int>& edge_colliders, std::vector<EdgeCorrection>& corr) const;
  // The correction of edge (a, b) against collider k; false (cr untouched) when there is none.
  bool edge_correction(const cloth::ClothState& s, int a, int b, int k, double material_thickness, double h,
                       EdgeCorrection& cr) const;
  // Drops the corrections of edges at a vertex threaded by a capsule; returns how many corrections remain.
  long drop_threaded_edges(const cloth::Cloth& cloth, std::vector<EdgeCorrection>& corr);
  // Applies the remaining corrections (Jacobi-averaged per vertex), appending their reactions to `records`.
  void apply_edge_corrections(cloth::Cloth& cloth, std::vector<EdgeCorrection>& corr,
                              std::vector<Reaction>& records);
  // final_d (optional): per entry of `mine`, the signed distance (m) at the returned x; left empty when the
  // last pass still changed x (then the caller evaluates it).
  int respond_vertex(const std::vector<int>& mine, const std::vector<Pair>& pairs, const Vec3& x0, Vec3& x,
                     Vec3& v, double m, double h, std::vector<Reaction>& out, long& contacts, long& ccd_hits,
                     std::vector<double>* final_d = nullptr) const;
  // After the passes left a vertex inside a capsule (a pinch between two): moves it out of all of `mine`
  // (nothing when a non-capsule collider is within its thickness).
  void exit_pinch(const std::vector<int>& mine, const std::vector<Pair>& pairs, Vec3& x, Vec3& v, double m,
                  double h, std::vector<Reaction>& out, long& contacts) const;

  ColliderSetPtr colliders_;
  BodyCollisionSettings settings_;
  ColliderBroadPhase broad_phase_;
  double max_deficit_ = 0.0;
  std::vector<std::vector<char>> near_;   // per cloth, per vertex: near a collider after the last step
  std::vector<std::vector<Pair>> pairs_;  // per cloth, per collider, this step
  std::vector<double> min_thickness_;     // m, per cloth: smallest contact thickness this step
  double h_ = 0.0;                        // s, this step
  long candidates_ = 0, contacts_ = 0, ccd_hits_ = 0, edge_contacts_ = 0, threaded_edges_ = 0, passes_ = 0,
       revisits_ = 0, unresolved_ = 0;
};

}  // namespace loom::collision
