#include "loom/cloth/ChoiKoTerm.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <unsupported/Eigen/AutoDiff>

#include "Numbers.h"
#include "loom/cloth/SpringSet.h"

namespace loom::cloth {

namespace choi_ko {

namespace {

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
    if (g > 0)
      lo = y;
    else
      hi = y;
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
    if (g > 0)
      hi = x;
    else
      lo = x;
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
std::array<int, 4> corners(const BucklingSpring& s) {
  return {s.i, s.j, s.a < 0 ? s.i : s.a, s.b < 0 ? s.j : s.b};
}
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

ChoiKoTerm::ChoiKoTerm(int num_vertices, std::vector<Spring> sequential,
                       std::vector<BucklingSpring> interlaced, double crossover_curvature,
                       double compensation_strain, std::vector<double> sequential_kb)
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
    const double eps =
        std::min(std::max(crossover_curvature * crossover_curvature * L * L / 24.0, 1e-12), 0.25);
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

namespace {
using Mat12 = Eigen::Matrix<double, 12, 12>;
using Vec12 = Eigen::Matrix<double, 12, 1>;
using Ad1 = Eigen::AutoDiffScalar<Eigen::Matrix<double, 5, 1>>;
using Ad2 = Eigen::AutoDiffScalar<Eigen::Matrix<Ad1, 5, 1>>;

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

// The unfolded chord of a hinge: the distance between the opposite vertices i, j of the triangles (i, e0, e1)
// and (j, e0, e1) when the two are laid flat, from the five edge lengths a_i = |i e0|, b_i = |i e1|,
// a_j = |j e0|, b_j = |j e1|, e = |e0 e1|: the foot of i on the edge is t_i = (a_i² + e² - b_i²) / 2e from
// e0, its height h_i = √(a_i² - t_i²), and l_u = √((t_i - t_j)² + (h_i + h_j)²).
template <class T>
T unfolded_chord(const T& ai, const T& bi, const T& aj, const T& bj, const T& e) {
  using std::sqrt;
  const T ti = (ai * ai + e * e - bi * bi) / (2.0 * e), tj = (aj * aj + e * e - bj * bj) / (2.0 * e);
  T hi2 = ai * ai - ti * ti, hj2 = aj * aj - tj * tj;
  if (hi2 < 1e-30) hi2 = T(1e-30);
  if (hj2 < 1e-30) hj2 = T(1e-30);
  const T dt = ti - tj, hs = sqrt(hi2) + sqrt(hj2);
  return sqrt(dt * dt + hs * hs);
}

// Corner pairs of the lengths that l_u depends on: the path i-a-j, i-b-j (grids: a = b, the middle node),
// or the hinge's five edges (meshes).
constexpr int kPathPairs[4][2] = {{0, 2}, {2, 1}, {0, 3}, {3, 1}};
constexpr int kHingePairs[5][2] = {{0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
}  // namespace

bool ChoiKoTerm::has_path(const BucklingSpring& s) { return s.a >= 0 && s.path_rest > 0.0; }

void ChoiKoTerm::geometry(const BucklingSpring& s, const Vec3s& x, bool hessian, SpringGeometry& g) const {
  const auto v = corners(s);
  const Vec3 d = x[s.j] - x[s.i];
  g.l = d.norm();
  const Vec3 u = d / g.l;
  g.gl.setZero();
  g.gl.segment<3>(0) = -u;
  g.gl.segment<3>(3) = u;
  if (hessian) {
    g.Hl.setZero();
    add_length_hessian(g.Hl, 0, 1, d, 1.0);
  }
  if (!has_path(s)) return;
  // l_u = F(lengths): ∇l_u = Σ F_k ∇len_k, ∇²l_u = Σ F_km ∇len_k ∇len_mᵀ + Σ F_k ∇²len_k.
  const bool path = s.a == s.b;
  const int np = path ? 4 : 5;
  const int(*pairs)[2] = path ? kPathPairs : kHingePairs;
  double len[5];
  Vec3 dir[5];
  for (int k = 0; k < np; ++k) {
    const Vec3 e = x[v[pairs[k][1]]] - x[v[pairs[k][0]]];
    len[k] = e.norm();
    dir[k] = e;
  }
  Eigen::Matrix<double, 5, 1> F = Eigen::Matrix<double, 5, 1>::Zero();
  Eigen::Matrix<double, 5, 5> FF = Eigen::Matrix<double, 5, 5>::Zero();
  if (path) {
    g.lu = 0.5 * (len[0] + len[1] + len[2] + len[3]);
    F.head<4>().setConstant(0.5);
  } else if (!hessian) {
    Ad1 a[5];
    for (int k = 0; k < 5; ++k) a[k] = Ad1(len[k], 5, k);
    const Ad1 r = unfolded_chord(a[0], a[1], a[2], a[3], a[4]);
    g.lu = r.value();
    F = r.derivatives();
  } else {
    Ad2 a[5];
    for (int k = 0; k < 5; ++k) {
      a[k].value() = Ad1(len[k], 5, k);
      a[k].derivatives().resize(5);
      for (int m = 0; m < 5; ++m)
        a[k].derivatives()[m] = Ad1(m == k ? 1.0 : 0.0, Eigen::Matrix<double, 5, 1>::Zero());
    }
    const Ad2 r = unfolded_chord(a[0], a[1], a[2], a[3], a[4]);
    g.lu = r.value().value();
    F = r.value().derivatives();
    for (int k = 0; k < 5; ++k) FF.row(k) = r.derivatives()[k].derivatives().transpose();
  }
  g.glu.setZero();
  Vec12 G[5];
  for (int k = 0; k < np; ++k) {
    const Vec3 w = dir[k] / len[k];
    G[k].setZero();
    G[k].segment<3>(3 * pairs[k][0]) -= w;
    G[k].segment<3>(3 * pairs[k][1]) += w;
    g.glu += F[k] * G[k];
  }
  if (!hessian) return;
  g.Hlu.setZero();
  for (int k = 0; k < np; ++k) {
    add_length_hessian(g.Hlu, pairs[k][0], pairs[k][1], dir[k], F[k]);
    if (!path)
      for (int m = 0; m < np; ++m) g.Hlu += FF(k, m) * G[k] * G[m].transpose();
  }
}

void ChoiKoTerm::ratios(const BucklingSpring& s, const SpringGeometry& g, double& r, double& m, double& dm,
                        double& ddm) const {
  if (!has_path(s)) {
    r = 1.0;
    m = g.l / s.rest_length;
    dm = ddm = 0.0;  // unused: m follows l directly
    return;
  }
  r = g.l / g.lu;
  // m = w / (1 + φ(w - 1)), w = l_u / l_u0: the membrane's compression along the spring (1 when stretched).
  const double P0 = s.path_rest, w = g.lu / P0;
  double p, dp, ddp;
  phi(w - 1.0, z0_, p, dp, ddp);
  const double D = 1.0 + p;
  m = w / D;
  dm = (1.0 / D - w * dp / (D * D)) / P0;
  ddm = (-2.0 * dp / (D * D) - w * ddp / (D * D) + 2.0 * w * dp * dp / (D * D * D)) / (P0 * P0);
}

double ChoiKoTerm::bending_tension(const BucklingSpring& s, double r) const {
  const double L = s.rest_length;
  return r >= 1.0 ? -12.0 * s.kb / (L * L) : choi_ko::buckling_force(r * L, L, s.kb);
}
double ChoiKoTerm::bending_stiffness(const BucklingSpring& s, double r) const {
  const double L = s.rest_length;
  return r >= 1.0 ? 7.2 * s.kb / (L * L * L) : choi_ko::buckling_force_derivative(r * L, L, s.kb);
}
double ChoiKoTerm::bending_energy(const BucklingSpring& s, double r) const {
  const double L = s.rest_length;
  return r >= 1.0 ? -12.0 * s.kb / L * (r - 1.0) : choi_ko::buckling_energy(r * L, L, s.kb);
}

double ChoiKoTerm::interlaced_bending_energy(const Vec3s& x) const {
  double e = 0.0;
  for (const BucklingSpring& s : interlaced_) {
    if (!has_path(s)) continue;
    SpringGeometry g;
    geometry(s, x, false, g);
    e += bending_energy(s, g.l / g.lu);
  }
  return e;
}

double ChoiKoTerm::spring_energy(const BucklingSpring& s, const Vec3s& x) const {
  SpringGeometry g;
  geometry(s, x, false, g);
  double r, m, dm, ddm;
  ratios(s, g, r, m, dm, ddm);
  double e = interlaced_energy(s, m * s.rest_length);
  if (has_path(s)) e += bending_energy(s, r);
  return e;
}

// Gradient (and Hessian) of the spring's energy over its 4 corners. `project`: the Choi-Ko clamp, i.e. the
// membrane part's geometric term dropped and the bending part projected onto its positive eigenvalues.
void ChoiKoTerm::spring_derivatives(const BucklingSpring& s, const Vec3s& x, Vec12* grad, Mat12* hess,
                                    bool project) const {
  SpringGeometry g;
  geometry(s, x, hess != nullptr, g);
  double r, m, dm, ddm;
  ratios(s, g, r, m, dm, ddm);
  const double L = s.rest_length;
  const double Tm = interlaced_tension(s, m * L);
  Vec12 gm, gr = Vec12::Zero();
  if (has_path(s)) {
    gm = L * dm * g.glu;
    gr = L * (g.gl / g.lu - g.l / (g.lu * g.lu) * g.glu);
  } else {
    gm = g.gl;
  }
  const double Tb = has_path(s) ? bending_tension(s, r) : 0.0;
  if (grad) *grad = Tm * gm + Tb * gr;
  if (!hess) return;
  Mat12& H = *hess;
  H = interlaced_stiffness(s, m * L) * gm * gm.transpose();
  if (!project && Tm != 0.0) {
    if (has_path(s))
      H += Tm * L * (ddm * g.glu * g.glu.transpose() + dm * g.Hlu);
    else
      H += Tm * g.Hl;
  }
  if (!has_path(s)) return;
  const double lu = g.lu;
  const Mat12 Hr = L * (g.Hl / lu - (g.gl * g.glu.transpose() + g.glu * g.gl.transpose()) / (lu * lu) +
                        2.0 * g.l / (lu * lu * lu) * g.glu * g.glu.transpose() - g.l / (lu * lu) * g.Hlu);
  Mat12 Hb = bending_stiffness(s, r) * gr * gr.transpose() + Tb * Hr;
  if (project) {
    Eigen::SelfAdjointEigenSolver<Mat12> eig(0.5 * (Hb + Hb.transpose()));
    const Vec12 ev = eig.eigenvalues().cwiseMax(0.0);
    Hb = eig.eigenvectors() * ev.asDiagonal() * eig.eigenvectors().transpose();
  }
  H += Hb;
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
  const double seq = chunked_sum(static_cast<int>(sequential_.size()), c.threads, [&](int k) {
    const Spring& s = sequential_[k];
    const double l = (c.x[s.j] - c.x[s.i]).norm(), stretch = l - s.rest_length;
    if (stretch > 0.0) return 0.5 * s.k * stretch * stretch;
    return seq_buckle_.empty() ? 0.0 : interlaced_energy(seq_buckle_[k], l);
  });
  return seq + chunked_sum(static_cast<int>(interlaced_.size()), c.threads,
                           [&](int k) { return spring_energy(interlaced_[k], c.x); });
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
      Vec12 g;
      spring_derivatives(s, c.x, &g, nullptr, false);
      for (int q = 0; q < 4; ++q) int_force_[4 * k + q] = -g.segment<3>(3 * q);
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
    Mat12 H;
    spring_derivatives(s, c.x, nullptr, &H, o.clamp_compression);
    if (H.isZero(0.0)) continue;
    const auto v = corners(s);
    // dfdx = -H, scattered over the corners (a corner may repeat: grids have a = b).
    for (int p = 0; p < 4; ++p)
      for (int q = 0; q < 4; ++q) {
        if ((p >= 2 || q >= 2) && !has_path(s)) continue;
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
  for (size_t k = 0; k < all.size(); ++k) {
    const SpringDef& d = mesh.springs()[k];
    if (d.kind == SpringKind::kStructural || d.kind == SpringKind::kShear || d.kind == SpringKind::kEdge) {
      sequential.push_back(all[k]);
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
      s.kb = 8.0 / 9.0 * directional_bend(d / L) * du * dv / L;
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
        // The dihedral hinge's energy (B/2) |e|²/(A1 + A2) θ² (Bridson, Marino & Fedkiw 2003;
        // docs/references.md) matched to the spring's arc energy: a fold θ across the edge shortens the chord
        // by h_i h_j θ² / (2 l_u).
        const Vec3 e = x[h.e1] - x[h.e0];
        const double elen = e.norm(), hi = e.cross(x[d.i] - x[h.e0]).norm() / elen,
                     hj = e.cross(x[d.j] - x[h.e0]).norm() / elen,
                     L3 = d.rest_length * d.rest_length * d.rest_length;
        s.kb = directional_bend(d.rest_uv_dir) * elen * L3 / (6.0 * hi * hj * (hi + hj));
        s.a = h.e0;
        s.b = h.e1;
        s.path_rest =
            unfolded_chord((x[h.e0] - x[d.i]).norm(), (x[h.e1] - x[d.i]).norm(), (x[h.e0] - x[d.j]).norm(),
                           (x[h.e1] - x[d.j]).norm(), (x[h.e1] - x[h.e0]).norm());
        interlaced.push_back(s);
      }
  }
  return std::make_unique<ChoiKoTerm>(mesh.num_vertices(), std::move(sequential), std::move(interlaced), 4.0,
                                      1e-5);
}

}  // namespace loom::cloth
