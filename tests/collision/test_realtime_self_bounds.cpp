// RealtimeSelfCollisionStage's candidate list. Against an exploding cloth: a triangle whose box spans more
// cells than kMaxBoxCells is never entered cell by cell (the grid work stays bounded whatever its size) but
// tested against every vertex, so the candidate list stays exact. Against fast motion: the list is a cache
// whose margins and padding never change the result.
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

// Two horizontal sheets, the upper one falling onto the lower one at `speed` (m/s) while one of its
// corners is flung sideways ten times faster; the stage run after each step's motion.
struct Falling {
  std::vector<std::unique_ptr<cloth::Cloth>> cloths;
  Falling() {
    for (double y : {0.0, 0.05}) {
      cloth::GridSpec g;
      g.nodes_u = g.nodes_v = 9;
      g.origin = cloth::Vec3(0.0, y, 0.0);
      cloths.push_back(std::make_unique<cloth::Cloth>(y == 0.0 ? "low" : "high", cloth::ClothMesh::grid(g),
                                                      cloth::Material{}));
    }
  }
  void step(RealtimeSelfCollisionStage& stage, double h, double speed) {
    cloth::ClothState& s = cloths[1]->state();
    for (auto& v : s.v) v = cloth::Vec3(0.0, -speed, 0.0);
    s.v[0] = cloth::Vec3(10.0 * speed, -speed, 0.0);
    for (int i = 0; i < s.size(); ++i) s.x[i] += h * s.v[i];
    cloth::StageContext ctx{cloths, 0.0, h, 1};
    stage.run(ctx);
  }
};

// The candidate list is a cache: the vertex margins from the velocities (and the padding) decide how long a
// list lasts, never the result. A padding of 5 mm (a list rebuilt at almost every run) and one of 10 cm give
// the same positions bit for bit through the contact of two sheets with a corner flung across the other.
TEST(RealtimeSelfBounds, MarginsAndPaddingNeverChangeTheResult) {
  Falling a, b;
  RealtimeSelfSettings narrow, wide;
  narrow.padding = 0.005;
  wide.padding = 0.1;
  RealtimeSelfCollisionStage sa(narrow), sb(wide);
  for (int k = 0; k < 60; ++k) {
    a.step(sa, 1e-3, 1.0);
    b.step(sb, 1e-3, 1.0);
    for (size_t c = 0; c < a.cloths.size(); ++c)
      for (int i = 0; i < a.cloths[c]->state().size(); ++i)
        ASSERT_EQ(a.cloths[c]->state().x[i], b.cloths[c]->state().x[i]) << "step " << k << " cloth " << c;
  }
  EXPECT_GT(counters_of(sa).at("contacts"), 0.0);  // the sheets met
  EXPECT_EQ(counters_of(sa).at("contacts"), counters_of(sb).at("contacts"));
  EXPECT_LT(counters_of(sb).at("broad_phases"), counters_of(sa).at("broad_phases"));
}

// A vertex faster than the rest gets a margin for its own motion: the list is not rebuilt at every run
// although that vertex moves 2 cm per run, more than half the 2 cm padding.
TEST(RealtimeSelfBounds, AFastVertexDoesNotRebuildTheListAtEveryRun) {
  Falling f;
  RealtimeSelfCollisionStage stage(RealtimeSelfSettings{});
  for (int k = 0; k < 20; ++k) f.step(stage, 1e-3, 2.0);
  const auto c = counters_of(stage);
  EXPECT_EQ(c.at("runs"), 20.0);
  EXPECT_LE(c.at("broad_phases"), 10.0);
}

}  // namespace
}  // namespace loom::collision
