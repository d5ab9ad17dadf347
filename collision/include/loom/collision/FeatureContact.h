#pragma once
// FeatureContactStage: discrete per-step contact between cloth and rigid colliders, feature against feature,
// for small steps (the real-time tier; the pipeline stage "feature_contact", after the solver). Each step,
// for every collider (its pose moves from `prev` at the step's start to `curr` at its end):
//   1. vertices: a free cloth vertex closer than the thickness to the collider at curr is moved out along the
//      signed distance's gradient to the thickness. Only where the vertex moved deeper into the collider than
//      the thickness within the step, so that the nearest face may be the wrong one, is the entry point found
//      by the continuous test (swept_point, conservative advancement) and the vertex pushed out along the
//      normal there;
//   2. faces: the collider's own features -- a sphere's centre and a capsule's axis (with their radius), the
//      edges of boxes, cylinders (12-gon rims) and convex hulls -- against cloth triangles. Each feature
//      segment is clipped to the prism over the triangle (the points whose projection lies inside it); its
//      deepest point must stay radius + thickness away from the triangle's plane on the side the feature was
//      on at the step's start. A violation moves the triangle's point under the feature by the missing depth,
//      split over the three vertices by barycentric weight and inverse mass (Bridson, Fedkiw, Anderson 2002,
//      "Robust treatment of collisions, contact and friction for cloth animation", Sec. 7.1), so a box corner
//      or a capsule's side cannot pass through a triangle whose three vertices are all outside the body;
//   3. each contact removes the approaching relative normal velocity (inelastic) and applies Coulomb friction
//      to the tangential part (Bridson et al. 2002, Sec. 7.2: stick if |v_t| <= mu_s |dv_n|, else
//      v_t *= 1 - mu_k |dv_n| / |v_t|); minus every impulse given to the cloth, and its moment about curr's
//      origin, is added to the collider's reaction_impulse / reaction_angular_impulse, so cloth and colliders
//      together conserve momentum exactly.
// Phases 1 and 2 alternate `iterations` times. Candidates come from a uniform grid over the cloth (vertices
// and triangle centroids) queried with each collider's swept box, so the cost grows with the contacts, not
// with vertices x colliders. Serial and deterministic.
#include <memory>
#include <optional>
#include <vector>

#include "loom/cloth/Stage.h"
#include "loom/collision/Collider.h"

namespace loom::collision {

struct FeatureContactSettings {
  double thickness = 0.0;                 // m; contact offset where a collider gives none (0: the material's)
  std::optional<double> friction;         // 1; kinetic coefficient for every collider (else the collider's)
  std::optional<double> static_friction;  // 1; static coefficient for every collider (else the collider's)
  int iterations = 2;                     // alternations of the vertex and face phases per step
  bool faces = true;                      // phase 2 (collider features against cloth triangles)
  // Phase 1 (cloth vertices against collider surfaces). Off: the face phase alone, for a caller with its own
  // vertex contacts (RealtimeBodyContactStage runs it before its vertex projection).
  bool vertices = true;
  // Phase 2's trigger, a fraction of the thickness in [0, 1): a feature acts on a triangle only once it is
  // closer to the triangle's plane than radius + (1 - face_slack) thickness, and then pushes it to radius +
  // thickness. 0: at once. A cloth wrapped round a rounded collider at the thickness has its triangles'
  // middles nearer than its vertices by the chord's sag (edge² / (8 (radius + thickness))); a slack above
  // that sag leaves such a cloth to the vertex contacts and acts only where a corner or an end presses into a
  // triangle.
  double face_slack = 0.0;
};

// A collider's features in its local frame: segments (a point is a segment with a == b) with a radius.
struct ColliderFeatures {
  std::vector<Vec3> a, b;  // m, local end points
  double radius = 0.0;     // m, sphere and capsule radius; 0 for polyhedral edges
};
// The features phase 2 uses: sphere centre, capsule axis, box / convex hull edges, cylinder rims and sides;
// none for planes and meshes (their vertex contacts are complete: a face cannot cross a plane unless a vertex
// does, and static meshes are two-sided sheets).
ColliderFeatures collider_features(const Collider& c);

class FeatureContactStage final : public cloth::Stage {
 public:
  FeatureContactStage(ColliderSetPtr colliders, FeatureContactSettings settings = {});
  ~FeatureContactStage() override;
  const char* name() const override { return "feature_contact"; }
  void run(cloth::StageContext& ctx) override;
  // vertex_contacts, face_contacts (responses), swept_vertices (vertices placed by the continuous test).
  std::vector<std::pair<std::string, double>> counters() const override;

  const ColliderSetPtr& colliders() const { return colliders_; }
  const FeatureContactSettings& settings() const { return settings_; }
  // Deepest penetration (m, >= 0) below a collider's surface seen before the push-out in the last step.
  double last_penetration() const { return last_penetration_; }

 private:
  struct Grid;
  struct ColliderPass;
  void run_cloth(cloth::Cloth& cloth, double h);
  // Fills cand_v_ (vertices in the swept box; all for a plane) and cand_t_ (triangles within reach of
  // collider k's features).
  void gather_candidates(const cloth::ClothState& s, size_t k, const ColliderPass& pass);
  // Phase 1: pushes candidate vertices out to the thickness and responds; `swept`: a vertex deeper than
  // the thickness is placed by the continuous test against its previous position.
  void push_vertices(cloth::ClothState& s, const ColliderPass& pass, double h, bool swept);
  // Phase 2: pushes candidate triangles off the collider's features (fa_, fb_) and responds.
  void push_triangles(cloth::ClothState& s, const cloth::ClothMesh& mesh, const ColliderPass& pass,
                      const ColliderFeatures& f, double h, bool have_prev);

  ColliderSetPtr colliders_;
  FeatureContactSettings settings_;
  std::vector<ColliderFeatures> features_;  // per collider, this step
  std::unique_ptr<Grid> grid_;
  std::vector<int> cand_v_, cand_t_;       // scratch: candidate vertices and triangles of one collider
  std::vector<Vec3> fa_, fb_, fa0_, fb0_;  // scratch: one collider's features in world at curr and prev
  double last_penetration_ = 0.0;
  long vertex_contacts_ = 0, face_contacts_ = 0, swept_vertices_ = 0;
};

// Clips the segment A + u (B - A), u in [u0, u1], to the prism over the triangle (a, b, c) with unit normal n
// (per edge: (P - e0) . (n x (e1 - e0)) >= 0). Returns false when nothing is left.
bool clip_to_prism(const Vec3& A, const Vec3& B, const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& n,
                   double& u0, double& u1);

}  // namespace loom::collision
