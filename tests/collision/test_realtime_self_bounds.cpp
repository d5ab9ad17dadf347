// RealtimeSelfCollisionStage against an exploding cloth: a triangle whose box spans more cells than
// kMaxBoxCells is never entered cell by cell (the hash work stays bounded whatever its size) but tested
// against every vertex, so the candidate list stays exact.
#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <vector>

#include "loom/cloth/Cloth.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Stage.h"
#include "loom/cloth/StateArchive.h"
#include "loom/collision/RealtimeSelfCollision.h"

namespace loom::collision {
namespace {

std::map<std::string, double> counters_of(const RealtimeSelfCollisionStage& s) {
  std::map<std::string, double> m;
  for (const auto& [k, v] : s.counters()) m[k] = v;
  return m;
}

std::vector<std::unique_ptr<cloth::Cloth>> sheet() {
  cloth::GridSpec g;
  g.nodes_u = g.nodes_v = 6;
  std::vector<std::unique_ptr<cloth::Cloth>> cloths;
  cloths.push_back(std::make_unique<cloth::Cloth>("sheet", cloth::ClothMesh::grid(g), cloth::Material{}));
  return cloths;
}

TEST(RealtimeSelfBounds, AnExplodedTriangleIsTestedAgainstEveryVertexNotCellByCell) {
  for (const double far : {1e3, 1e9, 1e300}) {
    auto cloths = sheet();
    const int n = cloths[0]->state().size();
    const int nt = cloths[0]->mesh().num_triangles();
    // One corner flung `far` away along the diagonal: its triangles' boxes span up to (far / cell)^3 cells.
    cloths[0]->state().x[0] = cloth::Vec3(far, far, far);
    // A vertex of another part of the sheet lifted into the exploded triangles' boxes (above the sheet).
    cloths[0]->state().x[n - 1] = cloth::Vec3(1.0, 1.0, 1.0);
    RealtimeSelfSettings settings;
    RealtimeSelfCollisionStage stage(settings);
    cloth::StageContext ctx{cloths, 0.0, 1e-3, 1};
    stage.run(ctx);
    const auto c = counters_of(stage);
    EXPECT_EQ(c.at("broad_phases"), 1.0) << far;
    EXPECT_GE(c.at("large_boxes"), 1.0) << far;  // the corner's triangles
    EXPECT_LE(c.at("hash_entries"), RealtimeSelfCollisionStage::kMaxBoxCells * nt) << far;
    // The lifted vertex lies in an exploded triangle's box: it is a candidate although that box was never
    // entered into the hash.
    EXPECT_GE(c.at("candidates"), 1.0) << far;
  }
}

TEST(RealtimeSelfBounds, ASaneSheetUsesTheHashOnly) {
  auto cloths = sheet();
  RealtimeSelfCollisionStage stage(RealtimeSelfSettings{});
  cloth::StageContext ctx{cloths, 0.0, 1e-3, 1};
  stage.run(ctx);
  EXPECT_EQ(counters_of(stage).at("large_boxes"), 0.0);
  EXPECT_GT(counters_of(stage).at("hash_entries"), 0.0);
}

// The guard saves every stage's state at the frame start and restores it when it retries a frame; for the
// first frame that state was saved before the stage ever ran (no sides, no list). A run after such a restore
// takes the current positions as it does at the first run, and resolves the contact.
TEST(RealtimeSelfBounds, AStateSavedBeforeTheFirstRunRestoresCleanly) {
  auto cloths = sheet();
  RealtimeSelfCollisionStage stage(RealtimeSelfSettings{});
  cloth::StateWriter before;
  stage.save_state(before);
  cloth::StageContext ctx{cloths, 0.0, 1e-3, 1};
  stage.run(ctx);
  cloth::StateReader in(before.data(), "frame start");
  stage.load_state(in);
  // The last vertex laid on the middle of a far triangle, 1 mm above it: a self contact.
  const auto& mesh = cloths[0]->mesh();
  cloth::ClothState& s = cloths[0]->state();
  const cloth::Tri t = mesh.triangles()[0];
  const cloth::Vec3 a = s.x[t[0]], b = s.x[t[1]], c = s.x[t[2]];
  const cloth::Vec3 nrm = (b - a).cross(c - a).normalized();
  const int n = s.size();
  s.x[n - 1] = (a + b + c) / 3.0 + 1e-3 * nrm;
  stage.run(ctx);
  EXPECT_GE(counters_of(stage).at("contacts"), 1.0);
  for (const auto& x : s.x) EXPECT_TRUE(x.allFinite());
  // Pushed out to the self thickness on the side it started on.
  EXPECT_GT((s.x[n - 1] - s.x[t[0]]).dot(nrm), 0.0);
}

}  // namespace
}  // namespace loom::collision
