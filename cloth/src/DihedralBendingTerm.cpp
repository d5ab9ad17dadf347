#include "loom/cloth/DihedralBendingTerm.h"

#include <cmath>
#include <map>
#include <unsupported/Eigen/AutoDiff>

#include "ElementJacobians.h"
#include "Numbers.h"

namespace loom::cloth {

namespace {

template <class S>
using V3 = Eigen::Matrix<S, 3, 1>;

// Bridson, Marino & Fedkiw 2003, eq. 2-5: g_i = ∂θ/∂x_i (= -u_i for θ with sin θ = (n1 × n2)·ê).
// Returns false for a degenerate stencil (zero-length edge or zero-area triangle): no force then.
template <class S>
bool theta_gradient(const V3<S>& x1, const V3<S>& x2, const V3<S>& x3, const V3<S>& x4, V3<S> g[4]) {
  using std::sqrt;
  const V3<S> E = x4 - x3;
  const V3<S> N1 = (x1 - x3).cross(x1 - x4), N2 = (x2 - x4).cross(x2 - x3);
  const S e2 = E.dot(E), n1 = N1.dot(N1), n2 = N2.dot(N2);
  if (!(e2 > S(0.0)) || !(n1 > S(1e-20) * e2 * e2) || !(n2 > S(1e-20) * e2 * e2)) return false;
  const S el = sqrt(e2);
  const V3<S> a = N1 / n1, b = N2 / n2;
  g[0] = -el * a;
  g[1] = -el * b;
  g[2] = -(((x1 - x4).dot(E) / el) * a + ((x2 - x4).dot(E) / el) * b);
  g[3] = ((x1 - x3).dot(E) / el) * a + ((x2 - x3).dot(E) / el) * b;
  return true;
}

// Exact Hessian of θ (12x12) by forward-mode differentiation of the analytic gradient.
bool theta_hessian(const Vec3 x[4], Eigen::Matrix<double, 12, 12>& H) {
  using AD = Eigen::AutoDiffScalar<Eigen::Matrix<double, 12, 1>>;
  V3<AD> xa[4];
  for (int i = 0; i < 4; ++i)
    for (int d = 0; d < 3; ++d) xa[i](d) = AD(x[i](d), 12, 3 * i + d);
  V3<AD> g[4];
  if (!theta_gradient<AD>(xa[0], xa[1], xa[2], xa[3], g)) return false;
  for (int i = 0; i < 4; ++i)
    for (int d = 0; d < 3; ++d) H.row(3 * i + d) = g[i](d).derivatives().transpose();
  return true;
}

double wrap(double a) {
  while (a > kPi) a -= 2 * kPi;
  while (a <= -kPi) a += 2 * kPi;
  return a;
}

}  // namespace

double dihedral_angle(const Vec3& x1, const Vec3& x2, const Vec3& x3, const Vec3& x4) {
  const Vec3 e = (x4 - x3).normalized();
  const Vec3 n1 = (x1 - x3).cross(x1 - x4).normalized(), n2 = (x2 - x4).cross(x2 - x3).normalized();
  return std::atan2(n1.cross(n2).dot(e), n1.dot(n2));
}

DihedralBendingTerm::DihedralBendingTerm(int num_vertices, std::vector<BendHinge> hinges, double damping)
    : n_(num_vertices), hinges_(std::move(hinges)), damping_(damping) {
  std::vector<std::array<int, 4>> hv(hinges_.size());
  for (size_t h = 0; h < hinges_.size(); ++h) hv[h] = hinges_[h].v;
  gather_ = ElementGather(n_, hv);
  corner_force_.resize(4 * hinges_.size());
}

double DihedralBendingTerm::energy(const EvalContext& c) const {
  return chunked_sum(static_cast<int>(hinges_.size()), c.threads, [&](int k) {
    const BendHinge& h = hinges_[k];
    const Vec3 &x1 = c.x[h.v[0]], &x2 = c.x[h.v[1]], &x3 = c.x[h.v[2]], &x4 = c.x[h.v[3]];
    const Vec3 E = x4 - x3;
    const double e2 = E.squaredNorm();
    const double n1 = (x1 - x3).cross(x1 - x4).squaredNorm(), n2 = (x2 - x4).cross(x2 - x3).squaredNorm();
    if (!(e2 > 0.0) || !(n1 > 1e-20 * e2 * e2) || !(n2 > 1e-20 * e2 * e2)) return 0.0;  // as theta_gradient
    const double d = wrap(dihedral_angle(x1, x2, x3, x4) - h.rest_angle);
    return h.k * d * d;
  });
}

void DihedralBendingTerm::add_forces(const EvalContext& c, Vec3s& f) const {
  const int nh = static_cast<int>(hinges_.size());
#pragma omp parallel num_threads(c.threads) if (c.threads > 1)
  {
#pragma omp for schedule(static)
    for (int k = 0; k < nh; ++k) {
      const BendHinge& h = hinges_[k];
      Vec3* out = &corner_force_[4 * k];
      Vec3 g[4];
      const Vec3 &x1 = c.x[h.v[0]], &x2 = c.x[h.v[1]], &x3 = c.x[h.v[2]], &x4 = c.x[h.v[3]];
      if (!theta_gradient<double>(x1, x2, x3, x4, g)) {
        for (int i = 0; i < 4; ++i) out[i].setZero();
        continue;
      }
      const double d = wrap(dihedral_angle(x1, x2, x3, x4) - h.rest_angle);
      double theta_dot = 0.0;
      for (int i = 0; i < 4; ++i) theta_dot += g[i].dot(c.v[h.v[i]]);
      // f = -∂E/∂x - k_d ∇θ θ̇, E = k_b (θ - θ̄)², k_d = damping * 2 k_b
      const double s = -2.0 * h.k * (d + damping_ * theta_dot);
      for (int i = 0; i < 4; ++i) out[i] = s * g[i];
    }
#pragma omp for schedule(static)
    for (int i = 0; i < n_; ++i) f[i] += gather_.sum(i, corner_force_);
  }
}

void DihedralBendingTerm::add_pattern(std::vector<std::pair<int, int>>& pairs) const {
  for (const BendHinge& h : hinges_)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) pairs.emplace_back(h.v[i], h.v[j]);
}

