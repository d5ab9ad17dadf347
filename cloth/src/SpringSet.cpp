#include "loom/cloth/SpringSet.h"

#include <algorithm>
#include <cmath>

namespace loom::cloth {

namespace {

// Directional interpolation between weft (φ = 0) and warp (φ = 90°) values; `dir` is a unit vector in
// material space (x = weft, y = warp).
double directional(double weft, double warp, const Vec2& dir) {
  return weft * dir.x() * dir.x() + warp * dir.y() * dir.y();
}

// Matches 1/2 k (L - l)² with l = L(1 - κ²L²/24) to the bending energy 1/2 B κ² A_e at κ = 1/L.
double bend_spring_stiffness(double bending, double area, double rest) {
  return 576.0 * bending * area / std::pow(rest, 4);
}

}  // namespace

std::vector<Spring> make_springs(const ClothMesh& mesh, const Material& mat) {
  const double shear_k = std::min(mat.shear, 0.5 * std::min(mat.stretch_weft, mat.stretch_warp));
  // On grids, bend springs (length 2d, two crossing every cut) add 4 k_bend to the in-plane modulus along
  // their direction; the structural springs give that much less, and k_bend is capped at (Y - k_d) / 8 so
  // at least half the modulus stays in the structural springs (fine grids, where 576 B A / L⁴ grows as 1/d²).
  auto bend_k = [&](const SpringDef& d) {
    const double k = bend_spring_stiffness(directional(mat.bend_weft, mat.bend_warp, d.rest_uv_dir), d.area,
                                           d.rest_length);
    if (d.kind != SpringKind::kBend) return k;
    return std::min(k, (directional(mat.stretch_weft, mat.stretch_warp, d.rest_uv_dir) - shear_k) / 8.0);
  };
  double bend_weft = 0.0, bend_warp = 0.0;  // grid bend-spring stiffness along each axis (interior rows)
  for (const SpringDef& d : mesh.springs())
    if (d.kind == SpringKind::kBend && d.row_share == 1.0)
      (std::abs(d.rest_uv_dir.x()) > 0.5 ? bend_weft : bend_warp) = bend_k(d);
  std::vector<Spring> out;
  out.reserve(mesh.springs().size());
  for (const SpringDef& d : mesh.springs()) {
    Spring s;
    s.i = d.i;
    s.j = d.j;
    s.rest_length = d.rest_length;
    switch (d.kind) {
      case SpringKind::kStructural:
        s.k = directional(mat.stretch_weft, mat.stretch_warp, d.rest_uv_dir) - shear_k -
              4.0 * (std::abs(d.rest_uv_dir.x()) > 0.5 ? bend_weft : bend_warp);
        break;
      case SpringKind::kShear:
        s.k = shear_k;
        break;
      case SpringKind::kBend:
      case SpringKind::kHinge:
        s.k = bend_k(d);
        break;
      case SpringKind::kEdge:
        // Van Gelder 1998: k_e = E sum_t A_t / l_e² for a 2D modulus E (N/m).
        s.k = directional(mat.stretch_weft, mat.stretch_warp, d.rest_uv_dir) * d.area /
              (d.rest_length * d.rest_length);
        break;
    }
    s.k *= d.row_share;
    s.c = mat.damping * s.k;
    out.push_back(s);
  }
  return out;
}

}  // namespace loom::cloth
