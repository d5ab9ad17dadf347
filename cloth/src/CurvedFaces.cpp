#include "loom/cloth/CurvedFaces.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <deque>
#include <map>

#include "Numbers.h"
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
         b120 * (3.0 * w * u * u) + b201 * (3.0 * w * w * v) + b021 * (3.0 * u * u * v) +
         b102 * (3.0 * w * v * v) + b012 * (3.0 * u * v * v) + b111 * (6.0 * w * u * v);
}

// Largest eigenvalue of a symmetric 2x2 matrix.
double largest_eigenvalue(const Eigen::Matrix2d& q) {
  const double h = 0.5 * (q(0, 0) - q(1, 1));
  return 0.5 * (q(0, 0) + q(1, 1)) + std::sqrt(h * h + q(0, 1) * q(0, 1));
}

}  // namespace

CurvedFaces::CurvedFaces(const ClothMesh& coarse, int levels, const std::string& file,
                         const std::string& where)
    : coarse_tris_(coarse.triangles()), coarse_n_(coarse.num_vertices()), levels_(levels) {
  if (levels < 0 || levels > 5)
    throw Error(file, where + ".levels", "must be an integer in [0, 5] (got " + std::to_string(levels) + ")");
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
    for (int k = 0; k < 3; ++k)
      uv[k] = ft.bary[k][0] * ruv[0] + ft.bary[k][1] * ruv[1] + ft.bary[k][2] * ruv[2];
    uvs.push_back(uv);
  }
  fine_ = ClothMesh::from_triangles(std::move(rest), std::move(fine_tris), std::move(uvs),
                                    file.empty() ? "detail" : file);
  heights_.assign(samples_.size(), 0.0);

  // Wrinkle data. Material coordinates unfolded breadth-first over the coarse triangles: every triangle's
  // rest_uv is in the same warp/weft orientation, so a triangle's unplaced corners are its rest_uv shifted by
  // the offset of an already placed corner (exact on flat and developable pieces without a closing seam).
  const auto& frames = coarse.triangle_frames();
  tri_uv_.resize(coarse_tris_.size());
  vertex_area_.assign(coarse_n_, 0.0);
  std::vector<std::vector<int>> vertex_tris(coarse_n_);
  for (size_t t = 0; t < coarse_tris_.size(); ++t) {
    tri_uv_[t] = frames[t].rest_uv;
    const Vec2 e1 = tri_uv_[t][1] - tri_uv_[t][0], e2 = tri_uv_[t][2] - tri_uv_[t][0];
    const double area = 0.5 * std::abs(e1.x() * e2.y() - e1.y() * e2.x());
    for (int v : coarse_tris_[t]) {
      vertex_tris[v].push_back(static_cast<int>(t));
      vertex_area_[v] += area;
    }
  }
  material_.assign(coarse_n_, Vec2::Zero());
  // expanded[v]: vertex v's triangles are all queued already (so each vertex's list is walked once: linear
  // in the mesh size whatever the valence).
  std::vector<char> placed(coarse_n_, 0), expanded(coarse_n_, 0), queued(coarse_tris_.size(), 0);
  for (size_t seed = 0; seed < coarse_tris_.size(); ++seed) {
    if (queued[seed]) continue;
    std::deque<int> queue{static_cast<int>(seed)};
    queued[seed] = 1;
    while (!queue.empty()) {
      const int t = queue.front();
      queue.pop_front();
      const Tri& c = coarse_tris_[t];
      Vec2 offset = Vec2::Zero();
      for (int k = 0; k < 3; ++k)
        if (placed[c[k]]) {
          offset = material_[c[k]] - tri_uv_[t][k];
          break;
        }
      for (int k = 0; k < 3; ++k) {
        if (!placed[c[k]]) {
          material_[c[k]] = tri_uv_[t][k] + offset;
          placed[c[k]] = 1;
        }
        if (expanded[c[k]]) continue;
        expanded[c[k]] = 1;
        for (int n : vertex_tris[c[k]])
          if (!queued[n]) {
            queued[n] = 1;
            queue.push_back(n);
          }
      }
    }
  }
}

void CurvedFaces::set_wrinkles(const WrinkleSettings& w, const std::string& file, const std::string& where) {
  if (w.enabled) {
    if (!(w.wavelength > 0.0) || !std::isfinite(w.wavelength))
      throw Error(file, where + ".wrinkles.wavelength", "must be a positive length (m)");
    if (!(w.amplitude >= 0.0) || !std::isfinite(w.amplitude))
      throw Error(file, where + ".wrinkles.amplitude", "must be a non-negative length (m)");
  }
  wrinkles_ = w;
}

