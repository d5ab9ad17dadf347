#include "loom/cloth/ClothMesh.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <tuple>

#include "loom/cloth/Error.h"
#include "loom/cloth/InputFile.h"
#include "loom/cloth/ObjFile.h"

namespace loom::cloth {

const char* to_string(SpringKind kind) {
  switch (kind) {
    case SpringKind::kStructural:
      return "structural";
    case SpringKind::kShear:
      return "shear";
    case SpringKind::kBend:
      return "bend";
    case SpringKind::kEdge:
      return "edge";
    case SpringKind::kHinge:
      return "hinge";
  }
  return "?";
}

namespace {

void plane_axes(GridPlane plane, Vec3& a1, Vec3& a2) {
  a1 = plane == GridPlane::kYZ ? Vec3::UnitY() : Vec3::UnitX();
  a2 = plane == GridPlane::kXY ? Vec3::UnitY() : Vec3::UnitZ();
}

int other_vertex(const Tri& t, int a, int b) {
  for (int v : t)
    if (v != a && v != b) return v;
  return -1;
}

// Every triangle side as (min vertex, max vertex, triangle), sorted: one run per edge, its triangles
// ascending, the runs in edge order.
std::vector<std::tuple<int, int, int>> sorted_sides(const std::vector<Tri>& triangles) {
  std::vector<std::tuple<int, int, int>> half;
  half.reserve(triangles.size() * 3);
  for (size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      int a = triangles[t][k], b = triangles[t][(k + 1) % 3];
      half.emplace_back(std::min(a, b), std::max(a, b), static_cast<int>(t));
    }
  std::sort(half.begin(), half.end());
  return half;
}

// The end of the run of sides on one edge that starts at s.
size_t run_end(const std::vector<std::tuple<int, int, int>>& half, size_t s) {
  size_t e = s;
  while (e < half.size() && std::get<0>(half[e]) == std::get<0>(half[s]) &&
         std::get<1>(half[e]) == std::get<1>(half[s]))
    ++e;
  return e;
}

// How errors name a vertex and a triangle (the field of loom::Error): "vertex i" and "triangle t" (0-based)
// for a mesh given as arrays; an OBJ's 1-based vertex with its line and the face's line (from_obj).
struct Labels {
  std::function<std::string(int)> vertex;
  std::function<std::string(int)> triangle;
};

Labels default_labels() {
  return {[](int i) { return "vertex " + std::to_string(i); },
          [](int t) { return "triangle " + std::to_string(t); }};
}

// Every check of a mesh the solvers can use, each naming a vertex and a triangle by `labels`: finite
// coordinates, indices in range, no repeated vertex, no zero area, no unused vertex, at most two triangles
// on an edge, no face given twice, no wings at one point and one orientation across every edge.
void check_mesh(const Vec3s& positions, const std::vector<Tri>& triangles, const std::string& source,
                const Labels& labels) {
  const auto& vertex = labels.vertex;
  const auto& triangle = labels.triangle;
  if (positions.empty()) throw Error(source, "", "mesh has no vertices");
  if (triangles.empty()) throw Error(source, "", "mesh has no triangles");
  const int n = static_cast<int>(positions.size());
  for (int i = 0; i < n; ++i)
    if (!positions[i].allFinite()) throw Error(source, vertex(i), "coordinate is not finite");
  std::vector<char> used(n, 0);
  double max_edge2 = 0.0;
  for (size_t t = 0; t < triangles.size(); ++t) {
    const Tri& tri = triangles[t];
    for (int k = 0; k < 3; ++k) {
      if (tri[k] < 0 || tri[k] >= n)
        throw Error(
            source, triangle(static_cast<int>(t)),
            "vertex index " + std::to_string(tri[k]) + " is out of range [0, " + std::to_string(n) + ")");
      used[tri[k]] = 1;
    }
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2])
      throw Error(source, triangle(static_cast<int>(t)), "repeats a vertex (degenerate triangle)");
    for (int k = 0; k < 3; ++k)
      max_edge2 = std::max(max_edge2, (positions[tri[k]] - positions[tri[(k + 1) % 3]]).squaredNorm());
  }
  for (size_t t = 0; t < triangles.size(); ++t) {
    const Tri& tri = triangles[t];
    const Vec3 e1 = positions[tri[1]] - positions[tri[0]], e2 = positions[tri[2]] - positions[tri[0]];
    double longest = std::max({e1.squaredNorm(), e2.squaredNorm(), (e2 - e1).squaredNorm()});
    if (e1.cross(e2).norm() <= 1e-10 * longest || longest <= 1e-24 * max_edge2)
      throw Error(source, triangle(static_cast<int>(t)), "has zero area (degenerate triangle)");
  }
  for (int i = 0; i < n; ++i)
    if (!used[i]) throw Error(source, vertex(i), "is not used by any triangle");

