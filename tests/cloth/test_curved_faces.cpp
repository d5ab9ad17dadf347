// Hybrid detail, curved faces (issue 10): the PN-triangle surface interpolates the coarse vertices, is exact on
// flat cloth, follows a curved sheet far better than the flat facets, moves continuously with the coarse mesh
// (no popping), and on the settled hanging cloth stays close to a full fine-resolution simulation.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "TestUtil.h"
#include "loom/cloth/CurvedFaces.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {
namespace {

std::shared_ptr<const ClothMesh> grid(int n, double size = 1.0) {
  GridSpec g;
  g.size_u = g.size_v = size;
  g.nodes_u = g.nodes_v = n;
  g.origin = Vec3(-0.5 * size, 1.0, -0.5 * size);
  return ClothMesh::grid(g);
}

TEST(CurvedFaces, SubdividesAndInterpolatesTheCoarseVertices) {
  auto coarse = grid(5);
  for (int levels : {0, 1, 2, 3}) {
    CurvedFaces cf(*coarse, levels);
    const int per = 1 << levels;  // fine edges per coarse edge
    EXPECT_EQ(cf.fine_mesh()->num_triangles(), coarse->num_triangles() * per * per);
    EXPECT_EQ(cf.fine_mesh()->num_vertices(), (4 * per + 1) * (4 * per + 1));
    std::mt19937 rng(3);
    const Vec3s x = test::perturbed(coarse->rest_positions(), 0.05, rng);
    Vec3s fine;
    cf.evaluate(x, fine);
    for (int i = 0; i < coarse->num_vertices(); ++i) EXPECT_LT((fine[cf.fine_vertex_of(i)] - x[i]).norm(), 1e-12);
  }
  EXPECT_THROW(CurvedFaces(*coarse, 6, "scene.json", "cloths[0].detail"), Error);
}

TEST(CurvedFaces, FlatClothStaysFlatAndCurvedClothIsFollowed) {
  auto coarse = grid(9);
  CurvedFaces cf(*coarse, 2);
  Vec3s fine;
  // Flat and rotated: the fine surface is the flat sheet itself (linear precision of PN triangles).
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  Vec3s x = coarse->rest_positions();
  for (Vec3& p : x) p = R * p;
  cf.evaluate(x, fine);
  double off = 0.0;
  for (int i = 0; i < cf.fine_mesh()->num_vertices(); ++i)
    off = std::max(off, (fine[i] - R * cf.fine_mesh()->rest_positions()[i]).norm());
  EXPECT_LT(off, 1e-12);
  // Rolled on a cylinder of radius 0.3 m (axis along z): distance of the fine vertices to the cylinder, PN
  // surface against the flat facets (the coarse mesh linearly subdivided).
  const double r = 0.3;
  auto roll = [&](const Vec3& p) { return Vec3(r * std::sin(p.x() / r), 1.0 - r * (1.0 - std::cos(p.x() / r)), p.z()); };
  for (int i = 0; i < coarse->num_vertices(); ++i) x[i] = roll(coarse->rest_positions()[i]);
  cf.evaluate(x, fine);
  double pn_err = 0.0, flat_err = 0.0;
  const Vec3 axis(0.0, 1.0 - r, 0.0);
  // Away from the sheet's two curved edges (where the vertex normals are one-sided): |x| < 0.5 - 1/8 at rest.
  double pn_edge = 0.0;
  for (int i = 0; i < cf.fine_mesh()->num_vertices(); ++i) {
    const Vec3& p = fine[i];
    const double e = std::abs(std::hypot(p.x() - axis.x(), p.y() - axis.y()) - r);
    if (std::abs(cf.fine_mesh()->rest_positions()[i].x()) < 0.5 - 0.125 + 1e-9)
      pn_err = std::max(pn_err, e);
    else
      pn_edge = std::max(pn_edge, e);
  }
  // Flat facets: the midpoint of a coarse edge of length a lies r (1 - cos(a / 2r)) inside the cylinder.
  const double a = 1.0 / 8.0;
  flat_err = r * (1.0 - std::cos(a / (2.0 * r)));
  std::printf("cylinder r = 0.3 m, coarse edge 0.125 m: PN surface off the cylinder by %.3g m (%.3g m in the "
              "cells along the free edges), flat facets by %.3g m\n", pn_err, pn_edge, flat_err);
  EXPECT_LT(pn_err, 0.1 * flat_err);
  EXPECT_LT(pn_edge, flat_err);
}

// RMS and max distance between the detail surface and a fine simulation, at the
// same material points (the subdivided coarse grid and the fine grid share their nodes).
struct Distance {
  double rms = 0.0, max = 0.0;
};
Distance distance(const CurvedFaces& cf, const Vec3s& detail, const ClothMesh& fine_mesh, const Vec3s& fine_x) {
  Distance d;
  int count = 0;
  const Vec3s& rest = cf.fine_mesh()->rest_positions();
  for (int i = 0; i < fine_mesh.num_vertices(); ++i) {
    const Vec3& X = fine_mesh.rest_positions()[i];
    int best = 0;
    for (int j = 1; j < static_cast<int>(rest.size()); ++j)
      if ((rest[j] - X).squaredNorm() < (rest[best] - X).squaredNorm()) best = j;
    const double e = (detail[best] - fine_x[i]).norm();
    d.rms += e * e;
    d.max = std::max(d.max, e);
    ++count;
  }
  d.rms = std::sqrt(d.rms / count);
  return d;
}

TEST(CurvedFaces, ContinuousInTimeAndCloseToAFineSimulation) {
  // The hanging sheet (1 m cotton, two corners pinned), coarse 9 x 9 with 2 levels of detail (33 x 33 fine
  // vertices) against a full 33 x 33 simulation; the same solver (implicit_euler, 60 Hz, drag to settle it).
  auto setup = [](int n) {
    SimulationSetup s = test::hanging_sheet(n);
    s.cloths[0].model = "baraff_witkin";
    s.solver.method = "implicit_euler";
    s.drag = DragSettings{};
    s.drag->isotropic = 2.0;  // kg/(m²·s): settles the swing in about a second
    return s;
  };
  const int frames = 150;
  Simulation coarse(setup(9));
  CurvedFaces cf(coarse.cloths()[0]->mesh(), 2);
  Vec3s detail, prev_detail;
  cf.evaluate(coarse.cloths()[0]->state().x, prev_detail);
  double worst_ratio = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int f = 0; f < frames; ++f) {
    const Vec3s before = coarse.cloths()[0]->state().x;
    coarse.step_frame();
    const Vec3s& after = coarse.cloths()[0]->state().x;
    cf.evaluate(after, detail);
    double dc = 0.0, df = 0.0;
    for (size_t i = 0; i < after.size(); ++i) dc = std::max(dc, (after[i] - before[i]).norm());
    for (size_t i = 0; i < detail.size(); ++i) df = std::max(df, (detail[i] - prev_detail[i]).norm());
    if (dc > 1e-6) worst_ratio = std::max(worst_ratio, df / dc);
    prev_detail = detail;
  }
  const double coarse_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  Simulation fine(setup(33));
  const auto t1 = std::chrono::steady_clock::now();
  for (int f = 0; f < frames; ++f) fine.step_frame();
  const double fine_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  const Distance pn = distance(cf, detail, fine.cloths()[0]->mesh(), fine.cloths()[0]->state().x);
  std::printf("hybrid detail, hanging sheet after %d frames: coarse 9x9 + 2 levels vs fine 33x33: RMS %.4f m, max "
              "%.4f m; worst per-frame fine/coarse motion ratio %.3f; cost coarse+detail %.0f ms vs fine %.0f ms "
              "(ratio %.3f)\n",
              frames, pn.rms, pn.max, worst_ratio, coarse_ms, fine_ms, coarse_ms / fine_ms);
  EXPECT_LT(worst_ratio, 2.0);  // no popping: the fine surface moves by O(the coarse motion)
  EXPECT_LT(pn.rms, 0.05);      // m, on a 1 m sheet
  EXPECT_LT(pn.max, 0.15);
}

}  // namespace
}  // namespace loom::cloth
