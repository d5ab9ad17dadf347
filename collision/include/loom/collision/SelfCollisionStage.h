#pragma once
// SelfCollisionStage: self-collision of each cloth and collision between cloths (multi-layer garments), as
// one pipeline stage after the solver (docs/collision.md). The solver's step moved every
// vertex from x_prev (intersection-free) to a candidate x; this stage changes x (and v by the same amount /
// h) so that the straight path x_prev -> x is free of intersections:
//   1. BVH update: one ClothBvh per cloth (material space, leaves = swept boxes inflated by half the cloth's
//      thickness); candidate triangle pairs = self pairs of each cloth (with `self`) + cross pairs of every
//      two cloths. Self pairs of a node whose patch is a flat-enough disk are culled by normal cones
//      (Volino & Magnenat-Thalmann 1994; Provot 1997): cone half-angle < 90 deg over the whole step and a
//      simple projected contour; pairs between cloths are never culled.
//   2. Proximity: vertex-face and edge-edge pairs closer than the pair thickness at x_prev get a repulsion
//      impulse and Coulomb friction (Bridson, Fedkiw, Anderson 2002, Sec. 7.2-7.3). Rest neighbours (features
//      of one cloth closer than twice its thickness in the rest mesh) have their pair thickness capped at
//      half their rest distance everywhere (2-4 too): one patch of cloth, not a contact, yet never left
//      untested.
//   3. Up to `passes` passes of continuous tests (Ccd.h, conservative, minimum separation) on x_prev -> x
//      with inelastic impulses; every pass after the first tests only pairs touching vertices that moved or
//      hit in the previous pass (I-Cloth, Tang et al. 2018, incremental sets).
//   4. Fail-safe: impact zones. Vertices of remaining contacts are merged into zones; a zone is first
//   resolved
//      by inelastic projection over its contacts (Harmon et al. 2008: normal approach cancelled, sliding
//      kept); a zone still colliding after 4 projections becomes a rigid impact zone (Provot 1997; Bridson et
//      al. 2002 Sec. 7.4): its velocities replaced by its rigid-body motion (momentum and angular momentum
//      kept), repeated until no contact is left between zones. A zone moved by the linearised rigid motion is
//      an invertible affine image of its intersection-free start at every t, so it cannot self-intersect;
//      merging ends, at worst, with one zone. Zones with kinematic (pinned) vertices follow the best-fit
//      rotation of their pinned vertices (Kabsch 1976) instead; that case is not guaranteed.
//   5. Colliders (with a body stage, set_body_stage): every free vertex moved by 2-4 whose end point came
//      closer than half the thickness to a collider, or whose path now crosses one, gets the body stage's
//      vertex response again (BodyCollisionStage::revisit_vertex) and is then held (inverse mass 0) while
//      3-4 run again on the pairs around it (a rigid zone takes held vertices back and moves them with it,
//      to be checked again); at most 16 such rounds, the last one's projections stand. So
//      no free vertex ends a step closer than half its thickness to a collider, also with several colliders
//      or a cloth squeezed between two; the census stays 0 when 3-4 can resolve around the held vertices.
// Impulses are computed per contact in parallel and applied per vertex in a fixed order (averaged over the
// vertex's contacts), so results are bit-identical for any thread count.
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "loom/cloth/Stage.h"
#include "loom/collision/ClothBvh.h"
#include "loom/collision/FrictionPair.h"