  // Unique edges by sorting (min, max, triangle) triples.
  const std::vector<std::tuple<int, int, int>> half = sorted_sides(triangles);
  for (size_t s = 0; s < half.size();) {
    const size_t e = run_end(half, s);
    const int a = std::get<0>(half[s]), b = std::get<1>(half[s]);
    if (e - s > 2)
      throw Error(source, "edge (" + vertex(a) + ", " + vertex(b) + ")",
                  "is shared by " + std::to_string(e - s) + " triangles (non-manifold edge)");
    if (e - s == 2 && std::get<2>(half[s]) == std::get<2>(half[s + 1]))
      throw Error(source, triangle(std::get<2>(half[s])), "uses an edge twice");
    if (e - s == 2) {
      const int o0 = other_vertex(triangles[std::get<2>(half[s])], a, b);
      const int o1 = other_vertex(triangles[std::get<2>(half[s + 1])], a, b);
      // Two triangles on the same three vertices (one face given twice, in either orientation) would be a
      // sheet of zero thickness folded onto itself.
      if (o0 == o1)
        throw Error(
            source, triangle(std::get<2>(half[s + 1])),
            "has the same three vertices as " + triangle(std::get<2>(half[s])) + " (a face given twice)");
      // Wings at one point (two vertices at the same position): the triangles lie folded onto each other
      // and the hinge's bending (its angle, its wing-to-wing spring of rest length 0) is undefined.
      const double wings = (positions[o0] - positions[o1]).norm();
      if (!(wings > 1e-9 * (positions[a] - positions[b]).norm()))
        throw Error(source, triangle(std::get<2>(half[s + 1])),
                    "lies folded onto " + triangle(std::get<2>(half[s])) + " across edge (" + vertex(a) +
                        ", " + vertex(b) + "): their " + vertex(o0) + " and " + vertex(o1) +
                        " are at the same position (merge them or move one)");
      // Two triangles on one edge must run along it in opposite directions (a consistent orientation): the
      // same direction twice is a sheet folded onto itself across the edge or a face given with its corners
      // the other way round; normals, bending angles and the pressure's volume would disagree there.
      {
        const int t0 = std::get<2>(half[s]), t1 = std::get<2>(half[s + 1]);
        auto runs = [&](int t) {  // true: the triangle's corners go a -> b
          const Tri& tri = triangles[t];
          for (int k = 0; k < 3; ++k)
            if (tri[k] == a && tri[(k + 1) % 3] == b) return true;
          return false;
        };
        const bool forward = runs(t0);
        if (forward == runs(t1))
          throw Error(source, triangle(t1),
                      "runs along the edge from " + (forward ? vertex(a) : vertex(b)) + " to " +
                          (forward ? vertex(b) : vertex(a)) + " in the same direction as " + triangle(t0) +
                          ": the two faces' orientations disagree (a sheet folded onto itself, or one face's "
                          "corners given the other way round); reverse one face's corner order");
      }
    }
    s = e;
  }
}

}  // namespace

double ClothMesh::total_area() const {
  double a = 0.0;
  for (double t : tri_area_) a += t;
  return a;
}

