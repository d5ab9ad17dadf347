#include "loom/cloth/ChoiKoTerm.h"

#include <algorithm>
#include <array>
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

namespace {
std::vector<std::array<int, 4>> corners_of(const std::vector<BucklingSpring>& springs) {
  std::vector<std::array<int, 4>> e;
  e.reserve(springs.size());
  for (const BucklingSpring& s : springs) e.push_back({s.i, s.j, s.a < 0 ? s.i : s.a, s.b < 0 ? s.j : s.b});
  return e;
}
// Corner vertices of interlaced spring s (i, j, a, b; without a path, a = i and b = j carry no force).
std::array<int, 4> corners(const BucklingSpring& s) { return {s.i, s.j, s.a < 0 ? s.i : s.a, s.b < 0 ? s.j : s.b}; }
// φ(z) and its first two derivatives (see ChoiKoTerm.h).
void phi(double z, double z0, double& p, double& dp, double& ddp) {
  if (z <= 0.0) {
    p = dp = ddp = 0.0;
  } else if (z >= z0) {
    p = z;
    dp = 1.0;
    ddp = 0.0;
  } else {
    const double t = z / z0;
    p = z * t * (2.0 - t);
    dp = t * (4.0 - 3.0 * t);
    ddp = (4.0 - 6.0 * t) / z0;
  }
}
}  // namespace

ChoiKoTerm::ChoiKoTerm(int num_vertices, std::vector<Spring> sequential, std::vector<BucklingSpring> interlaced,
                       double crossover_curvature, double compensation_strain, std::vector<double> sequential_kb)
    : sequential_(std::move(sequential)),
      interlaced_(std::move(interlaced)),
      z0_(compensation_strain),
      gather_seq_(num_vertices, sequential_),
      gather_int_(num_vertices, corners_of(interlaced_)) {
  seq_force_.resize(sequential_.size());
  int_force_.resize(4 * interlaced_.size());
  set_crossover(interlaced_, crossover_curvature);
  if (sequential_kb.size() == sequential_.size()) {
    for (size_t k = 0; k < sequential_.size(); ++k) {
      BucklingSpring b;
      b.i = sequential_[k].i;
      b.j = sequential_[k].j;
      b.rest_length = sequential_[k].rest_length;
      b.kb = sequential_kb[k];
      seq_buckle_.push_back(b);
    }
    set_crossover(seq_buckle_, crossover_curvature);
  }
}

void ChoiKoTerm::set_crossover(std::vector<BucklingSpring>& springs, double crossover_curvature) const {
  // Springs of equal rest length share the crossover; grids have only a few distinct lengths.
  std::map<double, double> ratio_by_length;
  for (BucklingSpring& s : springs) {
    const double L = s.rest_length;
    const double eps = std::min(std::max(crossover_curvature * crossover_curvature * L * L / 24.0, 1e-12), 0.25);
    auto it = ratio_by_length.find(L);
    if (it == ratio_by_length.end()) it = ratio_by_length.emplace(L, choi_ko::crossover_ratio(eps)).first;
    s.cb = 12.0 * s.kb / (eps * L * L * L);
    s.l_star = it->second * L;
    s.e_offset = 0.5 * s.cb * (s.l_star - L) * (s.l_star - L) - choi_ko::buckling_energy(s.l_star, L, s.kb);
  }
}

double ChoiKoTerm::sequential_tension(int k, double l) const {
  const Spring& s = sequential_[k];
  if (l >= s.rest_length) return s.k * (l - s.rest_length);
  return seq_buckle_.empty() ? 0.0 : interlaced_tension(seq_buckle_[k], l);
}

double ChoiKoTerm::effective_length(const BucklingSpring& s, const Vec3s& x, Vec3* grad) const {
  const Vec3 d = x[s.j] - x[s.i];
  const double l = d.norm();
  const Vec3 u = d / l;
  if (s.a < 0 || s.path_rest <= 0.0) {
    if (grad) {
      grad[0] = -u;
      grad[1] = u;
      grad[2] = grad[3] = Vec3::Zero();
    }
    return l;
  }
  const Vec3 ia = x[s.a] - x[s.i], aj = x[s.j] - x[s.a], ib = x[s.b] - x[s.i], bj = x[s.j] - x[s.b];
  const double P = 0.5 * (ia.norm() + aj.norm() + ib.norm() + bj.norm());
  double p, dp, ddp;
  phi(P / s.path_rest - 1.0, z0_, p, dp, ddp);
  const double sc = 1.0 + p;
  if (grad) {
    grad[0] = -u / sc;
    grad[1] = u / sc;
    grad[2] = grad[3] = Vec3::Zero();
    if (dp != 0.0) {
      // ∇l_eff = ∇l / s - l / s² ∇s, ∇s = φ' ∇P / P0.
      const double w = -l / (sc * sc) * dp / s.path_rest * 0.5;
      const Vec3 wia = ia.normalized(), waj = aj.normalized(), wib = ib.normalized(), wbj = bj.normalized();
      grad[0] += w * (-wia - wib);
      grad[1] += w * (waj + wbj);
      grad[2] += w * (wia - waj);
      grad[3] += w * (wib - wbj);
    }
  }
  return l / sc;
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
  for (size_t k = 0; k < sequential_.size(); ++k) {
    const Spring& s = sequential_[k];
    const double l = (c.x[s.j] - c.x[s.i]).norm(), stretch = l - s.rest_length;
    if (stretch > 0.0) e += 0.5 * s.k * stretch * stretch;
    else if (!seq_buckle_.empty()) e += interlaced_energy(seq_buckle_[k], l);
  }
  for (const BucklingSpring& s : interlaced_) e += interlaced_energy(s, effective_length(s, c.x, nullptr));
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
      seq_force_[k] = (sequential_tension(k, l) + s.c * u.dot(c.v[s.j] - c.v[s.i])) * u;
    }
