#include "loom/cloth/CurvedFaces.h"

#include <map>

#include "loom/cloth/Error.h"

namespace loom::cloth {

namespace {

// PN triangle (header) at barycentric weights (w, u, v) of (P1, P2, P3).
Vec3 pn_point(const Vec3& p1, const Vec3& p2, const Vec3& p3, const Vec3& n1, const Vec3& n2, const Vec3& n3,
              const Vec3& bary) {
  const double w = bary[0], u = bary[1], v = bary[2];
  auto wij = [](const Vec3& pi, const Vec3& pj, const Vec3& ni) { return (pj - pi).dot(ni); };
  const Vec3 b210 = (2.0 * p1 + p2 - wij(p1, p2, n1) * n1) / 3.0;
  const Vec3 b120 = (2.0 * p2 + p1 - wij(p2, p1, n2) * n2) / 3.0;
  const Vec3 b021 = (2.0 * p2 + p3 - wij(p2, p3, n2) * n2) / 3.0;
  const Vec3 b012 = (2.0 * p3 + p2 - wij(p3, p2, n3) * n3) / 3.0;
  const Vec3 b102 = (2.0 * p3 + p1 - wij(p3, p1, n3) * n3) / 3.0;
  const Vec3 b201 = (2.0 * p1 + p3 - wij(p1, p3, n1) * n1) / 3.0;
  const Vec3 e = (b210 + b120 + b021 + b012 + b102 + b201) / 6.0;
  const Vec3 c = (p1 + p2 + p3) / 3.0;
  const Vec3 b111 = e + 0.5 * (e - c);
  return p1 * (w * w * w) + p2 * (u * u * u) + p3 * (v * v * v) + b210 * (3.0 * w * w * u) +
         b120 * (3.0 * w * u * u) + b201 * (3.0 * w * w * v) + b021 * (3.0 * u * u * v) + b102 * (3.0 * w * v * v) +
         b012 * (3.0 * u * v * v) + b111 * (6.0 * w * u * v);
}

}  // namespace

CurvedFaces::CurvedFaces(const ClothMesh& coarse, int levels, const std::string& file, const std::string& where)
    : coarse_tris_(coarse.triangles()), coarse_n_(coarse.num_vertices()), levels_(levels) {
  if (levels < 0 || levels > 5) throw Error(file, where + ".levels", "must be an integer in [0, 5] (got " + std::to_string(levels) + ")");
  // Fine triangles, each with its coarse triangle and its corners' barycentric weights in it.
  struct FineTri {
    Tri v;
    int coarse;
    std::array<Vec3, 3> bary;
  };
  std::vector<FineTri> tris;
  samples_.assign(coarse_n_, Sample{});
  std::vector<char> seen(coarse_n_, 0);
  for (int t = 0; t < coarse.num_triangles(); ++t) {
    const Tri& c = coarse_tris_[t];
    tris.push_back({c, t, {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}});
    for (int k = 0; k < 3; ++k)
      if (!seen[c[k]]) {
        seen[c[k]] = 1;
        samples_[c[k]] = Sample{t, Vec3::Unit(k)};
      }
  }
  coarse_to_fine_.resize(coarse_n_);
  for (int i = 0; i < coarse_n_; ++i) coarse_to_fine_[i] = i;
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<int, int>, int> midpoint;
    std::vector<FineTri> next;
    next.reserve(4 * tris.size());
    for (const FineTri& ft : tris) {
      int m[3];
      Vec3 mb[3];
      for (int k = 0; k < 3; ++k) {
        const int a = ft.v[k], b = ft.v[(k + 1) % 3];
        mb[k] = 0.5 * (ft.bary[k] + ft.bary[(k + 1) % 3]);
        const auto key = std::minmax(a, b);
        auto it = midpoint.find(key);
        if (it == midpoint.end()) {
          it = midpoint.emplace(key, static_cast<int>(samples_.size())).first;
          samples_.push_back(Sample{ft.coarse, mb[k]});
        }
        m[k] = it->second;
      }
      // (a, b, c) -> (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca): orientation kept.
      next.push_back({{ft.v[0], m[0], m[2]}, ft.coarse, {ft.bary[0], mb[0], mb[2]}});
      next.push_back({{m[0], ft.v[1], m[1]}, ft.coarse, {mb[0], ft.bary[1], mb[1]}});
      next.push_back({{m[2], m[1], ft.v[2]}, ft.coarse, {mb[2], mb[1], ft.bary[2]}});
      next.push_back({{m[0], m[1], m[2]}, ft.coarse, {mb[0], mb[1], mb[2]}});
    }
    tris.swap(next);
  }
  // The fine mesh: rest shape = the curved surface of the coarse rest shape; texture coordinates from the
  // coarse triangle's material frame (rest_uv), so the fine frames keep its warp/weft directions.
  Vec3s rest;
  evaluate(coarse.rest_positions(), rest);
  std::vector<Tri> fine_tris;
  std::vector<std::array<Vec2, 3>> uvs;
  fine_tris.reserve(tris.size());
  uvs.reserve(tris.size());
  for (const FineTri& ft : tris) {
    fine_tris.push_back(ft.v);
    const auto& ruv = coarse.triangle_frames()[ft.coarse].rest_uv;
    std::array<Vec2, 3> uv;
    for (int k = 0; k < 3; ++k) uv[k] = ft.bary[k][0] * ruv[0] + ft.bary[k][1] * ruv[1] + ft.bary[k][2] * ruv[2];
    uvs.push_back(uv);
  }
  fine_ = ClothMesh::from_triangles(std::move(rest), std::move(fine_tris), std::move(uvs), file.empty() ? "detail" : file);
}

void CurvedFaces::vertex_normals(const Vec3s& x, Vec3s& normals) const {
  normals.assign(coarse_n_, Vec3::Zero());
  for (const Tri& t : coarse_tris_) {
    const Vec3 n = (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);  // |n| = 2 area: area-weighted
    for (int k = 0; k < 3; ++k) normals[t[k]] += n;
  }
  for (Vec3& n : normals) {
    const double l = n.norm();
    n = l > 0.0 ? Vec3(n / l) : Vec3::Zero();
  }
}

void CurvedFaces::evaluate(const Vec3s& coarse_x, Vec3s& fine_x) const {
  vertex_normals(coarse_x, normals_);
  const int n = static_cast<int>(samples_.size());
  fine_x.resize(n);
#pragma omp parallel for schedule(static) if (n > 20000)
  for (int i = 0; i < n; ++i) {
    const Sample& s = samples_[i];
    const Tri& t = coarse_tris_[s.tri];
    fine_x[i] = pn_point(coarse_x[t[0]], coarse_x[t[1]], coarse_x[t[2]], normals_[t[0]], normals_[t[1]], normals_[t[2]],
                         s.bary);
  }
}

}  // namespace loom::cloth