std::shared_ptr<const ClothMesh> ClothMesh::grid(const GridSpec& spec) {
  if (spec.nodes_u < 2 || spec.nodes_v < 2) throw Error("", "grid", "needs at least 2 nodes per side");
  if (!(spec.size_u > 0.0) || !(spec.size_v > 0.0) || !std::isfinite(spec.size_u) ||
      !std::isfinite(spec.size_v))
    throw Error("", "grid", "size must be finite and > 0");
  auto mesh = std::shared_ptr<ClothMesh>(new ClothMesh());
  ClothMesh& m = *mesh;
  const int nu = spec.nodes_u, nv = spec.nodes_v;
  const double du = spec.size_u / (nu - 1), dv = spec.size_v / (nv - 1);
  Vec3 a1, a2;
  plane_axes(spec.plane, a1, a2);
  m.grid_nodes_u_ = nu;
  m.grid_nodes_v_ = nv;
  m.rest_positions_.resize(static_cast<size_t>(nu) * nv);
  for (int iv = 0; iv < nv; ++iv)
    for (int iu = 0; iu < nu; ++iu)
      m.rest_positions_[m.grid_index(iu, iv)] = spec.origin + iu * du * a1 + iv * dv * a2;
  // Cells split along alternating diagonals, counter-clockwise in (u, v).
  for (int iv = 0; iv + 1 < nv; ++iv)
    for (int iu = 0; iu + 1 < nu; ++iu) {
      const int a = m.grid_index(iu, iv), b = m.grid_index(iu + 1, iv);
      const int c = m.grid_index(iu + 1, iv + 1), d = m.grid_index(iu, iv + 1);
      if ((iu + iv) % 2 == 0) {
        m.triangles_.push_back({a, b, c});
        m.triangles_.push_back({a, c, d});
      } else {
        m.triangles_.push_back({a, b, d});
        m.triangles_.push_back({b, c, d});
      }
    }
  m.build_topology("grid");
  // Material frame: weft along the first axis, warp along the second.
  m.frames_.resize(m.triangles_.size());
  for (size_t t = 0; t < m.triangles_.size(); ++t) {
    TriangleFrame& f = m.frames_[t];
    f.weft = a1;
    f.warp = a2;
    for (int k = 0; k < 3; ++k) {
      const int idx = m.triangles_[t][k];
      f.rest_uv[k] = Vec2((idx % nu) * du, (idx / nu) * dv);
    }
  }
  // Provot springs: structural (i+1), shear (both diagonals), bend (i+2).
  const double cell_area = du * dv;
  auto add = [&](int iu0, int iv0, int iu1, int iv1, SpringKind kind) {
    if (iu1 < 0 || iu1 >= nu || iv1 >= nv) return;
    SpringDef s;
    s.i = m.grid_index(iu0, iv0);
    s.j = m.grid_index(iu1, iv1);
    const Vec2 d((iu1 - iu0) * du, (iv1 - iv0) * dv);
    s.rest_length = d.norm();
    s.rest_uv_dir = d / s.rest_length;
    s.kind = kind;
    s.area = cell_area;
    // A spring along a boundary line stands for half a row of cloth.
    const bool along_u = iv1 == iv0, along_v = iu1 == iu0;
    if ((along_u && (iv0 == 0 || iv0 == nv - 1)) || (along_v && (iu0 == 0 || iu0 == nu - 1)))
      s.row_share = 0.5;
    if (kind == SpringKind::kStructural) m.strain_springs_.push_back(static_cast<int>(m.springs_.size()));
    m.springs_.push_back(s);
  };
  for (int iv = 0; iv < nv; ++iv)
    for (int iu = 0; iu < nu; ++iu) {
      add(iu, iv, iu + 1, iv, SpringKind::kStructural);
      add(iu, iv, iu, iv + 1, SpringKind::kStructural);
      add(iu, iv, iu + 1, iv + 1, SpringKind::kShear);
      add(iu, iv, iu - 1, iv + 1, SpringKind::kShear);
      add(iu, iv, iu + 2, iv, SpringKind::kBend);
      add(iu, iv, iu, iv + 2, SpringKind::kBend);
    }
  return mesh;
}

std::shared_ptr<const ClothMesh> ClothMesh::from_triangles(Vec3s positions, std::vector<Tri> triangles,
                                                           std::vector<std::array<Vec2, 3>> corner_uvs,
                                                           const std::string& source) {
  if (!corner_uvs.empty() && corner_uvs.size() != triangles.size())
    throw Error(source, "", "texture coordinates must be given for every triangle or none");
  check_mesh(positions, triangles, source, default_labels());
  auto mesh = std::shared_ptr<ClothMesh>(new ClothMesh());
  ClothMesh& m = *mesh;
  m.rest_positions_ = std::move(positions);
  m.triangles_ = std::move(triangles);
  m.build_topology(source);
  m.build_frames(corner_uvs);
  m.build_mesh_springs();
  return mesh;
}