void CurvedFaces::vertex_compression(const Vec3s& x) const {
  compression_.assign(coarse_n_, Eigen::Matrix2d::Zero());
  for (size_t t = 0; t < coarse_tris_.size(); ++t) {
    const Tri& c = coarse_tris_[t];
    const auto& uv = tri_uv_[t];
    // Deformation gradient F (3x2) from the warp/weft rest frame to the current positions.
    Eigen::Matrix2d dm;
    dm << uv[1] - uv[0], uv[2] - uv[0];
    Eigen::Matrix<double, 3, 2> ds;
    ds << x[c[1]] - x[c[0]], x[c[2]] - x[c[0]];
    const Eigen::Matrix<double, 3, 2> F = ds * dm.inverse();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(F.transpose() * F);
    Eigen::Matrix2d q = Eigen::Matrix2d::Zero();
    for (int i = 0; i < 2; ++i) {
      const double shrink = std::max(0.0, 1.0 - std::sqrt(std::max(eig.eigenvalues()[i], 0.0)));
      q += shrink * eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose();
    }
    const double area = 0.5 * std::abs(dm.determinant());
    for (int v : c) compression_[v] += area * q;
  }
  for (int v = 0; v < coarse_n_; ++v)
    if (vertex_area_[v] > 0.0) compression_[v] /= vertex_area_[v];
}

double CurvedFaces::wrinkle_height(int tri, const Vec3& bary) const {
  if (!wrinkles_.enabled || compression_.empty()) return 0.0;
  const Tri& t = coarse_tris_[tri];
  const Eigen::Matrix2d q =
      bary[0] * compression_[t[0]] + bary[1] * compression_[t[1]] + bary[2] * compression_[t[2]];
  const double q1 = std::min(largest_eigenvalue(q), 0.999);
  if (q1 <= 0.0) return 0.0;
  const Vec2 m = bary[0] * material_[t[0]] + bary[1] * material_[t[1]] + bary[2] * material_[t[2]];
  const double lambda = wrinkles_.wavelength;
  const double amplitude = std::min(wrinkles_.amplitude, lambda / kPi * std::sqrt(q1 / (1.0 - q1)));
  // Weights of the four wave directions: the principal compression direction θ (mod π) shares itself
  // between its two nearest directions (linear in angle), blended with equal weights by the isotropy of Q.
  const double q2 = q(0, 0) + q(1, 1) - largest_eigenvalue(q);
  const double anisotropy = std::clamp((q1 - q2) / q1, 0.0, 1.0);
  const double theta = 0.5 * std::atan2(2.0 * q(0, 1), q(0, 0) - q(1, 1));
  double h = 0.0;
  for (int k = 0; k < 4; ++k) {
    const double dk = k * kPi / 4.0;
    double dist = std::fmod(std::abs(theta - dk), kPi);
    if (dist > 0.5 * kPi) dist = kPi - dist;
    const double w = anisotropy * std::max(0.0, 1.0 - dist / (0.25 * kPi)) + (1.0 - anisotropy) * 0.25;
    if (w > 0.0) h += w * std::cos(2.0 * kPi * (std::cos(dk) * m.x() + std::sin(dk) * m.y()) / lambda);
  }
  return amplitude * h;
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
    fine_x[i] = pn_point(coarse_x[t[0]], coarse_x[t[1]], coarse_x[t[2]], normals_[t[0]], normals_[t[1]],
                         normals_[t[2]], s.bary);
  }
  if (!wrinkles_.enabled) return;
  vertex_compression(coarse_x);
  heights_.resize(n);
#pragma omp parallel for schedule(static) if (n > 20000)
  for (int i = 0; i < n; ++i) {
    const Sample& s = samples_[i];
    const Tri& t = coarse_tris_[s.tri];
    const Vec3 normal = s.bary[0] * normals_[t[0]] + s.bary[1] * normals_[t[1]] + s.bary[2] * normals_[t[2]];
    const double len = normal.norm();
    heights_[i] = wrinkle_height(s.tri, s.bary);
    if (len > 0.0) fine_x[i] += heights_[i] / len * normal;
  }
}

}  // namespace loom::cloth