#pragma omp for schedule(static)
    for (int k = 0; k < nb; ++k) {
      const BucklingSpring& s = interlaced_[k];
      Vec3 g[4];
      const double T = interlaced_tension(s, effective_length(s, c.x, g));
      for (int q = 0; q < 4; ++q) int_force_[4 * k + q] = -T * g[q];
    }
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) f[i] += gather_seq_.sum(i, seq_force_) + gather_int_.sum(i, int_force_);
  }
}

void ChoiKoTerm::add_pattern(std::vector<std::pair<int, int>>& pairs) const {
  for (const Spring& s : sequential_) pairs.emplace_back(s.i, s.j);
  for (const BucklingSpring& s : interlaced_) {
    const auto v = corners(s);
    for (int p = 0; p < 4; ++p)
      for (int q = p + 1; q < 4; ++q)
        if (v[p] != v[q]) pairs.emplace_back(v[p], v[q]);
  }
}

namespace {
void add_pair_block(BlockMatrix& m, int i, int j, const Mat3& K) {
  m.add(i, i, -K);
  m.add(i, j, K);
  m.add(j, i, K);
  m.add(j, j, -K);
}
using Mat12 = Eigen::Matrix<double, 12, 12>;
using Vec12 = Eigen::Matrix<double, 12, 1>;
// Adds the Hessian of |x_q - x_p| (corners p, q), times w, to H.
void add_length_hessian(Mat12& H, int p, int q, const Vec3& d, double w) {
  const double len = d.norm();
  const Vec3 u = d / len;
  const Mat3 A = w * (Mat3::Identity() - u * u.transpose()) / len;
  H.block<3, 3>(3 * p, 3 * p) += A;
  H.block<3, 3>(3 * q, 3 * q) += A;
  H.block<3, 3>(3 * p, 3 * q) -= A;
  H.block<3, 3>(3 * q, 3 * p) -= A;
}
}  // namespace

