#include "loom/cloth/FastXpbdSolver.h"

#include <omp.h>
#if defined(__SSE2__)
#include <xmmintrin.h>
#endif
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>
#define LOOM_FAST_XPBD_AVX 1
#define LOOM_AVX __attribute__((target("avx")))
#endif

#include <algorithm>
#include <cmath>
#include <cstring>

#include "loom/cloth/GravityTerm.h"
#include "loom/cloth/SpringSolverSupport.h"

namespace loom::cloth {

namespace {
// Loops shorter than this run on one thread: a parallel region costs more than the work it would split.
// Results do not depend on it (colours share no vertex; per-vertex loops are independent).
constexpr int kMinParallelSprings = 2048;
// Springs per batch: colours are padded to a multiple of it and split over threads at its multiples.
constexpr int kBatch = 8;
// m², springs shorter than 1 µm have no direction and are skipped.
constexpr float kMinLength2 = 1e-12f;

// Thread `me` of `team`'s static share of [begin, end), in whole batches from `begin`.
void share(int begin, int end, int me, int team, int* b, int* e) {
  const long len = end - begin;
  *b = begin + static_cast<int>(len * me / team / kBatch * kBatch);
  *e = me + 1 == team ? end : begin + static_cast<int>(len * (me + 1) / team / kBatch * kBatch);
}

// The springs of one sweep and the points they move; points are 4 floats (x, y, z, w), w the inverse mass.
struct Kernel {
  const int* si;
  const int* sj;
  const float* rest;       // m
  const float* gamma;      // 1
  const float* inv_denom;  // kg
  float* p;                // m, 4 floats per point
  const float* x0;         // m, 4 floats per point (step start; read only when damped)
};

// Macklin 2016 eq. (18) for C = l - L, ∇_j C = -∇_i C = n = d / l, with damping γ ∇C·(p - x_n):
//   Δλ = (-C - α̃ λ - γ n·((p_j - x_j) - (p_i - x_i))) / ((1 + γ)(w_i + w_j) + α̃),
//   p_i -= w_i Δλ n,  p_j += w_j Δλ n.
// With one iteration λ = 0 at the start, so the α̃ λ term vanishes. The scalar, SSE and AVX forms run the
// same float operations in the same order (no fused multiply-add), so a spring's result does not depend on
// which form projects it.
template <bool kDamped>
void project_scalar(const Kernel& q, int begin, int end) {
  for (int k = begin; k < end; ++k) {
    float* a = q.p + 4 * q.si[k];
    float* b = q.p + 4 * q.sj[k];
    const float dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
    const float l2 = dx * dx + dy * dy + dz * dz;
    if (!(l2 > kMinLength2)) continue;
    const float l = std::sqrt(l2);
    const float inv_l = 1.0f / l;
    const float c = l - q.rest[k];
    float num = 0.0f - c;
    if (kDamped) {
      const float* a0 = q.x0 + 4 * q.si[k];
      const float* b0 = q.x0 + 4 * q.sj[k];
      const float rate = ((b[0] - b0[0]) - (a[0] - a0[0])) * dx + ((b[1] - b0[1]) - (a[1] - a0[1])) * dy +
                         ((b[2] - b0[2]) - (a[2] - a0[2])) * dz;
      num = num - q.gamma[k] * (rate * inv_l);
    }
    const float s = (num * q.inv_denom[k]) * inv_l;
    const float sa = a[3] * s, sb = b[3] * s;
    a[0] -= sa * dx, a[1] -= sa * dy, a[2] -= sa * dz;
    b[0] += sb * dx, b[1] += sb * dy, b[2] += sb * dz;
  }
}

#if defined(__SSE2__)
template <bool kDamped>
void project_sse(const Kernel& q, int begin, int end) {
  const __m128 min_l2 = _mm_set1_ps(kMinLength2), one = _mm_set1_ps(1.0f), zero = _mm_setzero_ps();
  float* p = q.p;
  int k = begin;
  for (; k + 4 <= end; k += 4) {
    const int* i = q.si + k;
    const int* j = q.sj + k;
    __m128 ax = _mm_load_ps(p + 4 * i[0]), ay = _mm_load_ps(p + 4 * i[1]), az = _mm_load_ps(p + 4 * i[2]),
           aw = _mm_load_ps(p + 4 * i[3]);
    _MM_TRANSPOSE4_PS(ax, ay, az, aw);
    __m128 bx = _mm_load_ps(p + 4 * j[0]), by = _mm_load_ps(p + 4 * j[1]), bz = _mm_load_ps(p + 4 * j[2]),
           bw = _mm_load_ps(p + 4 * j[3]);
    _MM_TRANSPOSE4_PS(bx, by, bz, bw);
    const __m128 dx = _mm_sub_ps(bx, ax), dy = _mm_sub_ps(by, ay), dz = _mm_sub_ps(bz, az);
    const __m128 l2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
    const __m128 ok = _mm_cmpgt_ps(l2, min_l2);
    const __m128 l = _mm_sqrt_ps(l2);
    const __m128 inv_l = _mm_div_ps(one, _mm_or_ps(_mm_and_ps(ok, l), _mm_andnot_ps(ok, one)));
    const __m128 c = _mm_sub_ps(l, _mm_loadu_ps(q.rest + k));
    __m128 num = _mm_sub_ps(zero, c);
    if (kDamped) {  // the damping term needs the step-start positions
      const float* x0 = q.x0;
      __m128 a0x = _mm_load_ps(x0 + 4 * i[0]), a0y = _mm_load_ps(x0 + 4 * i[1]),
             a0z = _mm_load_ps(x0 + 4 * i[2]), a0w = _mm_load_ps(x0 + 4 * i[3]);
      _MM_TRANSPOSE4_PS(a0x, a0y, a0z, a0w);
      __m128 b0x = _mm_load_ps(x0 + 4 * j[0]), b0y = _mm_load_ps(x0 + 4 * j[1]),
             b0z = _mm_load_ps(x0 + 4 * j[2]), b0w = _mm_load_ps(x0 + 4 * j[3]);
      _MM_TRANSPOSE4_PS(b0x, b0y, b0z, b0w);
      const __m128 rate =
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_sub_ps(_mm_sub_ps(bx, b0x), _mm_sub_ps(ax, a0x)), dx),
                                _mm_mul_ps(_mm_sub_ps(_mm_sub_ps(by, b0y), _mm_sub_ps(ay, a0y)), dy)),
                     _mm_mul_ps(_mm_sub_ps(_mm_sub_ps(bz, b0z), _mm_sub_ps(az, a0z)), dz));
      num = _mm_sub_ps(num, _mm_mul_ps(_mm_loadu_ps(q.gamma + k), _mm_mul_ps(rate, inv_l)));
    }
    const __m128 s = _mm_and_ps(ok, _mm_mul_ps(_mm_mul_ps(num, _mm_loadu_ps(q.inv_denom + k)), inv_l));
    const __m128 sa = _mm_mul_ps(aw, s), sb = _mm_mul_ps(bw, s);
    ax = _mm_sub_ps(ax, _mm_mul_ps(sa, dx)), ay = _mm_sub_ps(ay, _mm_mul_ps(sa, dy));
    az = _mm_sub_ps(az, _mm_mul_ps(sa, dz));
    bx = _mm_add_ps(bx, _mm_mul_ps(sb, dx)), by = _mm_add_ps(by, _mm_mul_ps(sb, dy));
    bz = _mm_add_ps(bz, _mm_mul_ps(sb, dz));
    _MM_TRANSPOSE4_PS(ax, ay, az, aw);
    _mm_store_ps(p + 4 * i[0], ax), _mm_store_ps(p + 4 * i[1], ay), _mm_store_ps(p + 4 * i[2], az);
    _mm_store_ps(p + 4 * i[3], aw);
    _MM_TRANSPOSE4_PS(bx, by, bz, bw);
    _mm_store_ps(p + 4 * j[0], bx), _mm_store_ps(p + 4 * j[1], by), _mm_store_ps(p + 4 * j[2], bz);
    _mm_store_ps(p + 4 * j[3], bw);
  }
  project_scalar<kDamped>(q, k, end);
}
#endif

