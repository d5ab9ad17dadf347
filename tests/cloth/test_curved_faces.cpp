// Hybrid detail, curved faces: the PN-triangle surface interpolates the coarse vertices, is exact on
// flat cloth, follows a curved sheet far better than the flat facets, moves continuously with the coarse mesh
// (no popping), and on the settled hanging cloth stays close to a full fine-resolution simulation.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
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
    for (int i = 0; i < coarse->num_vertices(); ++i)
      EXPECT_LT((fine[cf.fine_vertex_of(i)] - x[i]).norm(), 1e-12);
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
  auto roll = [&](const Vec3& p) {
    return Vec3(r * std::sin(p.x() / r), 1.0 - r * (1.0 - std::cos(p.x() / r)), p.z());
  };
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
  std::printf(
      "cylinder r = 0.3 m, coarse edge 0.125 m: PN surface off the cylinder by %.3g m (%.3g m in the "
      "cells along the free edges), flat facets by %.3g m\n",
      pn_err, pn_edge, flat_err);
  EXPECT_LT(pn_err, 0.1 * flat_err);
  EXPECT_LT(pn_edge, flat_err);
}

// RMS and max distance between the detail surface and a fine simulation, at the
// same material points (the subdivided coarse grid and the fine grid share their nodes).
struct Distance {
  double rms = 0.0, max = 0.0;
};
Distance distance(const CurvedFaces& cf, const Vec3s& detail, const ClothMesh& fine_mesh,
                  const Vec3s& fine_x) {
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
  const double coarse_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  Simulation fine(setup(33));
  const auto t1 = std::chrono::steady_clock::now();
  for (int f = 0; f < frames; ++f) fine.step_frame();
  const double fine_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  const Distance pn = distance(cf, detail, fine.cloths()[0]->mesh(), fine.cloths()[0]->state().x);
  std::printf(
      "hybrid detail, hanging sheet after %d frames: coarse 9x9 + 2 levels vs fine 33x33: RMS %.4f m, max "
      "%.4f m; worst per-frame fine/coarse motion ratio %.3f; cost coarse+detail %.0f ms vs fine %.0f ms "
      "(ratio %.3f)\n",
      frames, pn.rms, pn.max, worst_ratio, coarse_ms, fine_ms, coarse_ms / fine_ms);
  EXPECT_LT(worst_ratio, 2.0);  // no popping: the fine surface moves by O(the coarse motion)
  EXPECT_LT(pn.rms, 0.05);      // m, on a 1 m sheet
  EXPECT_LT(pn.max, 0.15);
}

// Geometric wrinkles (CurvedFaces.h): a 1 m sheet, coarse 9 x 9, 3 levels (fine edge 1/64 m), wavelength
// 0.125 m (8 fine edges).
WrinkleSettings wrinkles(double amplitude = 0.05, double wavelength = 0.125) {
  WrinkleSettings w;
  w.enabled = true;
  w.amplitude = amplitude;
  w.wavelength = wavelength;
  return w;
}

double fine_area(const ClothMesh& mesh, const Vec3s& x) {
  double a = 0.0;
  for (const Tri& t : mesh.triangles()) a += 0.5 * (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).norm();
  return a;
}

TEST(CurvedFacesWrinkles, NoneWithoutCompression) {
  auto coarse = grid(9);
  CurvedFaces plain(*coarse, 2), wr(*coarse, 2);
  wr.set_wrinkles(wrinkles());
  const Mat3 R = Eigen::AngleAxisd(0.4, Vec3(0, 1, 1).normalized()).toRotationMatrix();
  // At rest, rigidly rotated, stretched 5 % along the weft and 2 % along the warp: nothing is compressed.
  for (int c = 0; c < 3; ++c) {
    Vec3s x = coarse->rest_positions();
    for (Vec3& p : x) {
      if (c >= 1) p = R * p;
      if (c == 2) p = Vec3(1.05 * p.x(), p.y(), 1.02 * p.z());
    }
    Vec3s a, b;
    plain.evaluate(x, a);
    wr.evaluate(x, b);
    double off = 0.0, hmax = 0.0;
    for (size_t i = 0; i < a.size(); ++i) off = std::max(off, (a[i] - b[i]).norm());
    for (double h : wr.wrinkle_heights()) hmax = std::max(hmax, std::abs(h));
    // Exactly none at rest and stretched; a rotation leaves round-off in the stretches (1e-16), which the
    // square-root amplitude law turns into about 1e-9 m.
    EXPECT_LE(off, c == 1 ? 1e-8 : 0.0) << c;
    EXPECT_LE(hmax, c == 1 ? 1e-8 : 0.0) << c;
  }
  EXPECT_THROW(wr.set_wrinkles(wrinkles(0.01, 0.0)), Error);
  EXPECT_THROW(wr.set_wrinkles(wrinkles(-0.01, 0.1)), Error);
}

