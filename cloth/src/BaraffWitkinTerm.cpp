#include "loom/cloth/BaraffWitkinTerm.h"

#include <cmath>

#include "ElementJacobians.h"

namespace loom::cloth {

std::vector<BwTriangle> make_bw_triangles(const ClothMesh& mesh) {
  std::vector<BwTriangle> out(mesh.num_triangles());
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    BwTriangle& bt = out[t];
    bt.v = mesh.triangles()[t];
    const auto& uv = mesh.triangle_frames()[t].rest_uv;
    // Baraff & Witkin 1998 §4.2 / Pritchard §3: w_u = (Δv2 Δx1 - Δv1 Δx2)/d, w_v = (Δu1 Δx2 - Δu2 Δx1)/d.
    const double du1 = uv[1].x() - uv[0].x(), dv1 = uv[1].y() - uv[0].y();
    const double du2 = uv[2].x() - uv[0].x(), dv2 = uv[2].y() - uv[0].y();
    const double d = du1 * dv2 - du2 * dv1;
    bt.a = {(dv1 - dv2) / d, dv2 / d, -dv1 / d};
    bt.b = {(du2 - du1) / d, -du2 / d, du1 / d};
    bt.alpha = std::sqrt(0.5 * std::abs(d));
  }
  return out;
}

BaraffWitkinTerm::BaraffWitkinTerm(Kind kind, int num_vertices, std::vector<BwTriangle> triangles, double k_u,
                                   double k_v, double k_shear, double damping)
    : kind_(kind),
      n_(num_vertices),
      tris_(std::move(triangles)),
      k_u_(k_u),
      k_v_(k_v),
      k_s_(k_shear),
      damping_(damping) {
  std::vector<Tri> tv(tris_.size());
  for (size_t t = 0; t < tris_.size(); ++t) tv[t] = tris_[t].v;
  gather_ = ElementGather(n_, tv);
  corner_force_.resize(3 * tris_.size());
}

