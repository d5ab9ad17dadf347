// ClothMesh: grid topology counts, areas, material frames, OBJ loading and every rejection path.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>

#include "TestDir.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/SpringSet.h"
#include "loom/cloth/SpringSolverSupport.h"

namespace loom::cloth {
namespace {

namespace fs = std::filesystem;

std::string write_temp(const std::string& name, const std::string& text) {
  const fs::path p = test::test_dir() / name;
  std::ofstream(p) << text;
  return p.string();
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Grid, CountsFollowProvotTopology) {
  GridSpec g;
  g.nodes_u = 5;
  g.nodes_v = 4;
  g.size_u = 2.0;
  g.size_v = 1.5;
  auto m = ClothMesh::grid(g);
  const int nu = 5, nv = 4;
  EXPECT_EQ(m->num_vertices(), nu * nv);
  EXPECT_EQ(m->num_triangles(), 2 * (nu - 1) * (nv - 1));
  int structural = 0, shear = 0, bend = 0;
  for (const SpringDef& s : m->springs()) {
    structural += s.kind == SpringKind::kStructural;
    shear += s.kind == SpringKind::kShear;
    bend += s.kind == SpringKind::kBend;
  }
  EXPECT_EQ(structural, (nu - 1) * nv + nu * (nv - 1));
  EXPECT_EQ(shear, 2 * (nu - 1) * (nv - 1));
  EXPECT_EQ(bend, (nu - 2) * nv + nu * (nv - 2));
  const int edges = structural + (nu - 1) * (nv - 1);
  EXPECT_EQ(static_cast<int>(m->edges().size()), edges);
  EXPECT_EQ(static_cast<int>(m->hinges().size()), edges - 2 * (nu - 1) - 2 * (nv - 1));
  EXPECT_NEAR(m->total_area(), 3.0, 1e-12);
  double vertex_area = 0.0;
  for (double a : m->vertex_areas()) vertex_area += a;
  EXPECT_NEAR(vertex_area, 3.0, 1e-12);
  EXPECT_EQ(m->strain_springs().size(), static_cast<size_t>(structural));
}

TEST(Grid, HingeOppositeVerticesAreNotOnTheEdge) {
  auto m = ClothMesh::grid(GridSpec{});
  for (const Hinge& h : m->hinges()) {
    EXPECT_NE(h.o0, h.o1);
    for (int o : {h.o0, h.o1}) {
      EXPECT_NE(o, h.e0);
      EXPECT_NE(o, h.e1);
    }
  }
}

TEST(Grid, PlaneAndOriginPlaceTheNodes) {
  GridSpec g;
  g.nodes_u = 3;
  g.nodes_v = 3;
  g.plane = GridPlane::kXY;
  g.origin = Vec3(1, 2, 3);
  auto m = ClothMesh::grid(g);
  EXPECT_TRUE(m->rest_positions()[m->grid_index(2, 2)].isApprox(Vec3(2, 3, 3)));
  EXPECT_TRUE(m->triangle_frames()[0].weft.isApprox(Vec3::UnitX()));
  EXPECT_TRUE(m->triangle_frames()[0].warp.isApprox(Vec3::UnitY()));
}

TEST(Springs, InPlaneModulusIsResolutionIndependentOnGrids) {
  // A grid's modulus along the weft is C11 = k_s + k_d + 4 k_bend (structural, both diagonals, and the two
  // bend springs crossing every cut): it must equal the material's modulus at every resolution, and the
  // shear modulus C33 = k_d (docs/references.md, "Fabric measurement").
  Material mat = material_preset("cotton");
  for (int n : {9, 33, 129}) {
    GridSpec g;
    g.nodes_u = g.nodes_v = n;
    auto m = ClothMesh::grid(g);
    const auto springs = make_springs(*m, mat);
    double ks_weft = 0, ks_warp = 0, kd = 0, kb_weft = 0, kb_warp = 0;
    for (size_t k = 0; k < springs.size(); ++k) {
      const SpringDef& d = m->springs()[k];
      const bool weft = std::abs(d.rest_uv_dir.x()) > 0.5;
      if (d.row_share != 1.0) {
        EXPECT_EQ(d.row_share, 0.5);  // boundary rows stand for half a row
        continue;
      }
      if (d.kind == SpringKind::kStructural) (weft ? ks_weft : ks_warp) = springs[k].k;
      if (d.kind == SpringKind::kShear) kd = springs[k].k;
      if (d.kind == SpringKind::kBend) (weft ? kb_weft : kb_warp) = springs[k].k;
    }
    EXPECT_NEAR(ks_weft + kd + 4 * kb_weft, mat.stretch_weft, 1e-9) << n;
    EXPECT_NEAR(ks_warp + kd + 4 * kb_warp, mat.stretch_warp, 1e-9) << n;
    EXPECT_NEAR(kd, mat.shear, 1e-12) << n;
    EXPECT_GE(ks_weft, 0.5 * (mat.stretch_weft - kd) - 1e-9) << n;  // the bend-spring cap
  }
}

TEST(Obj, LoadsQuadsAsTwoTrianglesWithFramesFromUVs) {
  // A unit quad in the YZ plane whose u runs along +y: the weft must follow +y.
  const std::string path = write_temp("quad.obj",
                                      "# quad\nv 0 0 0\nv 0 1 0\nv 0 1 1\nv 0 0 1\n"
                                      "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n");
  auto m = ClothMesh::from_obj(path);
  EXPECT_EQ(m->num_vertices(), 4);
  EXPECT_EQ(m->num_triangles(), 2);
  EXPECT_NEAR(m->total_area(), 1.0, 1e-12);
  for (const TriangleFrame& f : m->triangle_frames()) {
    EXPECT_TRUE(f.weft.isApprox(Vec3::UnitY(), 1e-12));
    EXPECT_NEAR(std::abs(f.warp.z()), 1.0, 1e-12);
  }
  EXPECT_EQ(m->hinges().size(), 1u);
  EXPECT_EQ(m->edges().size(), 5u);
}

TEST(Obj, ScaleAndTranslateApply) {
  const std::string path = write_temp("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  auto m = ClothMesh::from_obj(path, 2.0, Vec3(0, 0, 1));
  EXPECT_TRUE(m->rest_positions()[1].isApprox(Vec3(2, 0, 1)));
}

TEST(Obj, RejectsBadInputWithFileLineAndProblem) {
  struct Case {
    const char* name;
    const char* text;
    const char* expect_where;
    const char* expect_problem;
  };
  const Case cases[] = {
      {"out_of_range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 7\n", "line 5", "out of range"},
      {"bad_number.obj", "v 0 0 zero\n", "line 1", "three numbers"},
      {"nan.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "line 1", "not finite"},
      {"short_face.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", "line 3", "at least 3"},
      {"bad_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "line 4", "bad vertex index"},
      {"unknown.obj", "v 0 0 0\nbogus 1 2\n", "line 2", "unknown OBJ directive"},
      {"degenerate.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 4 2\nf 1 2 3\n", "line 6 ('f 1 2 3')",
       "zero area"},
      {"repeated.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2\n", "line 4 ('f 1 2 2')", "degenerate"},
      {"nonmanifold.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n",
       "edge (vertex 1 (line 1), vertex 2 (line 2))", "non-manifold"},
      // The 4th `v` is OBJ vertex 4 (1-based, as faces count), named with its line.
      {"unused.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n# a comment\nv 5 5 5\nf 1 2 3\n", "vertex 4 (line 5)",
       "not used"},
      // The third face lies over the other two with the same winding: edge 1->2 runs the same way in the
      // faces of lines 5 and 7 (a folded sheet), named by both lines.
      {"folded.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0 1\nf 1 2 3\nf 2 4 3\nf 1 2 4\n", "line 7 ('f 1 2 4')",
       "runs along the edge from vertex 1 (line 1) to vertex 2 (line 2) in the same direction as line 5 "
       "('f 1 2 3')"},
      {"empty.obj", "# nothing\n", "", "no vertices"},
  };
  for (const Case& c : cases) {
    const std::string path = write_temp(c.name, c.text);
    const std::string msg = error_of([&] { ClothMesh::from_obj(path); });
    EXPECT_NE(msg.find(path), std::string::npos) << c.name << ": " << msg;
    EXPECT_NE(msg.find(c.expect_where), std::string::npos) << c.name << ": " << msg;
    EXPECT_NE(msg.find(c.expect_problem), std::string::npos) << c.name << ": " << msg;
  }
  EXPECT_NE(error_of([] { ClothMesh::from_obj("/nonexistent/cloth.obj"); }).find("cannot open"),
            std::string::npos);
}

}  // namespace
}  // namespace loom::cloth

namespace loom::cloth {
namespace {

TEST(Materials, EveryPresetIsValidAndCitesPhysicalRanges) {
  const auto names = material_preset_names();
  EXPECT_GE(names.size(), 12u);
  for (const std::string& n : names) {
    const Material m = material_preset(n);
    EXPECT_NO_THROW(m.validate("", n)) << n;
    EXPECT_GT(m.areal_density, 0.05) << n;  // fabrics: 50-500 g/m²
    EXPECT_LT(m.areal_density, 0.5) << n;
    EXPECT_GT(m.bend_weft, 1e-6) << n;  // µN·m range
    EXPECT_LT(m.bend_weft, 1e-3) << n;
  }
  // Anisotropy survives: 11 oz denim is ~5x stiffer along the warp than the weft (Wang et al. 2011).
  const Material d = material_preset("denim_11oz");
  EXPECT_GT(d.stretch_warp / d.stretch_weft, 4.0);
  EXPECT_THROW(material_preset("silk"), Error);
}

TEST(Materials, CloStyleParametersMapToPhysicalUnits) {
  CloStyleParameters p;
  p.weight = 250;
  p.thickness = 0.8;
  p.bending_weft = 15;
  p.bending_warp = 30;
  p.internal_damping = 0.002;
  const Material m = from_clo_style(p);
  EXPECT_DOUBLE_EQ(m.areal_density, 0.25);
  EXPECT_DOUBLE_EQ(m.thickness, 0.0008);
  EXPECT_DOUBLE_EQ(m.bend_weft, 15e-6);
  EXPECT_DOUBLE_EQ(m.bend_warp, 30e-6);
  EXPECT_DOUBLE_EQ(m.damping, 0.002);
}

TEST(Materials, WarpAndWeftFollowTheMaterialFrameOnAnyMesh) {
  // The same sheet as a grid and as an OBJ-like mesh rotated in its plane with UVs: edge springs along the
  // warp get the warp modulus.
  Material m = material_preset("denim_11oz");
  // A right triangle whose legs run along weft (u) and warp (v), rotated by 30° in 3D.
  const double c = std::cos(0.5236), s = std::sin(0.5236);
  auto mesh = ClothMesh::from_triangles(
      {Vec3(0, 0, 0), Vec3(c, s, 0), Vec3(-s, c, 0), Vec3(c - s, s + c, 0)}, {{0, 1, 3}, {0, 3, 2}},
      {{Vec2(0, 0), Vec2(1, 0), Vec2(1, 1)}, {Vec2(0, 0), Vec2(1, 1), Vec2(0, 1)}}, "test");
  const auto springs = make_springs(*mesh, m);
  for (size_t k = 0; k < springs.size(); ++k) {
    const SpringDef& d = mesh->springs()[k];
    if (d.kind != SpringKind::kEdge) continue;
    const bool along_weft = (d.i == 0 && d.j == 1) || (d.i == 2 && d.j == 3);
    const bool along_warp = (d.i == 0 && d.j == 2) || (d.i == 1 && d.j == 3);
    if (along_weft) {
      EXPECT_NEAR(d.rest_uv_dir.x() * d.rest_uv_dir.x(), 1.0, 1e-9);
      EXPECT_NEAR(springs[k].k, m.stretch_weft * d.area / (d.rest_length * d.rest_length), 1e-9);
    }
    if (along_warp) {
      EXPECT_NEAR(d.rest_uv_dir.y() * d.rest_uv_dir.y(), 1.0, 1e-9);
      EXPECT_NEAR(springs[k].k, m.stretch_warp * d.area / (d.rest_length * d.rest_length), 1e-9);
    }
  }
}

// A disc of n triangles fanned around one centre vertex: n + 1 vertices, n spokes and n rim edges.
std::shared_ptr<const ClothMesh> fan(int n) {
  Vec3s x{Vec3::Zero()};
  std::vector<Tri> tris;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * 3.14159265358979323846 * i / n;
    x.emplace_back(std::cos(a), 0.0, std::sin(a));
    tris.push_back({0, 1 + i, 1 + (i + 1) % n});
  }
  return ClothMesh::from_triangles(std::move(x), std::move(tris), {}, "fan");
}

// Edge and hinge springs of a vertex of huge valence: every spoke is an interior edge with its two triangles
// (a hinge), every rim edge a boundary edge with one. The spring building does not grow with the valence
// (a 200000-triangle fan builds well within the test timeout).
TEST(Mesh, HighValenceFanBuildsEdgesAndHingesOfEveryTriangle) {
  const int n = 200000;
  const auto m = fan(n);
  ASSERT_EQ(m->num_vertices(), n + 1);
  EXPECT_EQ(m->edges().size(), 2u * n);
  EXPECT_EQ(m->hinges().size(), static_cast<size_t>(n));
  ASSERT_EQ(m->springs().size(), 3u * n);
  const std::vector<double>& area = m->triangle_rest_areas();
  int spokes = 0, rims = 0;
  for (size_t k = 0; k < m->edges().size(); ++k) {
    const SpringDef& s = m->springs()[k];
    ASSERT_EQ(s.kind, SpringKind::kEdge);
    if (s.i == 0) {  // a spoke to rim vertex j: triangles j-1 and j-2 (mod n) carry it
      ++spokes;
      const int t0 = (s.j - 1) % n, t1 = (s.j - 2 + n) % n;
      EXPECT_DOUBLE_EQ(s.area, area[t0] + area[t1]) << k;
    } else {
      ++rims;
      EXPECT_NEAR(s.area, area[0], 1e-9 * area[0]) << k;  // the triangles of the regular fan are alike
    }
    EXPECT_NEAR(s.rest_uv_dir.norm(), 1.0, 1e-12) << k;
  }
  EXPECT_EQ(spokes, n);
  EXPECT_EQ(rims, n);
  for (size_t k = m->edges().size(); k < m->springs().size(); ++k) {
    const SpringDef& s = m->springs()[k];
    ASSERT_EQ(s.kind, SpringKind::kHinge);
    EXPECT_NE(s.i, 0);
    EXPECT_NE(s.j, 0);
    EXPECT_NEAR(s.area, 2.0 * area[0] / 3.0, 1e-9 * area[0]) << k;
  }
}

// One polygon of many corners (fan-split by the OBJ reader): n - 2 triangles, n boundary edges and n - 3
// diagonals, each diagonal a hinge.
TEST(Obj, OneLargePolygonIsFanSplitWithEveryDiagonalAHinge) {
  const int n = 50000;
  std::string text;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * 3.14159265358979323846 * i / n;
    char line[80];
    std::snprintf(line, sizeof line, "v %.15f 0 %.15f\n", std::cos(a), std::sin(a));
    text += line;
  }
  text += "f";
  for (int i = 1; i <= n; ++i) text += " " + std::to_string(i);
  text += "\n";
  const auto m = ClothMesh::from_obj(write_temp("ngon.obj", text));
  EXPECT_EQ(m->num_triangles(), n - 2);
  EXPECT_EQ(m->edges().size(), static_cast<size_t>(2 * n - 3));
  EXPECT_EQ(m->hinges().size(), static_cast<size_t>(n - 3));
  EXPECT_EQ(m->springs().size(), static_cast<size_t>(3 * n - 6));
}

// Greedy spring colouring (each spring the lowest colour free at both its ends), checked against the plain
// scan on a small mesh, and valid on a fan whose centre needs one colour per spoke.
TEST(Springs, ColouringIsGreedyAndValidAtAnyValence) {
  auto reference = [](int nv, const std::vector<Spring>& springs) {
    std::vector<std::vector<int>> colors;
    std::vector<std::vector<char>> used(nv);
    for (int s = 0; s < static_cast<int>(springs.size()); ++s) {
      int c = 0;
      auto taken = [&](int v) { return c < static_cast<int>(used[v].size()) && used[v][c]; };
      while (taken(springs[s].i) || taken(springs[s].j)) ++c;
      if (c == static_cast<int>(colors.size())) colors.emplace_back();
      colors[c].push_back(s);
      for (int v : {springs[s].i, springs[s].j}) {
        if (static_cast<int>(used[v].size()) <= c) used[v].resize(c + 1, 0);
        used[v][c] = 1;
      }
    }
    return colors;
  };
  auto springs_of = [](const ClothMesh& m) {
    std::vector<Spring> out;
    for (const SpringDef& d : m.springs()) out.push_back(Spring{d.i, d.j, d.rest_length, 1.0, 0.0});
    return out;
  };
  const auto grid = ClothMesh::grid(GridSpec{1.0, 1.0, 9, 7, GridPlane::kXZ, Vec3::Zero()});
  const auto small = fan(40);
  for (const ClothMesh* m : {grid.get(), small.get()})
    EXPECT_EQ(color_springs(m->num_vertices(), springs_of(*m)), reference(m->num_vertices(), springs_of(*m)));
  const int n = 100000;
  const auto big = fan(n);
  const std::vector<Spring> springs = springs_of(*big);
  const auto colors = color_springs(big->num_vertices(), springs);
  EXPECT_GE(colors.size(), static_cast<size_t>(n));  // every spoke meets the centre
  std::vector<int> seen(springs.size(), 0);
  for (const auto& colour : colors) {
    std::vector<int> touched;
    for (int s : colour) {
      ++seen[s];
      touched.push_back(springs[s].i);
      touched.push_back(springs[s].j);
    }
    std::sort(touched.begin(), touched.end());
    EXPECT_EQ(std::adjacent_find(touched.begin(), touched.end()), touched.end());
  }
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), static_cast<long>(springs.size()));
}

}  // namespace
}  // namespace loom::cloth