void ClothMesh::build_topology(const std::string&) {  // the mesh passed check_mesh (or is a grid)
  const int n = num_vertices();
  tri_area_.resize(triangles_.size());
  vertex_area_.assign(n, 0.0);
  for (size_t t = 0; t < triangles_.size(); ++t) {
    const Tri& tri = triangles_[t];
    const Vec3& p0 = rest_positions_[tri[0]];
    tri_area_[t] = 0.5 * (rest_positions_[tri[1]] - p0).cross(rest_positions_[tri[2]] - p0).norm();
    for (int k = 0; k < 3; ++k) vertex_area_[tri[k]] += tri_area_[t] / 3.0;
  }
  // Unique edges by sorting (min, max, triangle) triples.
  const std::vector<std::tuple<int, int, int>> half = sorted_sides(triangles_);
  edges_.clear();
  hinges_.clear();
  for (size_t s = 0; s < half.size();) {
    const size_t e = run_end(half, s);
    const int a = std::get<0>(half[s]), b = std::get<1>(half[s]);
    edges_.push_back({a, b});
    if (e - s == 2) {
      Hinge h;
      h.e0 = a;
      h.e1 = b;
      h.o0 = other_vertex(triangles_[std::get<2>(half[s])], a, b);
      h.o1 = other_vertex(triangles_[std::get<2>(half[s + 1])], a, b);
      hinges_.push_back(h);
    }
    s = e;
  }
}

void ClothMesh::build_frames(const std::vector<std::array<Vec2, 3>>& corner_uvs) {
  // Best-fit plane of the whole mesh, the fallback frame when a triangle has no usable UVs.
  Vec3 mean = Vec3::Zero();
  for (const Vec3& p : rest_positions_) mean += p;
  mean /= static_cast<double>(rest_positions_.size());
  Mat3 cov = Mat3::Zero();
  for (const Vec3& p : rest_positions_) cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Mat3> eig(cov);
  const Vec3 axis1 = eig.eigenvectors().col(2), axis2 = eig.eigenvectors().col(1);

  frames_.resize(triangles_.size());
  for (size_t t = 0; t < triangles_.size(); ++t) {
    const Tri& tri = triangles_[t];
    const Vec3 e1 = rest_positions_[tri[1]] - rest_positions_[tri[0]];
    const Vec3 e2 = rest_positions_[tri[2]] - rest_positions_[tri[0]];
    const Vec3 normal = e1.cross(e2).normalized();
    Vec3 weft = Vec3::Zero();
    if (!corner_uvs.empty()) {
      // dX/du from [e1 e2] = [dX/du dX/dv] [duv1 duv2].
      const Vec2 d1 = corner_uvs[t][1] - corner_uvs[t][0], d2 = corner_uvs[t][2] - corner_uvs[t][0];
      const double det = d1.x() * d2.y() - d2.x() * d1.y();
      if (std::abs(det) > 1e-14) weft = (e1 * d2.y() - e2 * d1.y()) / det;
    }
    if (weft.squaredNorm() < 1e-24) {
      weft = axis1 - axis1.dot(normal) * normal;
      if (weft.squaredNorm() < 1e-6) weft = axis2 - axis2.dot(normal) * normal;
    }
    weft = (weft - weft.dot(normal) * normal).normalized();
    TriangleFrame& f = frames_[t];
    f.weft = weft;
    f.warp = normal.cross(weft);
    f.rest_uv[0] = Vec2::Zero();
    f.rest_uv[1] = Vec2(e1.dot(f.weft), e1.dot(f.warp));
    f.rest_uv[2] = Vec2(e2.dot(f.weft), e2.dot(f.warp));
  }
}

