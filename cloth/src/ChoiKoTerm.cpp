#include "loom/cloth/ChoiKoTerm.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "loom/cloth/SpringSet.h"

namespace loom::cloth {

namespace choi_ko {

namespace {
constexpr double kPi = 3.14159265358979323846;

// q(y) = (cos y - sinc y) / y², and q'(y) / y; Taylor series below y = 0.1 where the direct form cancels.
double q_of(double y) {
  if (y < 0.1) {
    const double y2 = y * y;
    return -1.0 / 3.0 + y2 * (1.0 / 30.0 + y2 * (-1.0 / 840.0 + y2 / 45360.0));
  }
  return (std::cos(y) - std::sin(y) / y) / (y * y);
}
double dq_over_y(double y) {
  if (y < 0.1) {
    const double y2 = y * y;
    return 1.0 / 15.0 + y2 * (-1.0 / 210.0 + y2 / 7560.0);
  }
  // q = c / y², c = cos y - sinc y, c' = -sin y - c / y  =>  q' = c'/y² - 2c/y³.
  const double c = std::cos(y) - std::sin(y) / y;
  const double dc = -std::sin(y) - c / y;
  return (dc / (y * y) - 2.0 * c / (y * y * y)) / y;
}
double sinc(double y) { return y < 1e-4 ? 1.0 - y * y / 6.0 : std::sin(y) / y; }
}  // namespace

double arc_half_angle(double ratio) {
  if (ratio >= 1.0) return 0.0;
  if (ratio <= 0.0) return kPi;
  double lo = 0.0, hi = kPi;
  // Series guess y² ≈ 6 (1 - l/L) near l = L; Newton, kept inside the bracket by bisection.
  double y = std::clamp(std::sqrt(6.0 * (1.0 - ratio)), 1e-9, kPi);
  for (int it = 0; it < 60; ++it) {
    const double g = sinc(y) - ratio;  // decreasing in y
    if (g == 0.0) return y;
    if (g > 0) lo = y; else hi = y;
    const double slope = q_of(y) * y;  // d sinc / dy = (cos y - sinc y) / y
    double next = slope != 0.0 ? y - g / slope : 0.5 * (lo + hi);
    if (!(next >= lo && next <= hi)) next = 0.5 * (lo + hi);  // inclusive: a converged step lands on y
    const double step = std::abs(next - y);
    y = next;
    // Converged to round-off: sinc is known to ~1e-16 and its slope is ~y/3, so y to ~3e-16 / y.
    if (step <= 1e-15 * (y + 1.0 / y)) break;
  }
  return y;
}

double buckling_force(double l, double rest, double kb) {
  const double y = arc_half_angle(l / rest);
  return 4.0 * kb / (rest * rest) / q_of(y);
}

double buckling_force_derivative(double l, double rest, double kb) {
  const double y = arc_half_angle(l / rest);
  const double q = q_of(y);
  // df/dl = (df/dy) / (dl/dy), dl/dy = L q y, f = 4 k_b / (L² q).
  return -4.0 * kb / (rest * rest * rest) * dq_over_y(y) / (q * q * q);
}

double buckling_energy(double l, double rest, double kb) {
  const double y = arc_half_angle(l / rest);
  return 2.0 * kb * y * y / rest;
}

double crossover_ratio(double eps) {
  // In units of k_b/L²: linear -12 (1 - x)/ε*, curve 4 / q(y(x)); they cross once in (0, 1) for ε* < 0.3.
  double lo = 0.0, hi = 1.0;
  for (int it = 0; it < 64; ++it) {
    const double x = 0.5 * (lo + hi);
    const double g = -12.0 * (1.0 - x) / eps - 4.0 / q_of(arc_half_angle(x));
    if (g > 0) hi = x; else lo = x;
  }
  return 0.5 * (lo + hi);
}

}  // namespace choi_ko

ChoiKoTerm::ChoiKoTerm(int num_vertices, std::vector<Spring> sequential, std::vector<BucklingSpring> interlaced,
                       double crossover_curvature)
    : sequential_(std::move(sequential)),
      interlaced_(std::move(interlaced)),
      gather_seq_(num_vertices, sequential_),
      gather_int_(num_vertices, interlaced_) {
  seq_force_.resize(sequential_.size());
  int_force_.resize(interlaced_.size());
  // Springs of equal rest length share the crossover; grids have only a few distinct lengths.
  std::map<double, double> ratio_by_length;
  for (BucklingSpring& s : interlaced_) {
    const double L = s.rest_length;
    const double eps = std::min(std::max(crossover_curvature * crossover_curvature * L * L / 24.0, 1e-12), 0.25);
    auto it = ratio_by_length.find(L);
    if (it == ratio_by_length.end()) it = ratio_by_length.emplace(L, choi_ko::crossover_ratio(eps)).first;
    s.cb = 12.0 * s.kb / (eps * L * L * L);
    s.l_star = it->second * L;
    s.e_offset = 0.5 * s.cb * (s.l_star - L) * (s.l_star - L) - choi_ko::buckling_energy(s.l_star, L, s.kb);
  }
}

double ChoiKoTerm::interlaced_tension(const BucklingSpring& s, double l) const {
  if (l >= s.rest_length) return 0.0;
  if (l >= s.l_star) return s.cb * (l - s.rest_length);
  return choi_ko::buckling_force(l, s.rest_length, s.kb);
}

double ChoiKoTerm::interlaced_stiffness(const BucklingSpring& s, double l) const {
  if (l >= s.rest_length) return 0.0;
  if (l >= s.l_star) return s.cb;
  return choi_ko::buckling_force_derivative(l, s.rest_length, s.kb);
}

double ChoiKoTerm::interlaced_energy(const BucklingSpring& s, double l) const {
  if (l >= s.rest_length) return 0.0;
  if (l >= s.l_star) return 0.5 * s.cb * (l - s.rest_length) * (l - s.rest_length);
  return s.e_offset + choi_ko::buckling_energy(l, s.rest_length, s.kb);
}

double ChoiKoTerm::energy(const EvalContext& c) const {
  double e = 0.0;
  for (const Spring& s : sequential_) {
    const double stretch = (c.x[s.j] - c.x[s.i]).norm() - s.rest_length;
    if (stretch > 0.0) e += 0.5 * s.k * stretch * stretch;
  }
  for (const BucklingSpring& s : interlaced_) e += interlaced_energy(s, (c.x[s.j] - c.x[s.i]).norm());
  return e;
}

void ChoiKoTerm::add_forces(const EvalContext& c, Vec3s& f) const {
  const int ns = static_cast<int>(sequential_.size()), nb = static_cast<int>(interlaced_.size());
  const int n = gather_seq_.num_vertices();
#pragma omp parallel num_threads(c.threads) if (c.threads > 1)
  {
#pragma omp for schedule(static)
    for (int k = 0; k < ns; ++k) {
      const Spring& s = sequential_[k];
      const Vec3 d = c.x[s.j] - c.x[s.i];
      const double l = d.norm();
      const Vec3 u = d / l;
      seq_force_[k] = (s.k * std::max(l - s.rest_length, 0.0) + s.c * u.dot(c.v[s.j] - c.v[s.i])) * u;
    }
#pragma omp for schedule(static)
    for (int k = 0; k < nb; ++k) {
      const BucklingSpring& s = interlaced_[k];
      const Vec3 d = c.x[s.j] - c.x[s.i];
      const double l = d.norm();
      int_force_[k] = interlaced_tension(s, l) / l * d;
    }
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) f[i] += gather_seq_.sum(i, seq_force_) + gather_int_.sum(i, int_force_);
  }
}

