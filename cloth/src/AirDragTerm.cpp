#include "loom/cloth/AirDragTerm.h"

#include <cmath>

#include "Numbers.h"

namespace loom::cloth {

namespace {
Mat3 skew(const Vec3& a) {
  Mat3 m;
  m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return m;
}
}  // namespace

Vec3 DragSettings::wind_at(double t) const {
  if (gust_amplitude == 0.0) return wind;
  return wind * (1.0 + gust_amplitude * std::sin(kTwoPi * gust_frequency * t));
}

AirDragTerm::AirDragTerm(const DragSettings& s, std::vector<Tri> triangles, std::vector<double> vertex_area)
    : s_(s), triangles_(std::move(triangles)), vertex_area_(std::move(vertex_area)) {
  vertex_triangles_.resize(vertex_area_.size());
  for (size_t t = 0; t < triangles_.size(); ++t)
    for (int v : triangles_[t]) vertex_triangles_[v].push_back(static_cast<int>(t));
  tri_force_.resize(triangles_.size());
}

void AirDragTerm::add_forces(const EvalContext& c, Vec3s& f) const {
  const Vec3 w = s_.wind_at(c.t);
  const int nt = static_cast<int>(triangles_.size());
  const int nv = static_cast<int>(vertex_area_.size());
  const bool normal = s_.normal != 0.0;
#pragma omp parallel num_threads(c.threads) if (c.threads > 1)
  {
    if (normal) {
#pragma omp for schedule(static)
      for (int t = 0; t < nt; ++t) {
        const Tri& tri = triangles_[t];
        const Vec3 N = (c.x[tri[1]] - c.x[tri[0]]).cross(c.x[tri[2]] - c.x[tri[0]]);
        const double len = N.norm();
        const Vec3 vrel = (c.v[tri[0]] + c.v[tri[1]] + c.v[tri[2]]) / 3.0 - w;
        // F = -c_n A (vrel·n̂) n̂ = -c_n (vrel·N) N / (2|N|); a third per vertex.
        tri_force_[t] = len > 0.0 ? Vec3(-s_.normal * vrel.dot(N) / (6.0 * len) * N) : Vec3::Zero();
      }
    }
#pragma omp for schedule(static)
    for (int i = 0; i < nv; ++i) {
      Vec3 acc = -s_.isotropic * vertex_area_[i] * (c.v[i] - w);
      if (normal)
        for (int t : vertex_triangles_[i]) acc += tri_force_[t];
      f[i] += acc;
    }
  }
}

void AirDragTerm::add_pattern(std::vector<std::pair<int, int>>& pairs) const {
  if (s_.normal == 0.0) return;
  for (const Tri& t : triangles_) {
    pairs.emplace_back(t[0], t[1]);
    pairs.emplace_back(t[1], t[2]);
    pairs.emplace_back(t[0], t[2]);
  }
}

void AirDragTerm::add_jacobians(const EvalContext& c, const JacobianOptions&, BlockMatrix* dfdx,
                                BlockMatrix* dfdv) const {
  if (dfdv)
    for (size_t i = 0; i < vertex_area_.size(); ++i)
      dfdv->add(static_cast<int>(i), static_cast<int>(i), -s_.isotropic * vertex_area_[i] * Mat3::Identity());
  if (s_.normal == 0.0) return;
  const Vec3 w = s_.wind_at(c.t);
  for (const Tri& tri : triangles_) {
    const Vec3 e1 = c.x[tri[1]] - c.x[tri[0]], e2 = c.x[tri[2]] - c.x[tri[0]];
    const Vec3 N = e1.cross(e2);
    const double len = N.norm();
    if (len == 0.0) continue;
    if (dfdv) {
      const Mat3 D = -s_.normal / (18.0 * len) * (N * N.transpose());
      for (int a : tri)
        for (int b : tri) dfdv->add(a, b, D);
    }
    if (dfdx) {
      const Vec3 vrel = (c.v[tri[0]] + c.v[tri[1]] + c.v[tri[2]]) / 3.0 - w;
      const double vn = vrel.dot(N);
      // g(N) = (vrel·N) N / |N|;  dg/dN = [N vrelᵀ + (vrel·N) I] / |N| - (vrel·N) N Nᵀ / |N|³.
      const Mat3 dg =
          (N * vrel.transpose() + vn * Mat3::Identity()) / len - vn * (N * N.transpose()) / (len * len * len);
      // dN/dx0 = [e2]x - [e1]x, dN/dx1 = -[e2]x, dN/dx2 = [e1]x.
      const Mat3 dN[3] = {skew(e2) - skew(e1), -skew(e2), skew(e1)};
      for (int k = 0; k < 3; ++k) {
        const Mat3 J = -s_.normal / 6.0 * dg * dN[k];
        for (int a : tri) dfdx->add(a, tri[k], J);
      }
    }
  }
}

}  // namespace loom::cloth