void ClothMesh::build_mesh_springs() {
  // Edge springs carry the area and the material direction of their triangles; hinge springs join the two
  // vertices opposite an interior edge (docs/references.md, "Cloth models"). The triangles of each edge (one
  // or two, ascending) come from the sorted sides, as in build_topology, so the cost does not grow with the
  // valence of a vertex.
  const std::vector<std::tuple<int, int, int>> half = sorted_sides(triangles_);
  std::vector<std::array<int, 2>> edge_tris;  // parallel to edges_; second -1 on a boundary edge
  edge_tris.reserve(edges_.size());
  for (size_t s = 0; s < half.size();) {
    const size_t e = run_end(half, s);
    edge_tris.push_back({std::get<2>(half[s]), e - s == 2 ? std::get<2>(half[s + 1]) : -1});
    s = e;
  }
  auto direction_in = [&](int t, const Vec3& d) {
    Vec2 uv(d.dot(frames_[t].weft), d.dot(frames_[t].warp));
    return uv.norm() > 0 ? Vec2(uv.normalized()) : Vec2(1.0, 0.0);
  };
  springs_.clear();
  strain_springs_.clear();
  for (size_t k = 0; k < edges_.size(); ++k) {
    const Edge& e = edges_[k];
    SpringDef s;
    s.i = e.i;
    s.j = e.j;
    s.kind = SpringKind::kEdge;
    const Vec3 d = rest_positions_[e.j] - rest_positions_[e.i];
    s.rest_length = d.norm();
    Vec2 dir = Vec2::Zero();
    for (int t : edge_tris[k]) {
      if (t < 0) continue;
      s.area += tri_area_[t];
      Vec2 uv = direction_in(t, d);
      if (dir.squaredNorm() > 0 && dir.dot(uv) < 0) uv = -uv;
      dir += uv;
    }
    s.rest_uv_dir = dir.normalized();
    strain_springs_.push_back(static_cast<int>(springs_.size()));
    springs_.push_back(s);
  }
  // Hinges are the interior edges in edge order; each has exactly its two triangles.
  size_t k = 0;
  for (const Hinge& h : hinges_) {
    while (edge_tris[k][1] < 0) ++k;
    const std::array<int, 2>& tris = edge_tris[k++];
    SpringDef s;
    s.i = h.o0;
    s.j = h.o1;
    s.kind = SpringKind::kHinge;
    const Vec3 d = rest_positions_[h.o1] - rest_positions_[h.o0];
    s.rest_length = d.norm();
    double a = 0.0;
    a += tri_area_[tris[0]];
    a += tri_area_[tris[1]];
    s.area = a / 3.0;
    s.rest_uv_dir = direction_in(tris[0], d);
    springs_.push_back(s);
  }
}

std::shared_ptr<const ClothMesh> ClothMesh::from_obj(const std::string& path, double scale,
                                                     const Vec3& translate) {
  const ObjFile obj = read_obj_file(path);  // strict: file, line and problem on any fault (ObjFile.h)
  Vec3s positions = obj.positions;
  const std::vector<Vec2>& texcoords = obj.texcoords;
  std::vector<Tri> triangles;
  std::vector<std::array<int, 3>> tri_vt;
  std::vector<size_t> face_of;  // the face each triangle came from
  bool any_vt = false, all_vt = true;
  for (size_t fi = 0; fi < obj.faces.size(); ++fi) {
    const std::vector<ObjCorner>& c = obj.faces[fi].corners;
    for (size_t k = 1; k + 1 < c.size(); ++k) {  // polygons fan-split
      triangles.push_back({c[0].v, c[k].v, c[k + 1].v});
      face_of.push_back(fi);
      tri_vt.push_back({c[0].vt, c[k].vt, c[k + 1].vt});
      const bool has = c[0].vt >= 0 && c[k].vt >= 0 && c[k + 1].vt >= 0;
      any_vt = any_vt || has;
      all_vt = all_vt && has;
    }
  }
  for (Vec3& p : positions) p = scale * p + translate;
  std::vector<std::array<Vec2, 3>> corner_uvs;
  if (any_vt && all_vt) {
    corner_uvs.resize(triangles.size());
    for (size_t t = 0; t < triangles.size(); ++t)
      for (int k = 0; k < 3; ++k) corner_uvs[t][k] = texcoords[tri_vt[t][k]];
  }
  // Checked first with the OBJ's names: a vertex by its 1-based index and line, a triangle by its face's
  // line (from_triangles would name them by 0-based array indices).
  Labels labels;
  labels.vertex = [&obj](int i) {
    return "vertex " + std::to_string(i + 1) + " (line " + std::to_string(obj.position_lines[i]) + ")";
  };
  labels.triangle = [&obj, &face_of](int t) {
    const ObjFace& f = obj.faces[face_of[t]];
    return line_where(f.line, f.text);
  };
  check_mesh(positions, triangles, path, labels);
  return from_triangles(std::move(positions), std::move(triangles), std::move(corner_uvs), path);
}

}  // namespace loom::cloth