TEST(CurvedFacesWrinkles, CompressionMakesWrinklesAcrossItsAxisThatKeepTheArea) {
  auto coarse = grid(9);
  CurvedFaces cf(*coarse, 3);
  cf.set_wrinkles(wrinkles());
  const auto& fine = *cf.fine_mesh();
  const double lambda = 0.125;
  for (int axis : {0, 2}) {  // compress 10 % along x (weft, u) or along z (warp, v)
    Vec3s x = coarse->rest_positions();
    for (Vec3& p : x) p[axis] *= 0.9;
    Vec3s out, flat;
    cf.evaluate(x, out);
    CurvedFaces plain(*coarse, 3);
    plain.evaluate(x, flat);
    // Amplitude from the arc-length rule, A = (λ/π) √(q / (1 - q)) with q = 0.1.
    const double expected = lambda / 3.14159265358979 * std::sqrt(0.1 / 0.9);
    double hmax = 0.0, spread_along = 0.0, worst_normal = 0.0;
    // Crests perpendicular to the compression axis: the height depends only on the rest coordinate along it.
    std::map<long, std::pair<double, double>> by_line;  // rest coordinate along the axis -> min, max height
    for (int i = 0; i < fine.num_vertices(); ++i) {
      const double h = cf.wrinkle_heights()[i];
      hmax = std::max(hmax, std::abs(h));
      const long key = std::lround(fine.rest_positions()[i][axis] * 1024.0);
      auto it = by_line.find(key);
      if (it == by_line.end())
        by_line[key] = {h, h};
      else
        it->second = {std::min(it->second.first, h), std::max(it->second.second, h)};
      // The displacement is along the normal (±y here).
      worst_normal = std::max(worst_normal, std::abs((out[i] - flat[i]).norm() - std::abs(h)) +
                                                std::abs(std::abs(out[i].y() - flat[i].y()) - std::abs(h)));
    }
    for (const auto& [k, mm] : by_line) spread_along = std::max(spread_along, mm.second - mm.first);
    const double a_rest = fine_area(fine, fine.rest_positions()), a_flat = fine_area(fine, flat),
                 a_wr = fine_area(fine, out);
    std::printf(
        "wrinkles, 10%% compression along %c: max height %.4g m (rule %.4g m), height spread along the "
        "crests %.2g m; "
        "area rest %.4f, compressed flat %.4f, with wrinkles %.4f m²\n",
        axis == 0 ? 'x' : 'z', hmax, expected, spread_along, a_rest, a_flat, a_wr);
    EXPECT_NEAR(hmax, expected, 0.02 * expected);
    EXPECT_LT(spread_along, 1e-9);
    EXPECT_LT(worst_normal, 1e-12);
    EXPECT_LT(std::abs(a_wr - a_rest), 0.35 * std::abs(a_flat - a_rest));  // area roughly kept
  }
  // The amplitude cap.
  cf.set_wrinkles(wrinkles(0.002));
  Vec3s x = coarse->rest_positions(), out;
  for (Vec3& p : x) p.x() *= 0.9;
  cf.evaluate(x, out);
  double hmax = 0.0;
  for (double h : cf.wrinkle_heights()) hmax = std::max(hmax, std::abs(h));
  EXPECT_NEAR(hmax, 0.002, 1e-9);
}

// A smooth, locally varying deformation: compressed in a bump, bent, sheared (s: 0..1 ramps it in).
Vec3s squeezed(const ClothMesh& m, double s) {
  Vec3s x = m.rest_positions();
  for (Vec3& p : x) {
    const double u = p.x(), v = p.z();
    const double squeeze = 0.15 * s * std::exp(-8.0 * (u * u + v * v));
    p = Vec3(u * (1.0 - squeeze) + 0.05 * s * v * v, 1.0 + 0.2 * s * u * u + 0.05 * s * std::sin(3 * v),
             v * (1.0 - 0.5 * squeeze));
  }
  return x;
}