#if defined(LOOM_FAST_XPBD_AVX)
// Eight points as four AVX rows x, y, z, w: lanes 0-3 from the low halves, 4-7 from the high halves.
LOOM_AVX inline void load8(const float* p, const int* i, __m256& x, __m256& y, __m256& z, __m256& w) {
  const __m256 r0 =
      _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(p + 4 * i[0])), _mm_load_ps(p + 4 * i[4]), 1);
  const __m256 r1 =
      _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(p + 4 * i[1])), _mm_load_ps(p + 4 * i[5]), 1);
  const __m256 r2 =
      _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(p + 4 * i[2])), _mm_load_ps(p + 4 * i[6]), 1);
  const __m256 r3 =
      _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(p + 4 * i[3])), _mm_load_ps(p + 4 * i[7]), 1);
  const __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpacklo_ps(r2, r3);
  const __m256 t2 = _mm256_unpackhi_ps(r0, r1), t3 = _mm256_unpackhi_ps(r2, r3);
  x = _mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(1, 0, 1, 0));
  y = _mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(3, 2, 3, 2));
  z = _mm256_shuffle_ps(t2, t3, _MM_SHUFFLE(1, 0, 1, 0));
  w = _mm256_shuffle_ps(t2, t3, _MM_SHUFFLE(3, 2, 3, 2));
}

