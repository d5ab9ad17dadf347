// scenes/buckling_wrinkles.json: a cotton sheet pushed together by 20% between two moving edges.
// Run with Choi-Ko and with linear springs: both stay finite at the scene's BDF2 step and fold out of plane;
// the measured in-plane compression of the structural springs is printed (docs/validation.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace loom::scene {
namespace {

struct SheetResult {
  double fold_height = 0.0;       // m, max - min height over the middle row across the fold direction
  double mean_compression = 0.0;  // 1, mean max(0, 1 - l/L) over structural springs along u
  double worst_compression = 0.0;
  bool finite = true;
};

SheetResult run(const std::string& model, double seconds) {
  const std::string path = std::string(LOOM_SOURCE_DIR) + "/scenes/buckling_wrinkles.json";
  Scene sc = load_scene(path, {"cloths[0].model=" + model});
  auto sim = build_simulation(sc);
  const int frames = static_cast<int>(std::lround(seconds * 30));
  for (int f = 0; f < frames; ++f) sim->step_frame();
  const cloth::Cloth& c = *sim->cloths()[0];
  const cloth::ClothMesh& mesh = *c.mesh_ptr();
  const cloth::Vec3s& x = c.state().x;
  SheetResult r;
  for (const cloth::Vec3& p : x) r.finite = r.finite && p.allFinite();
  int count = 0;
  for (const cloth::SpringDef& d : mesh.springs()) {
    if (d.kind != cloth::SpringKind::kStructural || d.rest_uv_dir.x() < 0.9) continue;  // along u (the push)
    const double strain = (x[d.j] - x[d.i]).norm() / d.rest_length - 1.0;
    r.mean_compression += std::max(0.0, -strain);
    r.worst_compression = std::max(r.worst_compression, -strain);
    ++count;
  }
  r.mean_compression /= std::max(count, 1);
  const int nu = mesh.grid_nodes_u(), mid = mesh.grid_nodes_v() / 2;
  double lo = 1e9, hi = -1e9;
  for (int iu = 0; iu < nu; ++iu) {
    const double y = x[mesh.grid_index(iu, mid)].y();
    lo = std::min(lo, y);
    hi = std::max(hi, y);
  }
  r.fold_height = hi - lo;
  return r;
}

TEST(BucklingScene, SheetPushedTogetherFoldsOutOfPlane) {
  const SheetResult ck = run("choi_ko", 1.2), sp = run("springs", 1.2);
  std::printf("choi_ko: fold %.4f m, mean compression %.5f, worst %.4f\n", ck.fold_height,
              ck.mean_compression, ck.worst_compression);
  std::printf("springs: fold %.4f m, mean compression %.5f, worst %.4f\n", sp.fold_height,
              sp.mean_compression, sp.worst_compression);
  ASSERT_TRUE(ck.finite);
  ASSERT_TRUE(sp.finite);
  // 20% of 30 cm taken up out of plane: a fold of several centimetres, not a flat compressed sheet.
  EXPECT_GT(ck.fold_height, 0.03);
}

}  // namespace
}  // namespace loom::scene
