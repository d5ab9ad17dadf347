#include "loom/cloth/FastXpbdSolver.h"

#include <omp.h>
#ifdef __SSE2__
#include <xmmintrin.h>
#endif

#include <algorithm>
#include <cmath>

#include "loom/cloth/SpringSolverSupport.h"

namespace loom::cloth {

namespace {
// Loops shorter than this run on one thread: a parallel region costs more than the work it would split.
// Results do not depend on it (colours share no vertex; per-vertex loops are independent).
constexpr int kMinParallelSprings = 2048;
// m², springs shorter than 1 µm have no direction and are skipped.
constexpr float kMinLength2 = 1e-12f;

// Thread `me` of `team`'s static share of [begin, end).
// Shares start at multiples of 4 from `begin`, so a spring's SSE lane does not depend on the thread count.
void share(int begin, int end, int me, int team, int* b, int* e) {
  const long len = end - begin;
  *b = begin + static_cast<int>(len * me / team / 4 * 4);
  *e = me + 1 == team ? end : begin + static_cast<int>(len * (me + 1) / team / 4 * 4);
}
}  // namespace

void FastXpbdSolver::check(const Cloth& cloth) const { check_spring_terms(cloth, name()); }

void FastXpbdSolver::set_frame(const Eigen::Isometry3d& frame) {
  origin_ = frame.translation();
  axes_ = frame.linear();
  framed_ = true;
}

std::vector<std::pair<std::string, double>> FastXpbdSolver::counters() const {
  return {{"springs", static_cast<double>(si_.size())}, {"sweeps", static_cast<double>(sweeps_)}};
}

void FastXpbdSolver::prepare(const Cloth& cloth) {
  std::vector<Spring> springs = collect_springs(cloth);
  springs.erase(std::remove_if(springs.begin(), springs.end(), [](const Spring& s) { return !(s.k > 0.0); }),
                springs.end());
  const std::vector<std::vector<int>> colors = color_springs(cloth.state().size(), springs);
  si_.clear(), sj_.clear(), rest_.clear(), alpha_.clear(), beta_.clear();
  color_start_.assign(1, 0);
  for (std::vector<int> color : colors) {
    std::sort(color.begin(), color.end(), [&](int a, int b) {
      return std::min(springs[a].i, springs[a].j) < std::min(springs[b].i, springs[b].j);
    });
    for (int k : color) {
      const Spring& s = springs[k];
      si_.push_back(s.i);
      sj_.push_back(s.j);
      rest_.push_back(static_cast<float>(s.rest_length));
      alpha_.push_back(static_cast<float>(compliance_scale_ / s.k));
      beta_.push_back(static_cast<float>(s.c / s.k));
    }
    color_start_.push_back(static_cast<int>(si_.size()));
  }
  const size_t ns = si_.size();
  gamma_.assign(ns, 0.0f);
  alpha_t_.assign(ns, 0.0f);
  inv_denom_.assign(ns, 0.0f);
  lambda_.assign(iterations_ > 1 ? ns : 0, 0.0);
  damped_ = std::any_of(beta_.begin(), beta_.end(), [](float b) { return b > 0.0f; });
  inv_mass_.clear();
  h_ = 0.0;
  prepared_for_ = &cloth;
}

void FastXpbdSolver::update_denominators(const ClothState& s, double h) {
  if (h == h_ && inv_mass_ == s.inv_mass) return;
  const int ns = static_cast<int>(si_.size());
  const double inv_h2 = 1.0 / (h * h);
  for (int k = 0; k < ns; ++k) {
    const double w = s.inv_mass[si_[k]] + s.inv_mass[sj_[k]];
    const double gamma = beta_[k] / h, alpha_t = alpha_[k] * inv_h2;
    gamma_[k] = static_cast<float>(gamma);
    alpha_t_[k] = static_cast<float>(alpha_t);
    inv_denom_[k] = w > 0.0 ? static_cast<float>(1.0 / ((1.0 + gamma) * w + alpha_t)) : 0.0f;
  }
  h_ = h;
  inv_mass_ = s.inv_mass;
}

// Macklin 2016 eq. (18) for C = l - L, ∇_j C = -∇_i C = n = d / l, with damping γ ∇C·(p - x_n):
//   Δλ = (-C - α̃ λ - γ n·((p_j - x_j) - (p_i - x_i))) / ((1 + γ)(w_i + w_j) + α̃),  p_i -= w_i Δλ n, p_j +=
//   w_j Δλ n.
// With one iteration λ = 0 at the start, so the α̃ λ term vanishes. The scalar and the SSE forms run the same
// float operations in the same order, so a spring's result does not depend on which form projects it.
void FastXpbdSolver::project_scalar(int begin, int end) {
  Point* p = p_.data();
  const Point* x0 = x0_.data();
  for (int k = begin; k < end; ++k) {
    Point& a = p[si_[k]];
    Point& b = p[sj_[k]];
    const Point& a0 = x0[si_[k]];
    const Point& b0 = x0[sj_[k]];
    const float dx = b.x - a.x, dy = b.y - a.y, dz = b.z - a.z;
    const float l2 = dx * dx + dy * dy + dz * dz;
    if (!(l2 > kMinLength2)) continue;
    const float l = std::sqrt(l2);
    const float inv_l = 1.0f / l;
    const float c = l - rest_[k];
    const float rate = ((b.x - b0.x) - (a.x - a0.x)) * dx + ((b.y - b0.y) - (a.y - a0.y)) * dy +
                       ((b.z - b0.z) - (a.z - a0.z)) * dz;
    const float num = (0.0f - c) - gamma_[k] * (rate * inv_l);
    const float s = (num * inv_denom_[k]) * inv_l;
    const float sa = a.w * s, sb = b.w * s;
    a.x -= sa * dx, a.y -= sa * dy, a.z -= sa * dz;
    b.x += sb * dx, b.y += sb * dy, b.z += sb * dz;
  }
}

void FastXpbdSolver::project_lambda(int begin, int end) {
  Point* p = p_.data();
  const Point* x0 = x0_.data();
  for (int k = begin; k < end; ++k) {
    Point& a = p[si_[k]];
    Point& b = p[sj_[k]];
    const Point& a0 = x0[si_[k]];
    const Point& b0 = x0[sj_[k]];
    const double dx = b.x - a.x, dy = b.y - a.y, dz = b.z - a.z;
    const double l2 = dx * dx + dy * dy + dz * dz;
    if (!(l2 > kMinLength2)) continue;
    const double l = std::sqrt(l2);
    const double c = l - rest_[k];
    const double rate = ((b.x - b0.x) - (a.x - a0.x)) * dx + ((b.y - b0.y) - (a.y - a0.y)) * dy +
                        ((b.z - b0.z) - (a.z - a0.z)) * dz;
    const double dl = (-c - alpha_t_[k] * lambda_[k] - gamma_[k] * rate / l) / ((1.0 / inv_denom_[k]));
    lambda_[k] += inv_denom_[k] > 0.0f ? dl : 0.0;
    const double s = inv_denom_[k] > 0.0f ? dl / l : 0.0;
    a.x -= static_cast<float>(a.w * s * dx), a.y -= static_cast<float>(a.w * s * dy);
    a.z -= static_cast<float>(a.w * s * dz);
    b.x += static_cast<float>(b.w * s * dx), b.y += static_cast<float>(b.w * s * dy);
    b.z += static_cast<float>(b.w * s * dz);
  }
}

template <bool kDamped>
void FastXpbdSolver::project(int begin, int end) {
  int k = begin;
#ifdef __SSE2__
  Point* p = p_.data();
  const Point* x0 = x0_.data();
  const __m128 min_l2 = _mm_set1_ps(kMinLength2), one = _mm_set1_ps(1.0f), zero = _mm_setzero_ps();
  for (; k + 4 <= end; k += 4) {
    const int* i = &si_[k];
    const int* j = &sj_[k];
    __m128 ax = _mm_load_ps(&p[i[0]].x), ay = _mm_load_ps(&p[i[1]].x), az = _mm_load_ps(&p[i[2]].x),
           aw = _mm_load_ps(&p[i[3]].x);
    _MM_TRANSPOSE4_PS(ax, ay, az, aw);
    __m128 bx = _mm_load_ps(&p[j[0]].x), by = _mm_load_ps(&p[j[1]].x), bz = _mm_load_ps(&p[j[2]].x),
           bw = _mm_load_ps(&p[j[3]].x);
    _MM_TRANSPOSE4_PS(bx, by, bz, bw);
    const __m128 dx = _mm_sub_ps(bx, ax), dy = _mm_sub_ps(by, ay), dz = _mm_sub_ps(bz, az);
    const __m128 l2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
    const __m128 ok = _mm_cmpgt_ps(l2, min_l2);
    const __m128 l = _mm_sqrt_ps(l2);
    const __m128 inv_l = _mm_div_ps(one, _mm_or_ps(_mm_and_ps(ok, l), _mm_andnot_ps(ok, one)));
    const __m128 c = _mm_sub_ps(l, _mm_loadu_ps(&rest_[k]));
    __m128 num = _mm_sub_ps(zero, c);
    if (kDamped) {  // the damping term needs the step-start positions
      __m128 a0x = _mm_load_ps(&x0[i[0]].x), a0y = _mm_load_ps(&x0[i[1]].x), a0z = _mm_load_ps(&x0[i[2]].x),
             a0w = _mm_load_ps(&x0[i[3]].x);
      _MM_TRANSPOSE4_PS(a0x, a0y, a0z, a0w);
      __m128 b0x = _mm_load_ps(&x0[j[0]].x), b0y = _mm_load_ps(&x0[j[1]].x), b0z = _mm_load_ps(&x0[j[2]].x),
             b0w = _mm_load_ps(&x0[j[3]].x);
      _MM_TRANSPOSE4_PS(b0x, b0y, b0z, b0w);
      const __m128 rate =
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_sub_ps(_mm_sub_ps(bx, b0x), _mm_sub_ps(ax, a0x)), dx),
                                _mm_mul_ps(_mm_sub_ps(_mm_sub_ps(by, b0y), _mm_sub_ps(ay, a0y)), dy)),
                     _mm_mul_ps(_mm_sub_ps(_mm_sub_ps(bz, b0z), _mm_sub_ps(az, a0z)), dz));
      num = _mm_sub_ps(num, _mm_mul_ps(_mm_loadu_ps(&gamma_[k]), _mm_mul_ps(rate, inv_l)));
    }
    const __m128 s = _mm_and_ps(ok, _mm_mul_ps(_mm_mul_ps(num, _mm_loadu_ps(&inv_denom_[k])), inv_l));
    const __m128 sa = _mm_mul_ps(aw, s), sb = _mm_mul_ps(bw, s);
    ax = _mm_sub_ps(ax, _mm_mul_ps(sa, dx)), ay = _mm_sub_ps(ay, _mm_mul_ps(sa, dy));
    az = _mm_sub_ps(az, _mm_mul_ps(sa, dz));
    bx = _mm_add_ps(bx, _mm_mul_ps(sb, dx)), by = _mm_add_ps(by, _mm_mul_ps(sb, dy));
    bz = _mm_add_ps(bz, _mm_mul_ps(sb, dz));
    _MM_TRANSPOSE4_PS(ax, ay, az, aw);
    _mm_store_ps(&p[i[0]].x, ax), _mm_store_ps(&p[i[1]].x, ay), _mm_store_ps(&p[i[2]].x, az);
    _mm_store_ps(&p[i[3]].x, aw);
    _MM_TRANSPOSE4_PS(bx, by, bz, bw);
    _mm_store_ps(&p[j[0]].x, bx), _mm_store_ps(&p[j[1]].x, by), _mm_store_ps(&p[j[2]].x, bz);
    _mm_store_ps(&p[j[3]].x, bw);
  }