// The inverse of load8.
LOOM_AVX inline void store8(float* p, const int* i, __m256 x, __m256 y, __m256 z, __m256 w) {
  const __m256 t0 = _mm256_unpacklo_ps(x, y), t1 = _mm256_unpacklo_ps(z, w);
  const __m256 t2 = _mm256_unpackhi_ps(x, y), t3 = _mm256_unpackhi_ps(z, w);
  const __m256 r0 = _mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(1, 0, 1, 0));
  const __m256 r1 = _mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(3, 2, 3, 2));
  const __m256 r2 = _mm256_shuffle_ps(t2, t3, _MM_SHUFFLE(1, 0, 1, 0));
  const __m256 r3 = _mm256_shuffle_ps(t2, t3, _MM_SHUFFLE(3, 2, 3, 2));
  _mm_store_ps(p + 4 * i[0], _mm256_castps256_ps128(r0));
  _mm_store_ps(p + 4 * i[1], _mm256_castps256_ps128(r1));
  _mm_store_ps(p + 4 * i[2], _mm256_castps256_ps128(r2));
  _mm_store_ps(p + 4 * i[3], _mm256_castps256_ps128(r3));
  _mm_store_ps(p + 4 * i[4], _mm256_extractf128_ps(r0, 1));
  _mm_store_ps(p + 4 * i[5], _mm256_extractf128_ps(r1, 1));
  _mm_store_ps(p + 4 * i[6], _mm256_extractf128_ps(r2, 1));
  _mm_store_ps(p + 4 * i[7], _mm256_extractf128_ps(r3, 1));
}

template <bool kDamped>
LOOM_AVX void project_avx(const Kernel& q, int begin, int end) {
  const __m256 min_l2 = _mm256_set1_ps(kMinLength2), one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
  float* const p = q.p;
  const int* const si = q.si;
  const int* const sj = q.sj;
  const float* const rest = q.rest;
  const float* const inv_denom = q.inv_denom;
  int k = begin;
  for (; k + 8 <= end; k += 8) {
    const int* i = si + k;
    const int* j = sj + k;
    __m256 ax, ay, az, aw, bx, by, bz, bw;
    load8(p, i, ax, ay, az, aw);
    load8(p, j, bx, by, bz, bw);
    const __m256 dx = _mm256_sub_ps(bx, ax), dy = _mm256_sub_ps(by, ay), dz = _mm256_sub_ps(bz, az);
    const __m256 l2 =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
    const __m256 ok = _mm256_cmp_ps(l2, min_l2, _CMP_GT_OQ);
    const __m256 l = _mm256_sqrt_ps(l2);
    const __m256 inv_l = _mm256_div_ps(one, _mm256_or_ps(_mm256_and_ps(ok, l), _mm256_andnot_ps(ok, one)));
    const __m256 c = _mm256_sub_ps(l, _mm256_loadu_ps(rest + k));
    __m256 num = _mm256_sub_ps(zero, c);
    if (kDamped) {  // the damping term needs the step-start positions
      __m256 a0x, a0y, a0z, a0w, b0x, b0y, b0z, b0w;
      load8(q.x0, i, a0x, a0y, a0z, a0w);
      load8(q.x0, j, b0x, b0y, b0z, b0w);
      const __m256 rate = _mm256_add_ps(
          _mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_sub_ps(bx, b0x), _mm256_sub_ps(ax, a0x)), dx),
                        _mm256_mul_ps(_mm256_sub_ps(_mm256_sub_ps(by, b0y), _mm256_sub_ps(ay, a0y)), dy)),
          _mm256_mul_ps(_mm256_sub_ps(_mm256_sub_ps(bz, b0z), _mm256_sub_ps(az, a0z)), dz));
      num = _mm256_sub_ps(num, _mm256_mul_ps(_mm256_loadu_ps(q.gamma + k), _mm256_mul_ps(rate, inv_l)));
    }
    const __m256 s =
        _mm256_and_ps(ok, _mm256_mul_ps(_mm256_mul_ps(num, _mm256_loadu_ps(inv_denom + k)), inv_l));
    const __m256 sa = _mm256_mul_ps(aw, s), sb = _mm256_mul_ps(bw, s);
    ax = _mm256_sub_ps(ax, _mm256_mul_ps(sa, dx)), ay = _mm256_sub_ps(ay, _mm256_mul_ps(sa, dy));
    az = _mm256_sub_ps(az, _mm256_mul_ps(sa, dz));
    bx = _mm256_add_ps(bx, _mm256_mul_ps(sb, dx)), by = _mm256_add_ps(by, _mm256_mul_ps(sb, dy));
    bz = _mm256_add_ps(bz, _mm256_mul_ps(sb, dz));
    store8(p, i, ax, ay, az, aw);
    store8(p, j, bx, by, bz, bw);
  }
  project_scalar<kDamped>(q, k, end);
}
#endif

