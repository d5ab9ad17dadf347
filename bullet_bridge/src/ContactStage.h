#pragma once
// The bridge's own cloth-vs-collider contact response (private). It stands in for the collision library's
// body-collision stage until that one lands; same contract: reads the ColliderSet's prev/curr
// poses, pushes cloth vertices out to `thickness` from each collider at curr, removes the approaching
// relative normal velocity (inelastic), applies Coulomb friction to the tangential part, and sums minus the
// impulse given to the cloth into each collider's reaction_impulse / reaction_angular_impulse (moment about
// curr's origin), so the sum over cloth and colliders is exactly conserved.
// Vertices, then cloth edges (a collider's edge or corner slicing between two vertices; convex shapes).
#include <map>
#include <string>

#include "ShapeDistance.h"
#include "loom/cloth/Stage.h"
#include "loom/collision/Collider.h"

namespace loom::bullet {

class ContactStage final : public cloth::Stage {
 public:
  ContactStage(collision::ColliderSetPtr colliders, double thickness, bool edges = true)
      : colliders_(std::move(colliders)), thickness_(thickness), edges_(edges) {}
  const char* name() const override { return "bullet_contacts"; }
  void run(cloth::StageContext& ctx) override;
  std::vector<std::pair<std::string, double>> counters() const override {
    return {{"contacts", static_cast<double>(contacts_)},
            {"edge_contacts", static_cast<double>(edge_contacts_)}};
  }
  double thickness() const { return thickness_; }  // m
  // Deepest penetration (m, >= 0) below the surface seen before the push-out in the last run.
  double last_penetration() const { return last_penetration_; }

 private:
  const HullPlanes* hull_for(const collision::Collider& c);
  void edge_contacts(collision::Collider& col, const HullPlanes* hull, double reach, const Transform& back,
                     double h, cloth::ClothState& s, const cloth::ClothMesh& mesh);

  collision::ColliderSetPtr colliders_;
  double thickness_;                         // m
  bool edges_;                               // the cloth-edge pass
  std::map<std::string, HullPlanes> hulls_;  // convex colliders' planes by name
  long contacts_ = 0;
  long edge_contacts_ = 0;
  double last_penetration_ = 0.0;
};

}  // namespace loom::bullet