#endif
  project_scalar(k, end);
}

void FastXpbdSolver::step(Cloth& cloth, double t, double h, int threads) {
  if (prepared_for_ != &cloth) prepare(cloth);
  ClothState& s = cloth.state();
  const int n = s.size();
  const int ns = static_cast<int>(si_.size());
  const int num_colors = static_cast<int>(color_start_.size()) - 1;
  update_denominators(s, h);
  external_forces(cloth, s.x, s.v, t, threads, f_);
  p_.resize(n);
  x0_.resize(n);
  pred_.resize(n);
  if (!framed_) origin_ = n > 0 ? s.x[0] : Vec3::Zero();
  // World axes need no rotation (and keep every rounding of the unframed step); a frame's axes do.
  const bool turn = framed_ && axes_ != Mat3::Identity();
  const Mat3 to_local = axes_.transpose();
  s.x_prev.resize(n);
  const bool with_lambda = iterations_ > 1;
#pragma omp parallel num_threads(threads) if (threads > 1 && ns >= kMinParallelSprings)
  {
    const int team = omp_get_num_threads(), me = omp_get_thread_num();
    int b = 0, e = 0;
    if (with_lambda) {
      share(0, ns, me, team, &b, &e);
      std::fill(lambda_.begin() + b, lambda_.begin() + e, 0.0);
    }
    // Prediction (Macklin 2016, Alg. 1 line 3): kinematic vertices have w = 0, so p = x + h v exactly.
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      const double w = s.inv_mass[i];
      pred_[i] = s.x[i] + h * (s.v[i] + (h * w) * f_[i]);
      Vec3 q = pred_[i] - origin_, q0 = s.x[i] - origin_;
      if (turn) q = to_local * q, q0 = to_local * q0;
      p_[i] = Point{static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()),
                    static_cast<float>(w)};
      x0_[i] =
          Point{static_cast<float>(q0.x()), static_cast<float>(q0.y()), static_cast<float>(q0.z()), 0.0f};
    }
    for (int it = 0; it < iterations_; ++it)
      for (int c = 0; c < num_colors; ++c) {
        share(color_start_[c], color_start_[c + 1], me, team, &b, &e);
        if (with_lambda)
          project_lambda(b, e);
        else if (damped_)
          project<true>(b, e);
        else
          project<false>(b, e);
#pragma omp barrier
      }
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      // x_new = p_pred + R (q_f - q_f0): only the corrections pass through float.
      Vec3 q0 = pred_[i] - origin_;
      if (turn) q0 = to_local * q0;
      Vec3 dq(static_cast<double>(p_[i].x) - static_cast<double>(static_cast<float>(q0.x())),
              static_cast<double>(p_[i].y) - static_cast<double>(static_cast<float>(q0.y())),
              static_cast<double>(p_[i].z) - static_cast<double>(static_cast<float>(q0.z())));
      if (turn) dq = axes_ * dq;
      const Vec3 q = pred_[i] + dq;
      s.x_prev[i] = s.x[i];
      if (s.inv_mass[i] > 0.0) s.v[i] = (q - s.x[i]) / h;
      s.x[i] = s.inv_mass[i] > 0.0 ? q : pred_[i];
    }
  }
  sweeps_ += iterations_;
}

}  // namespace loom::cloth