// The widest form this processor runs: 8 (AVX), 4 (SSE) or 1.
int widest_form() {
#if defined(LOOM_FAST_XPBD_AVX)
  if (__builtin_cpu_supports("avx")) return 8;
#endif
#if defined(__SSE2__)
  return 4;
#else
  return 1;
#endif
}
}  // namespace

void FastXpbdSolver::check(const Cloth& cloth) const { check_spring_terms(cloth, name()); }

void FastXpbdSolver::set_frame(const Eigen::Isometry3d& frame) {
  origin_ = frame.translation();
  axes_ = frame.linear();
  framed_ = true;
}

void FastXpbdSolver::set_lanes(int lanes) { lanes_ = std::min(lanes, widest_form()); }

std::vector<std::pair<std::string, double>> FastXpbdSolver::counters() const {
  return {{"springs", static_cast<double>(real_springs_)}, {"sweeps", static_cast<double>(sweeps_)}};
}

std::vector<std::vector<std::pair<int, int>>> FastXpbdSolver::spring_colors() const {
  std::vector<std::vector<std::pair<int, int>>> out;
  for (size_t c = 0; c + 1 < color_start_.size(); ++c) {
    out.emplace_back();
    for (int k = color_start_[c]; k < color_start_[c + 1]; ++k)
      if (si_[k] < vertices_) out.back().emplace_back(si_[k], sj_[k]);
  }
  return out;
}

void FastXpbdSolver::prepare(const Cloth& cloth) {
  std::vector<Spring> springs = collect_springs(cloth);
  springs.erase(std::remove_if(springs.begin(), springs.end(), [](const Spring& s) { return !(s.k > 0.0); }),
                springs.end());
  vertices_ = cloth.state().size();
  const std::vector<std::vector<int>> colors = color_springs(vertices_, springs);
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
    while (si_.size() % kBatch != 0) {  // padding: the spare vertex with itself, zero weight
      si_.push_back(vertices_);
      sj_.push_back(vertices_);
      rest_.push_back(0.0f);
      alpha_.push_back(0.0f);
      beta_.push_back(0.0f);
    }
    color_start_.push_back(static_cast<int>(si_.size()));
  }
  real_springs_ = static_cast<int>(springs.size());
  const size_t ns = si_.size();
  gamma_.assign(ns, 0.0f);
  alpha_t_.assign(ns, 0.0f);
  inv_denom_.assign(ns, 0.0f);
  lambda_.assign(iterations_ > 1 ? ns : 0, 0.0);
  damped_ = std::any_of(beta_.begin(), beta_.end(), [](float b) { return b > 0.0f; });
  if (lanes_ == 0) lanes_ = widest_form();
  inv_mass_.clear();
  h_ = 0.0;
  prepared_for_ = &cloth;
}