namespace loom::collision {

struct SelfCollisionSettings {
  bool self = true;  // collisions within each cloth; pairs between cloths are always handled
  std::vector<double>
      thickness;           // m, per cloth (layer); empty or <= 0 entries: the cloth's material thickness
  double friction = -1.0;  // 1, kinetic Coulomb coefficient; < 0: mean of the two cloths' materials
  double static_friction = -1.0;  // 1, static coefficient; < 0: equal to the kinetic one
  // Per cloth pair (entries with other_cloth >= 0; the collider entries are the body stage's): win over the
  // two above for that pair.
  std::vector<FrictionPair> friction_pairs;
  int passes = 4;            // continuous-test passes with impulses before the impact-zone fail-safe
  double separation = 0.25;  // 1, CCD minimum separation in the passes, as a fraction of the pair thickness
  double repulsion = 0.1;    // 1, share of the thickness overlap removed per step by repulsion (Bridson 2002)
  bool normal_cones = true;  // cull self pairs of flat patches (never pairs between cloths)
  int max_zone_iterations = 200;  // fail-safe rounds before every vertex goes into one zone
  // Work bound of the fail-safe: vertex-face and edge-edge features tested by the impact zones in one step,
  // per cloth vertex. A cloth crushed into a box stays at a few thousand per vertex in a step; a torn or
  // exploded one (triangles spanning the whole cloth) tests thousands per vertex in every round. Past the
  // bound, every vertex moves as one rigid zone and the step is reported (violation()), so the guard retries
  // or stops the run with that cause instead of the step running for hours.
  double zone_features_per_vertex = 2e4;
  double near_body_mass = 1e3;  // 1, mass factor of vertices the body stage left near a collider
  // 1, the largest velocity change a cloth-cloth impulse gives one vertex, as a multiple of the contact's
  // relative velocity change (capped_shares, SelfProximity.cpp); <= 0 or infinite: Bridson's shares unbounded
  double max_share = 1.0;
};

// Shares beta_k (k = the contact's four vertices) of a cloth-cloth contact's velocity change: vertex k
// changes by beta_k dv, with sum_k w_k beta_k = 1 for the barycentric weights w_k, the least mass-weighted
// change under |beta_k| <= cap (cap <= 0 or infinite: Bridson et al. 2002's unbounded shares); im = inverse
// masses. The first `first` vertices are one feature (w_k >= 0: the point of a vertex-face pair, first = 1,
// or an edge, first = 2), the others the second (w_k <= 0). Where no movable vertex is left below the bound,
// every movable vertex takes the bound on its feature's side, w_k = 0 included (each feature moves as a
// block), and the rest is left to the next pass. Returns false when no vertex can move.
bool capped_shares(const double w[4], const double im[4], int first, double cap, double beta[4]);

class BodyCollisionStage;

class SelfCollisionStage final : public loom::cloth::Stage {
 public:
  explicit SelfCollisionStage(SelfCollisionSettings settings) : settings_(std::move(settings)) {}
  // The body-collision stage that runs before this one (optional): vertices it left near a collider count
  // `near_body_mass` times heavier here, so cloth-cloth responses move the other cloth, not these into the
  // body (layers stacked on a body, a tablecloth under objects).
  // It also hands back every free vertex this stage moved into a collider (or whose path it moved through
  // one): step 5 below.
  void set_body_stage(BodyCollisionStage* body) { body_ = body; }
  const char* name() const override { return "self_collision"; }
  void run(loom::cloth::StageContext& ctx) override;
  // "" or, for the last step, that the impact zones ran past their work bound
  // (SelfCollisionSettings::zone_features_per_vertex).
  std::string violation() const override { return zone_budget_violation_; }
  // candidate_pairs (triangle pairs from the BVHs), features (their vertex-face and edge-edge features that
  // passed the box filter), culled_nodes (normal-cone culls), contacts (proximity +
  // continuous contacts given impulses), passes (continuous-test passes), impact_zones (zones formed),
  // zone_iterations, projections (inelastic projections of a zone), rigid_zones (zones that went rigid),
  // bvh_rebuilds, ccd_tests and ccd_boxes (continuous tests in the passes, inclusion boxes), ccd_start_hits
  // (pairs of the passes closer than the separation at the step's start: hits at t = 0 without a continuous
  // test), unresolved (steps that ended with a forced global zone), collider_fixes (vertices handed back to
  // the body stage), collider_rounds, zone_ccd_cut (the impact zones' continuous tests that ran out of their
  // 4096-box budget and so count as hits); all since the start. Phase wall times (ms since the start):
  // bvh_ms, pairs_ms (the step's first search, all_features, includes its feature extraction), features_ms
  // (the other searches' extraction), proximity_ms, ccd_ms, zones_ms (the zones' own searches counted in it
  // and in their phases).
  std::vector<std::pair<std::string, double>> counters() const override;