TEST(CurvedFacesWrinkles, ContinuousAcrossSharedCoarseEdges) {
  auto coarse = grid(9);
  CurvedFaces cf(*coarse, 2);
  cf.set_wrinkles(wrinkles(0.05, 0.1));
  Vec3s out;
  cf.evaluate(squeezed(*coarse, 1.0), out);
  double hmax = 0.0;
  for (double h : cf.wrinkle_heights()) hmax = std::max(hmax, std::abs(h));
  ASSERT_GT(hmax, 1e-3);  // there are wrinkles to compare
  // Every interior coarse edge: points on it evaluated from both triangles agree.
  std::map<std::pair<int, int>, std::vector<std::pair<int, int>>>
      edge_tris;  // edge -> (triangle, corner of its first vertex)
  const auto& tris = coarse->triangles();
  for (int t = 0; t < static_cast<int>(tris.size()); ++t)
    for (int k = 0; k < 3; ++k) edge_tris[std::minmax(tris[t][k], tris[t][(k + 1) % 3])].push_back({t, k});
  int compared = 0;
  double worst = 0.0;
  for (const auto& [e, ts] : edge_tris) {
    if (ts.size() != 2) continue;
    for (double f : {0.1, 0.37, 0.5, 0.8}) {
      double h[2];
      for (int side = 0; side < 2; ++side) {
        const auto [t, k] = ts[side];
        Vec3 bary = Vec3::Zero();
        // weight of edge vertex e.first = 1 - f, of e.second = f
        for (int c = 0; c < 3; ++c) {
          if (tris[t][c] == e.first) bary[c] = 1.0 - f;
          if (tris[t][c] == e.second) bary[c] = f;
        }
        (void)k;
        h[side] = cf.wrinkle_height(t, bary);
      }
      worst = std::max(worst, std::abs(h[0] - h[1]));
      ++compared;
    }
  }
  std::printf(
      "wrinkles across %d shared-edge points: largest difference between the two sides %.3g m (max height "
      "%.3g m)\n",
      compared, worst, hmax);
  EXPECT_GT(compared, 100);
  EXPECT_LT(worst, 1e-12);
}

TEST(CurvedFacesWrinkles, BoundedFrameToFrameChangeForSmoothMotion) {
  // The deformation ramps in over 200 frames: the fine surface (wrinkles included) must move by a bounded
  // multiple of the coarse motion per frame, never jump (popping would be a jump of the order of the
  // amplitude in one frame).
  auto coarse = grid(9);
  CurvedFaces cf(*coarse, 2);
  cf.set_wrinkles(wrinkles(0.05, 0.1));
  Vec3s prev, out;
  Vec3s prev_coarse = coarse->rest_positions();
  cf.evaluate(prev_coarse, prev);
  const int frames = 200;
  double worst_fine = 0.0, worst_coarse = 0.0, hmax = 0.0, worst_dh = 0.0;
  std::vector<double> prev_h(cf.fine_mesh()->num_vertices(), 0.0);
  for (int f = 1; f <= frames; ++f) {
    const double s = 0.5 - 0.5 * std::cos(3.14159265358979 * f / frames);  // smooth ramp 0 -> 1
    const Vec3s x = squeezed(*coarse, s);
    cf.evaluate(x, out);
    double dc = 0.0, df = 0.0;
    for (size_t i = 0; i < x.size(); ++i) dc = std::max(dc, (x[i] - prev_coarse[i]).norm());
    for (size_t i = 0; i < out.size(); ++i) df = std::max(df, (out[i] - prev[i]).norm());
    worst_fine = std::max(worst_fine, df);
    worst_coarse = std::max(worst_coarse, dc);
    for (size_t i = 0; i < prev_h.size(); ++i)
      worst_dh = std::max(worst_dh, std::abs(cf.wrinkle_heights()[i] - prev_h[i]));
    prev_h = cf.wrinkle_heights();
    prev = out;
    prev_coarse = x;
  }
  for (double h : cf.wrinkle_heights()) hmax = std::max(hmax, std::abs(h));
  std::printf(
      "wrinkles over a smooth %d-frame ramp: largest per-frame move fine %.3g m, coarse %.3g m, of a wrinkle "
      "height %.3g m; final max height %.3g m\n",
      frames, worst_fine, worst_coarse, worst_dh, hmax);
  ASSERT_GT(hmax, 2e-3);
  EXPECT_LT(worst_fine, 0.2 * hmax);
  EXPECT_LT(worst_fine, 5.0 * worst_coarse);
  EXPECT_LT(worst_dh, 0.1 * hmax);  // the wrinkles grow over many frames
}

}  // namespace
}  // namespace loom::cloth