void FastXpbdSolver::update_denominators(const ClothState& s, double h, int begin, int end) {
  const double inv_h2 = 1.0 / (h * h);
  for (int k = begin; k < end; ++k) {
    if (si_[k] >= vertices_) continue;  // padding keeps γ = α̃ = 1 / denominator = 0
    const double w = s.inv_mass[si_[k]] + s.inv_mass[sj_[k]];
    const double gamma = beta_[k] / h, alpha_t = alpha_[k] * inv_h2;
    gamma_[k] = static_cast<float>(gamma);
    alpha_t_[k] = static_cast<float>(alpha_t);
    inv_denom_[k] = w > 0.0 ? static_cast<float>(1.0 / ((1.0 + gamma) * w + alpha_t)) : 0.0f;
  }
}

void FastXpbdSolver::project(int begin, int end) {
  const Kernel q{si_.data(),        sj_.data(),    rest_.data(),  gamma_.data(),
                 inv_denom_.data(), &p_.data()->x, &x0_.data()->x};
#if defined(LOOM_FAST_XPBD_AVX)
  if (lanes_ == 8) return damped_ ? project_avx<true>(q, begin, end) : project_avx<false>(q, begin, end);
#endif
#if defined(__SSE2__)
  if (lanes_ == 4) return damped_ ? project_sse<true>(q, begin, end) : project_sse<false>(q, begin, end);
#endif
  return damped_ ? project_scalar<true>(q, begin, end) : project_scalar<false>(q, begin, end);
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

// Prediction (Macklin 2016, Alg. 1 line 3): p = x + h (v + h w f), f the external forces, or m g when gravity
// is the only external force (the same operations: f_i = m_i g). Kinematic vertices have w = 0, so
// p = x + h v exactly. Evaluated twice per step, before and after the projections, with the same bits (the
// state is not changed in between), rather than stored.
inline Vec3 predicted(const Vec3* x, const Vec3* v, const double* inv_mass, const Vec3* f, double h,
                      const double* gravity_mass, const Vec3& g, int i) {
  return x[i] + h * (v[i] + (h * inv_mass[i]) * (gravity_mass ? Vec3(gravity_mass[i] * g) : f[i]));
}

template <bool kTurn>
void FastXpbdSolver::predict(const ClothState& s, double h, const double* gravity_mass, const Vec3& g,
                             int begin, int end) {
  const Mat3 to_local = axes_.transpose();
  const bool start = damped_ || iterations_ > 1;
  const Vec3* const x = s.x.data();
  const Vec3* const v = s.v.data();
  const double* const inv_mass = s.inv_mass.data();
  const Vec3* const f = f_.data();
  Point* const p = p_.data();
  for (int i = begin; i < end; ++i) {
    Vec3 q = predicted(x, v, inv_mass, f, h, gravity_mass, g, i) - origin_;
    if (kTurn) q = to_local * q;
    p[i] = Point{static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()),
                 static_cast<float>(inv_mass[i])};
    if (start) {
      Vec3 q0 = x[i] - origin_;
      if (kTurn) q0 = to_local * q0;
      x0_[i] =
          Point{static_cast<float>(q0.x()), static_cast<float>(q0.y()), static_cast<float>(q0.z()), 0.0f};
    }
  }
}

// x_new = p_pred + R (q_f - q_f0), q_f0 the float prediction: only the corrections pass through float;
// v = (x_new - x) / h.
template <bool kTurn>
void FastXpbdSolver::finish(ClothState& s, double h, const double* gravity_mass, const Vec3& g, int begin,
                            int end) {
  const Mat3 to_local = axes_.transpose();
  Vec3* const x = s.x.data();
  Vec3* const v = s.v.data();
  Vec3* const x_prev = s.x_prev.data();
  const double* const inv_mass = s.inv_mass.data();
  const Vec3* const f = f_.data();
  const Point* const p = p_.data();
  for (int i = begin; i < end; ++i) {
    const Vec3 pred = predicted(x, v, inv_mass, f, h, gravity_mass, g, i);
    x_prev[i] = x[i];
    if (!(inv_mass[i] > 0.0)) {
      x[i] = pred;
      continue;
    }
    Vec3 q0 = pred - origin_;
    if (kTurn) q0 = to_local * q0;
    const Point& a = p[i];
    Vec3 dq(static_cast<double>(a.x) - static_cast<double>(static_cast<float>(q0.x())),
            static_cast<double>(a.y) - static_cast<double>(static_cast<float>(q0.y())),
            static_cast<double>(a.z) - static_cast<double>(static_cast<float>(q0.z())));
    if (kTurn) dq = axes_ * dq;
    const Vec3 q = pred + dq;
    v[i] = (q - x[i]) / h;
    x[i] = q;
  }
}