namespace {

// w_u, w_v and their rates for one triangle.
struct Deformation {
  Vec3 wu, wv, wu_dot, wv_dot;
};

Deformation deformation(const BwTriangle& t, const Vec3s& x, const Vec3s& v) {
  Deformation d{Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  for (int m = 0; m < 3; ++m) {
    d.wu += t.a[m] * x[t.v[m]];
    d.wv += t.b[m] * x[t.v[m]];
    d.wu_dot += t.a[m] * v[t.v[m]];
    d.wv_dot += t.b[m] * v[t.v[m]];
  }
  return d;
}

}  // namespace

double BaraffWitkinTerm::energy(const EvalContext& c) const {
  return chunked_sum(static_cast<int>(tris_.size()), c.threads, [&](int k) {
    const BwTriangle& t = tris_[k];
    const Deformation d = deformation(t, c.x, c.v);
    if (kind_ == Kind::kStretch) {
      const double cu = t.alpha * (d.wu.norm() - 1.0), cv = t.alpha * (d.wv.norm() - 1.0);
      return 0.5 * (k_u_ * cu * cu + k_v_ * cv * cv);
    }
    const double cs = t.alpha * d.wu.dot(d.wv);
    return 0.5 * k_s_ * cs * cs;
  });
}

void BaraffWitkinTerm::add_forces(const EvalContext& c, Vec3s& f) const {
  const int nt = static_cast<int>(tris_.size());
#pragma omp parallel num_threads(c.threads) if (c.threads > 1)
  {
#pragma omp for schedule(static)
    for (int k = 0; k < nt; ++k) {
      const BwTriangle& t = tris_[k];
      const Deformation d = deformation(t, c.x, c.v);
      Vec3* out = &corner_force_[3 * k];
      for (int m = 0; m < 3; ++m) out[m].setZero();
      if (kind_ == Kind::kStretch) {
        // f_m = -(k C + k_d Ċ) ∂C/∂x_m, ∂C_u/∂x_m = α a_m ŵ_u (Baraff & Witkin 1998 §4)
        auto stretch = [&](const Vec3& w, const Vec3& w_dot, const std::array<double, 3>& coef, double k) {
          const double l = w.norm();
          if (!(l > 0.0)) return;
          const Vec3 n = w / l;
          const double C = t.alpha * (l - 1.0), C_dot = t.alpha * n.dot(w_dot);
          const double s = -(k * C + damping_ * k * C_dot) * t.alpha;
          for (int m = 0; m < 3; ++m) out[m] += (s * coef[m]) * n;
        };
        stretch(d.wu, d.wu_dot, t.a, k_u_);
        stretch(d.wv, d.wv_dot, t.b, k_v_);
      } else {
        // ∂C/∂x_m = α (a_m w_v + b_m w_u)
        const double C = t.alpha * d.wu.dot(d.wv);
        const double C_dot = t.alpha * (d.wu_dot.dot(d.wv) + d.wu.dot(d.wv_dot));
        const double s = -(k_s_ * C + damping_ * k_s_ * C_dot) * t.alpha;
        for (int m = 0; m < 3; ++m) out[m] = s * (t.a[m] * d.wv + t.b[m] * d.wu);
      }
    }
#pragma omp for schedule(static)
    for (int i = 0; i < n_; ++i) f[i] += gather_.sum(i, corner_force_);
  }
}

void BaraffWitkinTerm::add_pattern(std::vector<std::pair<int, int>>& pairs) const {
  for (const BwTriangle& t : tris_) {
    pairs.emplace_back(t.v[0], t.v[1]);
    pairs.emplace_back(t.v[1], t.v[2]);
    pairs.emplace_back(t.v[0], t.v[2]);
  }
}

void BaraffWitkinTerm::triangle_blocks(int k, const EvalContext& c, const JacobianOptions& o, Mat3* kx,
                                       Mat3* kv) const {
  const Mat3 I = Mat3::Identity();
  const BwTriangle& t = tris_[k];
  const Deformation d = deformation(t, c.x, c.v);
  for (int q = 0; q < 9; ++q) {
    kx[q].setZero();
    kv[q].setZero();
  }
  const double a2 = t.alpha * t.alpha;
  if (kind_ == Kind::kStretch) {
    auto stretch = [&](const Vec3& w, const Vec3& w_dot, const std::array<double, 3>& coef, double k) {
      const double l = w.norm();
      if (!(l > 0.0)) return;
      const Vec3 n = w / l;
      const Mat3 nn = n * n.transpose(), P = I - nn;
      // K_mn = -k α² c_m c_n [n̂n̂ᵀ + (1 - 1/|w|)(I - n̂n̂ᵀ)]  (∂²C_u/∂x_m∂x_n = α a_m a_n P / |w|)
      double ratio = 1.0 - 1.0 / l;
      if (o.clamp_compression) ratio = std::max(ratio, 0.0);
      Mat3 Ke = k * (nn + ratio * P);
      const double kd = damping_ * k;
      if (o.damping_position_terms && kd != 0.0)  // d/dx of -k_d α² a_m (n̂·ẇ) n̂
        Ke += kd * (n.dot(w_dot) * P + n * w_dot.transpose() * P) / l;
      const Mat3 De = kd * nn;
      for (int m = 0; m < 3; ++m)
        for (int nn_ = 0; nn_ < 3; ++nn_) {
          const double s = -a2 * coef[m] * coef[nn_];
          kx[3 * m + nn_] += s * Ke;
          kv[3 * m + nn_] += s * De;
        }
    };
    stretch(d.wu, d.wu_dot, t.a, k_u_);
    stretch(d.wv, d.wv_dot, t.b, k_v_);
  } else {
    const double C = t.alpha * d.wu.dot(d.wv);
    const double C_dot = t.alpha * (d.wu_dot.dot(d.wv) + d.wu.dot(d.wv_dot));
    const double kd = damping_ * k_s_;
    std::array<Vec3, 3> g;
    for (int m = 0; m < 3; ++m) g[m] = t.alpha * (t.a[m] * d.wv + t.b[m] * d.wu);
    for (int m = 0; m < 3; ++m)
      for (int n = 0; n < 3; ++n) {
        const double hess = t.alpha * (t.a[m] * t.b[n] + t.a[n] * t.b[m]);  // ∂²C/∂x_m∂x_n = hess I
        // K_mn = -k (g_m g_nᵀ + C ∂²C)
        Mat3 Ke = k_s_ * g[m] * g[n].transpose();
        if (!o.clamp_compression) Ke += (k_s_ * C * hess) * I;
        if (o.damping_position_terms && kd != 0.0)
          Ke +=
              kd * (hess * C_dot * I + t.alpha * g[m] * (t.a[n] * d.wv_dot + t.b[n] * d.wu_dot).transpose());
        kx[3 * m + n] = -Ke;
        kv[3 * m + n] = -kd * g[m] * g[n].transpose();
      }
  }
}

void BaraffWitkinTerm::add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                                     BlockMatrix* dfdv) const {
  if (!dfdx && !dfdv) return;
  assemble_element_jacobians(tris_, c.threads, dfdv && damping_ != 0.0, scatter_, gather_x_, gather_v_,
                             dx_blocks_, dv_blocks_, dfdx, dfdv,
                             [&](int k, Mat3* kx, Mat3* kv) { triangle_blocks(k, c, o, kx, kv); });
}

std::unique_ptr<Term> make_bw_stretch_term(const ClothMesh& mesh, const Material& m) {
  return std::make_unique<BaraffWitkinTerm>(BaraffWitkinTerm::Kind::kStretch, mesh.num_vertices(),
                                            make_bw_triangles(mesh), m.stretch_weft, m.stretch_warp, m.shear,
                                            m.damping);
}

std::unique_ptr<Term> make_bw_shear_term(const ClothMesh& mesh, const Material& m) {
  return std::make_unique<BaraffWitkinTerm>(BaraffWitkinTerm::Kind::kShear, mesh.num_vertices(),
                                            make_bw_triangles(mesh), m.stretch_weft, m.stretch_warp, m.shear,
                                            m.damping);
}

}  // namespace loom::cloth