 private:
  struct Feature {  // vertex-face (a = vertex, b = triangle) or edge-edge (a < b, edges); global indices
    int type = 0;   // 0 VF, 1 EE
    int a = 0, b = 0;
    float cap = HUGE_VALF;  // m, the pair thickness' cap for rest neighbours (rest_cap), else infinite
    // m, a lower bound on the two features' distance at x0 (fixed during the step), left by the proximity
    // phase for the continuous passes; < 0: unknown.
    float d0 = -1.0f;
    bool operator<(const Feature& o) const {
      return type != o.type ? type < o.type : a != o.a ? a < o.a : b < o.b;
    }
    bool operator==(const Feature& o) const { return type == o.type && a == o.a && b == o.b; }
  };
  struct Contact {  // the four vertices of a feature with weights: relative motion = sum w_i x_i
    int v[4] = {0, 0, 0, 0};
    double w[4] = {0, 0, 0, 0};
    int cloth_a = 0, cloth_b = 0;
    double cap = HUGE_VAL;  // m, Feature::cap
  };

  void setup(loom::cloth::StageContext& ctx);
  void update_bvhs(int threads, bool full_update);
  // The step's features of all candidate pairs (self pairs culled by normal cones, pairs between cloths).
  std::vector<Feature> all_features(int threads);
  std::vector<TrianglePair> triangle_pairs_touching(const std::vector<char>& dirty, int threads);
  std::vector<Feature> features(const std::vector<TrianglePair>& pairs, const std::vector<char>* dirty,
                                int threads) const;
  void extract_features(const TrianglePair* pairs, long n, const std::vector<char>* dirty,
                        std::vector<Feature>& out) const;
  std::vector<Feature> extract_in_chunks(const std::vector<TrianglePair>& pairs,
                                         const std::vector<char>* dirty, int threads) const;
  void vertex_boxes(int threads) const;
  Contact contact_of(const Feature& f) const;
  // m: the mean of the two cloths' thicknesses, capped for rest neighbours (Contact::cap).
  double pair_thickness(const Contact& c) const;
  // Rest neighbours (setup_rest_neighbours): features of one cloth closer than twice its thickness in the
  // rest mesh. Returns the cap of their pair thickness, half their rest distance (m), or infinity.
  float rest_cap(const Feature& f) const;
  void setup_rest_neighbours(const loom::cloth::StageContext& ctx);
  // Proximity impulses over `fs` (all features); marks the vertices it moved in `moved`, and leaves in each
  // feature a lower bound on its distance at x0 (Feature::d0).
  void proximity(std::vector<Feature>& fs, int threads, std::vector<char>& moved);
  void first_pass_features(std::vector<Feature>& fs, const std::vector<char>& moved, int threads);
  // One continuous pass over `fs`; returns whether any pair hit, marks moved/hit vertices in `dirty`.
  bool ccd_pass(const std::vector<Feature>& fs, int threads, std::vector<char>& dirty);
  bool impact_zones(std::vector<char> dirty, int threads);
  // Continuous passes then the fail-safe: the first pass over `first` when given, else (and after) over the
  // features touching `dirty` vertices.
  void resolve(std::vector<char>& dirty, const std::vector<Feature>* first, int threads);
  bool collider_round(loom::cloth::StageContext& ctx, std::vector<char>& dirty, int threads);
  static constexpr int kColliderRounds = 16;
  struct ZoneConstraint {  // n . sum_i w_i x1_{v_i} >= b (inelastic projection, Harmon et al. 2008)
    int v[4] = {0, 0, 0, 0};
    double w[4] = {0, 0, 0, 0};
    Vec3 n = Vec3::Zero();
    double b = 0.0;  // m
  };
  bool project_zone(const std::vector<int>& constraints);
  void apply_rigid_zone(const std::vector<int>& verts);
  // The three parts of one impact-zone round (ImpactZones.cpp).
  void zone_hits(const std::vector<Feature>& fs, const std::vector<int>& zone_rounds, int threads,
                 std::vector<char>& hit, std::vector<ZoneConstraint>& found);
  bool merge_zone_hits(const std::vector<Feature>& fs, const std::vector<char>& hit,
                       const std::vector<ZoneConstraint>& found, std::vector<int>& zone_rounds,
                       std::vector<int>& roots_changed);
  void move_changed_zones(const std::vector<int>& roots_changed, std::vector<int>& zone_rounds,
                          std::vector<char>& dirty);