void ChoiKoTerm::add_pattern(std::vector<std::pair<int, int>>& pairs) const {
  for (const Spring& s : sequential_) pairs.emplace_back(s.i, s.j);
  for (const BucklingSpring& s : interlaced_) pairs.emplace_back(s.i, s.j);
}

namespace {
void add_pair_block(BlockMatrix& m, int i, int j, const Mat3& K) {
  m.add(i, i, -K);
  m.add(i, j, K);
  m.add(j, i, K);
  m.add(j, j, -K);
}
}  // namespace

void ChoiKoTerm::add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                               BlockMatrix* dfdv) const {
  for (const Spring& s : sequential_) {
    const Vec3 d = c.x[s.j] - c.x[s.i];
    const double l = d.norm();
    const Vec3 u = d / l;
    const Mat3 uu = u * u.transpose(), transverse = Mat3::Identity() - uu;
    if (dfdx) {
      Mat3 K = Mat3::Zero();
      if (l > s.rest_length) K = s.k * (uu + (1.0 - s.rest_length / l) * transverse);
      if (o.damping_position_terms && s.c != 0.0) {
        const Vec3 w = c.v[s.j] - c.v[s.i];
        K += s.c * (u.dot(w) * Mat3::Identity() + u * w.transpose()) * transverse / l;
      }
      add_pair_block(*dfdx, s.i, s.j, K);
    }
    if (dfdv && s.c != 0.0) add_pair_block(*dfdv, s.i, s.j, s.c * uu);
  }
  if (!dfdx) return;
  for (const BucklingSpring& s : interlaced_) {
    const Vec3 d = c.x[s.j] - c.x[s.i];
    const double l = d.norm();
    if (l >= s.rest_length) continue;
    const Vec3 u = d / l;
    const Mat3 uu = u * u.transpose();
    Mat3 K = interlaced_stiffness(s, l) * uu;
    if (!o.clamp_compression) K += interlaced_tension(s, l) / l * (Mat3::Identity() - uu);
    add_pair_block(*dfdx, s.i, s.j, K);
  }
}