void FastXpbdSolver::step(Cloth& cloth, double t, double h, int threads) {
  ClothState& s = cloth.state();
  if (prepared_for_ != &cloth || s.size() != vertices_) prepare(cloth);
  const int n = s.size();
  const int ns = static_cast<int>(si_.size());
  const int num_colors = static_cast<int>(color_start_.size()) - 1;
  // The denominators are recomputed when h or an inverse mass changed since they were (each thread compares
  // its share of the inverse masses bitwise: a -0 for a 0 only recomputes).
  int stale = !(h == h_);
  if (inv_mass_.size() != s.inv_mass.size()) inv_mass_.assign(n, 0.0), stale = 1;
  // Gravity alone is folded into the prediction; other external forces are summed first.
  const GravityTerm* gravity = nullptr;
  int others = 0;
  for (const auto& term : cloth.terms()) {
    if (dynamic_cast<const SpringTerm*>(term.get())) continue;
    const auto* g = dynamic_cast<const GravityTerm*>(term.get());
    if (g && !gravity && static_cast<int>(g->mass().size()) == n)
      gravity = g;
    else
      ++others;
  }
  const double* gravity_mass = nullptr;
  Vec3 g = Vec3::Zero();
  if (others == 0) {
    if (gravity)
      gravity_mass = gravity->mass().data(), g = gravity->g();
    else
      f_.assign(n, Vec3::Zero());  // no external force at all
  } else {
    external_forces(cloth, s.x, s.v, t, threads, f_);
  }
  p_.resize(n + 1);
  x0_.resize(n + 1);
  p_[n] = x0_[n] = Point{0.0f, 0.0f, 0.0f, 0.0f};  // the padding springs' spare vertex
  if (!framed_) origin_ = n > 0 ? s.x[0] : Vec3::Zero();
  // World axes need no rotation (and keep every rounding of the unframed step); a frame's axes do.
  const bool turn = framed_ && axes_ != Mat3::Identity();
  s.x_prev.resize(n);
  const bool with_lambda = iterations_ > 1;
  // The step on thread `me` of `team`. A team of one runs without OpenMP: libgomp's barrier and the end of a
  // parallel region wake waiting threads with a system call even when there are none, one per colour.
  auto body = [&](int me, int team) {
    auto sync = [team] {
      if (team > 1) {
#pragma omp barrier
      }
    };
    int b = 0, e = 0;
    if (with_lambda) {
      share(0, ns, me, team, &b, &e);
      std::fill(lambda_.begin() + b, lambda_.begin() + e, 0.0);
    }
    const int vb = static_cast<int>(static_cast<long>(n) * me / team);
    const int ve = static_cast<int>(static_cast<long>(n) * (me + 1) / team);
    if (turn)
      predict<true>(s, h, gravity_mass, g, vb, ve);
    else
      predict<false>(s, h, gravity_mass, g, vb, ve);
    if (ve > vb && std::memcmp(inv_mass_.data() + vb, s.inv_mass.data() + vb, (ve - vb) * sizeof(double))) {
#pragma omp atomic write
      stale = 1;
    }
    sync();
    if (stale) {
      share(0, ns, me, team, &b, &e);
      update_denominators(s, h, b, e);
      std::copy(s.inv_mass.begin() + vb, s.inv_mass.begin() + ve, inv_mass_.begin() + vb);
      sync();
    }
    for (int it = 0; it < iterations_; ++it)
      for (int c = 0; c < num_colors; ++c) {
        share(color_start_[c], color_start_[c + 1], me, team, &b, &e);
        if (with_lambda)
          project_lambda(b, e);
        else
          project(b, e);
        sync();
      }
    if (turn)
      finish<true>(s, h, gravity_mass, g, vb, ve);
    else
      finish<false>(s, h, gravity_mass, g, vb, ve);
  };
  if (threads > 1 && ns >= kMinParallelSprings) {
#pragma omp parallel num_threads(threads)
    body(omp_get_thread_num(), omp_get_num_threads());
  } else {
    body(0, 1);
  }
  h_ = h;
  sweeps_ += iterations_;
}

}  // namespace loom::cloth
