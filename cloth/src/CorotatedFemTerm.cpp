#include "loom/cloth/CorotatedFemTerm.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <unsupported/Eigen/AutoDiff>

#include "ElementJacobians.h"

namespace loom::cloth {

namespace {

using std::sqrt;

template <class T>
using V3 = Eigen::Matrix<T, 3, 1>;

// The stretch S = sqrt(FᵀF) (2x2 symmetric, closed form) and the rotation's columns r0, r1 (R = F S⁻¹).
template <class T>
struct Polar {
  V3<T> wu, wv;     // F's columns
  T s00, s01, s11;  // S
  T det;            // det S (clamped away from 0 for collapsed triangles)
  bool ok = true;   // false: F is (numerically) zero
};

template <class T>
Polar<T> polar(const BwTriangle& t, const V3<T>* x) {
  Polar<T> p;
  p.wu = t.a[0] * x[0] + t.a[1] * x[1] + t.a[2] * x[2];
  p.wv = t.b[0] * x[0] + t.b[1] * x[1] + t.b[2] * x[2];
  const T c00 = p.wu.dot(p.wu), c01 = p.wu.dot(p.wv), c11 = p.wv.dot(p.wv);
  T detc = c00 * c11 - c01 * c01;
  if (detc < T(0.0)) detc = T(0.0);  // round-off of a collapsed triangle
  const T tr = c00 + c11;
  if (!(tr > T(1e-300))) {
    p.ok = false;
    return p;
  }
  // sqrt(C) = (C + s I) / t, s = sqrt(det C), t = sqrt(tr C + 2 s) (Cayley-Hamilton for 2x2).
  const T s = detc > T(0.0) ? T(sqrt(detc)) : T(0.0);
  const T tt = sqrt(tr + 2.0 * s);
  p.s00 = (c00 + s) / tt;
  p.s01 = c01 / tt;
  p.s11 = (c11 + s) / tt;
  p.det = p.s00 * p.s11 - p.s01 * p.s01;
  const T floor = 1e-12 * (p.s00 + p.s11) * (p.s00 + p.s11);
  if (p.det < floor) p.det = floor;
  return p;
}

// Energy and its gradient ∂E/∂x_m of one triangle (header: E = A (1/2 Y_u ε_uu² + 1/2 Y_v ε_vv² + 2 G
// ε_uv²)).
template <class T>
T fem_gradient(const BwTriangle& t, const V3<T>* x, double y_u, double y_v, double g, V3<T>* grad) {
  const Polar<T> p = polar(t, x);
  if (!p.ok) {
    for (int m = 0; m < 3; ++m) grad[m].setZero();
    return T(0.0);
  }
  const double A = t.alpha * t.alpha;
  const T e00 = p.s00 - 1.0, e11 = p.s11 - 1.0, e01 = p.s01;
  // σ = ∂E/∂S for symmetric variations (σ : dS = σ00 dS00 + σ11 dS11 + 2 σ01 dS01).
  const T q00 = A * y_u * e00, q11 = A * y_v * e11, q01 = 2.0 * A * g * e01;
  // Γ from S Γ + Γ S = σ (dE = σ : dS = Γ : dC since S dS + dS S = dC):
  //   2 S00 Γ00 + 2 S01 Γ01 = σ00,  2 S01 Γ01 + 2 S11 Γ11 = σ11,  S01 (Γ00 + Γ11) + (S00 + S11) Γ01 = σ01.
  const T g01 = (q01 * p.s00 * p.s11 - 0.5 * p.s01 * (q00 * p.s11 + q11 * p.s00)) / ((p.s00 + p.s11) * p.det);
  const T g00 = (q00 - 2.0 * p.s01 * g01) / (2.0 * p.s00);
  const T g11 = (q11 - 2.0 * p.s01 * g01) / (2.0 * p.s11);
  // ∂E/∂F = 2 F Γ; ∂E/∂x_m = ∂E/∂F (a_m, b_m)ᵀ.
  const V3<T> col_u = 2.0 * (g00 * p.wu + g01 * p.wv), col_v = 2.0 * (g01 * p.wu + g11 * p.wv);
  for (int m = 0; m < 3; ++m) grad[m] = t.a[m] * col_u + t.b[m] * col_v;
  return A * (0.5 * y_u * e00 * e00 + 0.5 * y_v * e11 * e11 + 2.0 * g * e01 * e01);
}

// The rotation's columns R = F S⁻¹.
template <class T>
void rotation(const Polar<T>& p, V3<T>& r0, V3<T>& r1) {
  r0 = (p.s11 * p.wu - p.s01 * p.wv) / p.det;
  r1 = (p.s00 * p.wv - p.s01 * p.wu) / p.det;
}

// -R K₀ Rᵀ u for the three corners (K₀: linear orthotropic stiffness of the rest triangle, header), scaled by
// `scale`: the damping force (u = v, scale = damping) of one triangle.
template <class T>
void rotated_linear_force(const BwTriangle& t, const V3<T>& r0, const V3<T>& r1, const V3<T>* u, double y_u,
                          double y_v, double g, double scale, V3<T>* out) {
  const double A = t.alpha * t.alpha;
  // Linear strain (rates) of the in-plane components p_n = Rᵀ u_n.
  T e00 = T(0.0), e11 = T(0.0), gam = T(0.0);
  for (int n = 0; n < 3; ++n) {
    const T px = r0.dot(u[n]), py = r1.dot(u[n]);
    e00 += t.a[n] * px;
    e11 += t.b[n] * py;
    gam += t.b[n] * px + t.a[n] * py;
  }
  const T s00 = A * y_u * e00, s11 = A * y_v * e11, s01 = A * g * gam;
  for (int m = 0; m < 3; ++m)
    out[m] = -scale * ((t.a[m] * s00 + t.b[m] * s01) * r0 + (t.b[m] * s11 + t.a[m] * s01) * r1);
}

}  // namespace

CorotatedFemTerm::CorotatedFemTerm(int num_vertices, std::vector<BwTriangle> triangles, double y_u,
                                   double y_v, double shear, double damping)
    : n_(num_vertices), tris_(std::move(triangles)), y_u_(y_u), y_v_(y_v), g_(shear), damping_(damping) {
  std::vector<Tri> tv(tris_.size());
  for (size_t t = 0; t < tris_.size(); ++t) tv[t] = tris_[t].v;
  gather_ = ElementGather(n_, tv);
  corner_force_.resize(3 * tris_.size());
}

double CorotatedFemTerm::energy(const EvalContext& c) const {
  return chunked_sum(static_cast<int>(tris_.size()), c.threads, [&](int k) {
    const BwTriangle& t = tris_[k];
    const Vec3 x[3] = {c.x[t.v[0]], c.x[t.v[1]], c.x[t.v[2]]};
    Vec3 grad[3];
    return fem_gradient(t, x, y_u_, y_v_, g_, grad);
  });
}

void CorotatedFemTerm::triangle_forces(int k, const EvalContext& c, Vec3* out) const {
  const BwTriangle& t = tris_[k];
  const Vec3 x[3] = {c.x[t.v[0]], c.x[t.v[1]], c.x[t.v[2]]};
  Vec3 grad[3];
  fem_gradient(t, x, y_u_, y_v_, g_, grad);
  for (int m = 0; m < 3; ++m) out[m] = -grad[m];
  if (damping_ != 0.0) {
    const Polar<double> p = polar(t, x);
    if (!p.ok) return;
    Vec3 r0, r1, fd[3];
    rotation(p, r0, r1);
    const Vec3 v[3] = {c.v[t.v[0]], c.v[t.v[1]], c.v[t.v[2]]};
    rotated_linear_force(t, r0, r1, v, y_u_, y_v_, g_, damping_, fd);
    for (int m = 0; m < 3; ++m) out[m] += fd[m];
  }
}

void CorotatedFemTerm::add_forces(const EvalContext& c, Vec3s& f) const {
  const int nt = static_cast<int>(tris_.size());
#pragma omp parallel num_threads(c.threads) if (c.threads > 1)
  {
#pragma omp for schedule(static)
    for (int k = 0; k < nt; ++k) triangle_forces(k, c, &corner_force_[3 * k]);
#pragma omp for schedule(static)
    for (int i = 0; i < n_; ++i) f[i] += gather_.sum(i, corner_force_);
  }
}

void CorotatedFemTerm::add_pattern(std::vector<std::pair<int, int>>& pairs) const {
  for (const BwTriangle& t : tris_) {
    pairs.emplace_back(t.v[0], t.v[1]);
    pairs.emplace_back(t.v[1], t.v[2]);
    pairs.emplace_back(t.v[0], t.v[2]);
  }
}

void CorotatedFemTerm::triangle_blocks(int k, const EvalContext& c, const JacobianOptions& o, Mat3* kx,
                                       Mat3* kv) const {
  const BwTriangle& t = tris_[k];
  for (int q = 0; q < 9; ++q) {
    kx[q].setZero();
    kv[q].setZero();
  }
  const Vec3 x[3] = {c.x[t.v[0]], c.x[t.v[1]], c.x[t.v[2]]};
  const Polar<double> p = polar(t, x);
  if (!p.ok) return;
  Vec3 r0, r1;
  rotation(p, r0, r1);
  // -R K₀ Rᵀ, column by column: the response to a unit displacement of corner n along axis d.
  Mat3 lin[9];
  for (int n = 0; n < 3; ++n)
    for (int d = 0; d < 3; ++d) {
      Vec3 u[3] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()}, out[3];
      u[n][d] = 1.0;
      rotated_linear_force(t, r0, r1, u, y_u_, y_v_, g_, 1.0, out);
      for (int m = 0; m < 3; ++m) lin[3 * m + n].col(d) = out[m];
    }
  for (int q = 0; q < 9; ++q) kv[q] = damping_ * lin[q];
  if (o.clamp_compression && corotational_only_) {
    // The standard co-rotational stiffness (header): symmetric, negative semi-definite.
    for (int q = 0; q < 9; ++q) kx[q] = lin[q];
    return;
  }
  // Exact: forward-mode AutoDiff of the analytic force (elastic, plus damping if asked).
  using AD = Eigen::AutoDiffScalar<Eigen::Matrix<double, 9, 1>>;
  V3<AD> xa[3], grad[3];
  for (int m = 0; m < 3; ++m)
    for (int d = 0; d < 3; ++d) {
      xa[m][d] = AD(x[m][d], 9, 3 * m + d);
    }
  fem_gradient(t, xa, y_u_, y_v_, g_, grad);
  V3<AD> fd[3];
  const bool with_damping = o.damping_position_terms && !o.clamp_compression && damping_ != 0.0;
  if (with_damping) {
    const Polar<AD> pa = polar(t, xa);
    V3<AD> a0, a1, va[3];
    rotation(pa, a0, a1);
    for (int m = 0; m < 3; ++m) va[m] = c.v[t.v[m]].cast<AD>();
    rotated_linear_force(t, a0, a1, va, y_u_, y_v_, g_, damping_, fd);
  }
  for (int m = 0; m < 3; ++m)
    for (int d = 0; d < 3; ++d) {
      Eigen::Matrix<double, 9, 1> row = -grad[m][d].derivatives();
      if (with_damping) row += fd[m][d].derivatives();
      for (int n = 0; n < 3; ++n) kx[3 * m + n].row(d) = row.segment<3>(3 * n).transpose();
    }
  if (!o.clamp_compression) return;
  // Solvers: the exact Hessian projected onto the negative semi-definite matrices (eigenvalues of the
  // triangle's 9x9 df/dx clamped to <= 0; Teran et al. 2005 "Robust quasistatic finite elements").
  Eigen::Matrix<double, 9, 9> H;
  for (int m = 0; m < 3; ++m)
    for (int n = 0; n < 3; ++n) H.block<3, 3>(3 * m, 3 * n) = kx[3 * m + n];
  H = (0.5 * (H + H.transpose())).eval();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(H);
  const Eigen::Matrix<double, 9, 1> lambda = eig.eigenvalues().cwiseMin(0.0);
  H = eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
  for (int m = 0; m < 3; ++m)
    for (int n = 0; n < 3; ++n) kx[3 * m + n] = H.block<3, 3>(3 * m, 3 * n);
}

void CorotatedFemTerm::add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                                     BlockMatrix* dfdv) const {
  if (!dfdx && !dfdv) return;
  assemble_element_jacobians(tris_, c.threads, dfdv && damping_ != 0.0, scatter_, gather_x_, gather_v_,
                             dx_blocks_, dv_blocks_, dfdx, dfdv,
                             [&](int k, Mat3* kx, Mat3* kv) { triangle_blocks(k, c, o, kx, kv); });
}

std::unique_ptr<Term> make_corotated_fem_term(const ClothMesh& mesh, const Material& m) {
  return std::make_unique<CorotatedFemTerm>(mesh.num_vertices(), make_bw_triangles(mesh), m.stretch_weft,
                                            m.stretch_warp, m.shear, m.damping);
}

}  // namespace loom::cloth