void ChoiKoTerm::add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                               BlockMatrix* dfdv) const {
  for (size_t k = 0; k < sequential_.size(); ++k) {
    const Spring& s = sequential_[k];
    const Vec3 d = c.x[s.j] - c.x[s.i];
    const double l = d.norm();
    const Vec3 u = d / l;
    const Mat3 uu = u * u.transpose(), transverse = Mat3::Identity() - uu;
    if (dfdx) {
      Mat3 K = Mat3::Zero();
      if (l > s.rest_length) {
        K = s.k * (uu + (1.0 - s.rest_length / l) * transverse);
      } else if (!seq_buckle_.empty()) {
        K = interlaced_stiffness(seq_buckle_[k], l) * uu;
        if (!o.clamp_compression) K += interlaced_tension(seq_buckle_[k], l) / l * transverse;
      }
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
    Vec3 g[4];
    const double le = effective_length(s, c.x, g);
    if (le >= s.rest_length) continue;
    const double T = interlaced_tension(s, le), dT = interlaced_stiffness(s, le);
    const auto v = corners(s);
    Vec12 G;
    for (int q = 0; q < 4; ++q) G.segment<3>(3 * q) = g[q];
    // Hessian of E(l_eff): T' ∇l_eff ∇l_effᵀ + T ∇²l_eff; the second part is indefinite for T < 0 and
    // is dropped with clamp_compression (Choi-Ko), which keeps -K positive semi-definite.
    Mat12 H = dT * G * G.transpose();
    if (!o.clamp_compression) {
      const Vec3 d = c.x[s.j] - c.x[s.i];
      const double l = d.norm();
      Mat12 Hl = Mat12::Zero();
      add_length_hessian(Hl, 0, 1, d, 1.0);
      double p = 0.0, dp = 0.0, ddp = 0.0;
      Vec12 Gp = Vec12::Zero();
      Mat12 HP = Mat12::Zero();
      if (s.a >= 0 && s.path_rest > 0.0) {
        const Vec3 ia = c.x[s.a] - c.x[s.i], aj = c.x[s.j] - c.x[s.a], ib = c.x[s.b] - c.x[s.i], bj = c.x[s.j] - c.x[s.b];
        const double P = 0.5 * (ia.norm() + aj.norm() + ib.norm() + bj.norm());
        phi(P / s.path_rest - 1.0, z0_, p, dp, ddp);
        const Vec3 wia = ia.normalized(), waj = aj.normalized(), wib = ib.normalized(), wbj = bj.normalized();
        Gp.segment<3>(0) = 0.5 * (-wia - wib);
        Gp.segment<3>(3) = 0.5 * (waj + wbj);
        Gp.segment<3>(6) += 0.5 * (wia - waj);
        Gp.segment<3>(9) += 0.5 * (wib - wbj);
        add_length_hessian(HP, 0, 2, ia, 0.5);
        add_length_hessian(HP, 2, 1, aj, 0.5);
        add_length_hessian(HP, 0, 3, ib, 0.5);
        add_length_hessian(HP, 3, 1, bj, 0.5);
      }
      const double sc = 1.0 + p, P0 = s.path_rest > 0.0 ? s.path_rest : 1.0;
      Vec12 Gl = Vec12::Zero();
      Gl.segment<3>(0) = -d / l;
      Gl.segment<3>(3) = d / l;
      const Vec12 Gs = dp / P0 * Gp;
      const Mat12 Hs = ddp / (P0 * P0) * Gp * Gp.transpose() + dp / P0 * HP;
      const Mat12 Hle = Hl / sc - (Gl * Gs.transpose() + Gs * Gl.transpose()) / (sc * sc) - l / (sc * sc) * Hs +
                        2.0 * l / (sc * sc * sc) * Gs * Gs.transpose();
      H += T * Hle;
    }
    // dfdx = -H, scattered over the corners (a corner may repeat: grids have a = b).
    for (int p = 0; p < 4; ++p)
      for (int q = 0; q < 4; ++q) {
        if ((p >= 2 || q >= 2) && (s.a < 0 || s.path_rest <= 0.0)) continue;
        dfdx->add(v[p], v[q], -H.block<3, 3>(3 * p, 3 * q));
      }
  }
}

std::unique_ptr<ChoiKoTerm> make_choi_ko_term(const ClothMesh& mesh, const Material& mat) {
  // Type 1: the tension-only counterparts of the mesh's structural/shear (grid) or edge springs, mapped as
  // if there were no bend springs (whose in-plane share make_springs would otherwise take out).
  Material membrane = mat;
  membrane.bend_weft = membrane.bend_warp = 0.0;
  std::vector<Spring> all = make_springs(mesh, membrane), sequential;
  std::vector<double> sequential_kb;
  for (size_t k = 0; k < all.size(); ++k) {
    const SpringDef& d = mesh.springs()[k];
    if (d.kind == SpringKind::kStructural || d.kind == SpringKind::kShear || d.kind == SpringKind::kEdge) {
      sequential.push_back(all[k]);
      const Vec2 dir = d.rest_uv_dir;
      sequential_kb.push_back((mat.bend_weft * dir.x() * dir.x() + mat.bend_warp * dir.y() * dir.y()) * d.area / d.rest_length);
    }
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
      BucklingSpring s;
      s.i = mesh.grid_index(iu, iv);
      s.j = mesh.grid_index(ju, jv);
      s.rest_length = L;
      s.kb = 2.0 / 3.0 * directional_bend(d / L) * du * dv / L;
      s.a = s.b = mesh.grid_index((iu + ju) / 2, (iv + jv) / 2);
      s.path_rest = L;
      interlaced.push_back(s);
    };
    for (int iv = 0; iv < nv; ++iv)
      for (int iu = 0; iu < nu; ++iu) {
        add(iu, iv, iu + 2, iv);
        add(iu, iv, iu, iv + 2);
        add(iu, iv, iu + 2, iv + 2);
        add(iu, iv, iu - 2, iv + 2);
      }
  } else {
    size_t hinge = 0;  // hinge springs follow mesh.hinges() in order
    for (const SpringDef& d : mesh.springs())
      if (d.kind == SpringKind::kHinge) {
        const Hinge& h = mesh.hinges()[hinge++];
        BucklingSpring s;
        s.i = d.i;
        s.j = d.j;
        s.rest_length = d.rest_length;
        s.kb = 8.0 / 3.0 * directional_bend(d.rest_uv_dir) * d.area / d.rest_length;
        s.a = h.e0;
        s.b = h.e1;
        s.path_rest = 0.5 * ((x[h.e0] - x[d.i]).norm() + (x[d.j] - x[h.e0]).norm() + (x[h.e1] - x[d.i]).norm() +
                             (x[d.j] - x[h.e1]).norm());
        interlaced.push_back(s);
      }
  }
  return std::make_unique<ChoiKoTerm>(mesh.num_vertices(), std::move(sequential), std::move(interlaced), 4.0, 1e-5,
                                      std::move(sequential_kb));
}

}  // namespace loom::cloth