void DihedralBendingTerm::hinge_blocks(int k, const EvalContext& c, const JacobianOptions& o, Mat3* kx,
                                       Mat3* kv) const {
  const BendHinge& h = hinges_[k];
  for (int q = 0; q < 16; ++q) kx[q].setZero();
  if (kv)
    for (int q = 0; q < 16; ++q) kv[q].setZero();
  const Vec3 x[4] = {c.x[h.v[0]], c.x[h.v[1]], c.x[h.v[2]], c.x[h.v[3]]};
  Vec3 g[4];
  if (!theta_gradient<double>(x[0], x[1], x[2], x[3], g)) return;
  const double kd = damping_ * 2.0 * h.k;
  // Gauss-Newton part: K = -2 k_b ∇θ∇θᵀ, D = -k_d ∇θ∇θᵀ.
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      const Mat3 gg = g[i] * g[j].transpose();
      kx[4 * i + j] = -2.0 * h.k * gg;
      if (kv) kv[4 * i + j] = -kd * gg;
    }
  if (o.clamp_compression) return;
  // Exact: K -= 2 k_b (θ - θ̄) H, and with damping position terms -k_d (H θ̇ + ∇θ (H v)ᵀ).
  Eigen::Matrix<double, 12, 12> H;
  if (!theta_hessian(x, H)) return;
  const double d = wrap(dihedral_angle(x[0], x[1], x[2], x[3]) - h.rest_angle);
  Eigen::Matrix<double, 12, 1> v12, g12;
  for (int i = 0; i < 4; ++i) {
    v12.segment<3>(3 * i) = c.v[h.v[i]];
    g12.segment<3>(3 * i) = g[i];
  }
  Eigen::Matrix<double, 12, 12> extra = -2.0 * h.k * d * H;
  if (o.damping_position_terms && kd != 0.0) {
    const double theta_dot = g12.dot(v12);
    extra -= kd * (theta_dot * H + g12 * (H * v12).transpose());
  }
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) kx[4 * i + j] += extra.block<3, 3>(3 * i, 3 * j);
}

void DihedralBendingTerm::add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                                        BlockMatrix* dfdv) const {
  if (!dfdx && !dfdv) return;
  const bool want_v = dfdv && damping_ != 0.0;
  assemble_element_jacobians(
      hinges_, c.threads, want_v, scatter_, gather_x_, gather_v_, dx_blocks_, dv_blocks_, dfdx, dfdv,
      [&](int k, Mat3* kx, Mat3* kv) { hinge_blocks(k, c, o, kx, want_v ? kv : nullptr); });
}

std::unique_ptr<Term> make_dihedral_bending_term(const ClothMesh& mesh, const Material& m) {
  // The triangle of each edge's first side, for the material direction.
  std::map<std::pair<int, int>, int> edge_triangle;
  for (int t = 0; t < mesh.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = mesh.triangles()[t][k], b = mesh.triangles()[t][(k + 1) % 3];
      edge_triangle.emplace(std::make_pair(std::min(a, b), std::max(a, b)), t);
    }
  const Vec3s& X = mesh.rest_positions();
  std::vector<BendHinge> out;
  out.reserve(mesh.hinges().size());
  for (const Hinge& hg : mesh.hinges()) {
    BendHinge h;
    h.v = {hg.o0, hg.o1, hg.e0, hg.e1};
    const Vec3 e = X[hg.e1] - X[hg.e0];
    const double a1 = 0.5 * (X[hg.o0] - X[hg.e0]).cross(X[hg.o0] - X[hg.e1]).norm();
    const double a2 = 0.5 * (X[hg.o1] - X[hg.e0]).cross(X[hg.o1] - X[hg.e1]).norm();
    const TriangleFrame& fr =
        mesh.triangle_frames()[edge_triangle.at({std::min(hg.e0, hg.e1), std::max(hg.e0, hg.e1)})];
    Vec2 eu(e.dot(fr.weft), e.dot(fr.warp));
    eu.normalize();
    // Bending across the edge: direction (-e_v, e_u) in material space.
    const double B = m.bend_weft * eu.y() * eu.y() + m.bend_warp * eu.x() * eu.x();
    h.k = 0.5 * B * e.squaredNorm() / (a1 + a2);
    h.rest_angle = dihedral_angle(X[hg.o0], X[hg.o1], X[hg.e0], X[hg.e1]);
    out.push_back(h);
  }
  return std::make_unique<DihedralBendingTerm>(mesh.num_vertices(), std::move(out), m.damping);
}

}  // namespace loom::cloth