  SelfCollisionSettings settings_;
  BodyCollisionStage* body_ = nullptr;
  double h_ = 0.0;
  // Global numbering over all cloths, set up on the first run.
  int num_cloths_ = 0;
  std::vector<int> vertex_offset_, tri_offset_;
  std::vector<int> vertex_cloth_, tri_cloth_, edge_cloth_;
  std::vector<loom::cloth::Tri> tris_;         // global vertex indices
  std::vector<std::array<int, 2>> edges_;      // global vertex indices
  std::vector<std::array<int, 3>> tri_edges_;  // global edge indices
  std::vector<int> vtx_tri_start_, vtx_tri_;   // vertex -> triangles (CSR, ascending)
  std::vector<int> edge_owner_;                // edge -> lowest-numbered triangle holding it
  std::vector<unsigned char> tri_owns_;        // triangle -> owner bits (vertices 0-2, edges 3-5)
  std::vector<double> cloth_thickness_, cloth_friction_;
  // Rest neighbours with their caps (m): vertex -> (triangle, cap), CSR; edge -> (higher edge, cap), CSR.
  std::vector<int> rest_vf_start_, rest_ee_start_;
  std::vector<std::pair<int, float>> rest_vf_, rest_ee_;
  std::vector<double> pair_mu_k_, pair_mu_s_;  // 1, per cloth pair (num_cloths_^2, symmetric)
  std::vector<std::unique_ptr<ClothBvh>> bvhs_;
  std::vector<loom::cloth::Vec3s> cx0_, cx1_;  // m, per cloth: the positions of the last BVH refit
  // Per step.
  loom::cloth::Vec3s x0_, x1_, x1_solver_;        // m: start, current end, end as the solver left it
  std::vector<double> w_, m_;                     // 1/kg inverse masses, kg masses
  std::vector<double> w_free_;                    // 1/kg, w_ before any vertex was held for a collider
  std::vector<char> near_;                        // 1: the body stage left the vertex near a collider
  std::vector<char> fixed_;                       // 1: handed back to the body stage this step, held since
  loom::cloth::Vec3s fixed_v_;                    // m/s, the velocity the body stage gave a fixed vertex
  std::vector<int> zone_parent_;                  // union-find over vertices for impact zones (-1: no zone)
  std::vector<ZoneConstraint> zone_constraints_;  // the contacts found by the fail-safe this step
  // Counters.
  long candidate_pairs_ = 0, contacts_ = 0, passes_ = 0, impact_zones_ = 0, zone_iterations_ = 0;
  long bvh_rebuilds_ = 0, unresolved_ = 0, culled_nodes_ = 0, ccd_tests_ = 0, ccd_boxes_ = 0;
  long projections_ = 0, rigid_zones_ = 0, collider_fixes_ = 0, collider_rounds_ = 0, ccd_start_hits_ = 0;
  std::string zone_budget_violation_;
  long zone_ccd_cut_ = 0;  // the impact zones' continuous tests cut short by their box budget (hits)
  // Phase wall times since the start (ms): BVH refit/rebuild, triangle-pair search, feature extraction,
  // proximity impulses, continuous passes, impact zones (the zones' own searches included).
  double bvh_ms_ = 0.0, pairs_ms_ = 0.0, proximity_ms_ = 0.0, ccd_ms_ = 0.0, zones_ms_ = 0.0;
  mutable double features_ms_ = 0.0;
  mutable std::vector<Aabb> vbox_;  // m, per vertex: swept box of x0 -> x1 at the last feature search
  mutable long features_ = 0;       // features extracted from candidate pairs (all calls)
};

}  // namespace loom::collision