std::unique_ptr<ChoiKoTerm> make_choi_ko_term(const ClothMesh& mesh, const Material& mat) {
  // Type 1: the tension-only counterparts of the mesh's structural/shear (grid) or edge springs, mapped as
  // if there were no bend springs (whose in-plane share make_springs would otherwise take out).
  Material membrane = mat;
  membrane.bend_weft = membrane.bend_warp = 0.0;
  std::vector<Spring> all = make_springs(mesh, membrane), sequential;
  for (size_t k = 0; k < all.size(); ++k) {
    const SpringKind kind = mesh.springs()[k].kind;
    if (kind == SpringKind::kStructural || kind == SpringKind::kShear || kind == SpringKind::kEdge) sequential.push_back(all[k]);
  }
  // Type 2: interlaced pairs.
  std::vector<BucklingSpring> interlaced;
  const Vec3s& x = mesh.rest_positions();
  auto directional_bend = [&](const Vec2& dir) {
    return mat.bend_weft * dir.x() * dir.x() + mat.bend_warp * dir.y() * dir.y();
  };
  if (mesh.is_grid()) {
    const int nu = mesh.grid_nodes_u(), nv = mesh.grid_nodes_v();
    const double du = (x[mesh.grid_index(1, 0)] - x[mesh.grid_index(0, 0)]).norm();
    const double dv = (x[mesh.grid_index(0, 1)] - x[mesh.grid_index(0, 0)]).norm();
    auto add = [&](int iu, int iv, int ju, int jv) {
      if (ju < 0 || ju >= nu || jv >= nv) return;
      const Vec2 d((ju - iu) * du, (jv - iv) * dv);
      const double L = d.norm();
      interlaced.push_back({mesh.grid_index(iu, iv), mesh.grid_index(ju, jv), L,
                            2.0 / 3.0 * directional_bend(d / L) * du * dv / L});
    };
    for (int iv = 0; iv < nv; ++iv)
      for (int iu = 0; iu < nu; ++iu) {
        add(iu, iv, iu + 2, iv);
        add(iu, iv, iu, iv + 2);
        add(iu, iv, iu + 2, iv + 2);
        add(iu, iv, iu - 2, iv + 2);
      }
  } else {
    for (const SpringDef& d : mesh.springs())
      if (d.kind == SpringKind::kHinge)
        interlaced.push_back({d.i, d.j, d.rest_length, 8.0 / 3.0 * directional_bend(d.rest_uv_dir) * d.area / d.rest_length});
  }
  return std::make_unique<ChoiKoTerm>(mesh.num_vertices(), std::move(sequential), std::move(interlaced));
}

}  // namespace loom::cloth
