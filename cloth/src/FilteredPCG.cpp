#include "loom/cloth/FilteredPCG.h"

#include <algorithm>
#include <cmath>

#include "loom/cloth/Term.h"  // chunked_sum

namespace loom::cloth {

namespace {
constexpr int kChunk = 256;  // vertices per partial sum (fixed, so sums do not depend on the thread count)
constexpr int kParallelMin = 2048;  // vertices; smaller systems iterate on one thread

// y = A x, rows in parallel (each row is summed in a fixed order).
void multiply(const BlockMatrix& A, const Vec3s& x, Vec3s& y, int threads) {
  const int n = A.size();
  y.resize(n);
  const auto& rs = A.row_start();
  const auto& cols = A.cols();
  const auto& b = A.blocks();
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
  for (int i = 0; i < n; ++i) {
    Vec3 acc = Vec3::Zero();
    for (int k = rs[i]; k < rs[i + 1]; ++k) acc += b[k] * x[cols[k]];
    y[i] = acc;
  }
}

// Contact filter S_i = I - n nᵀ: y -= n (n·y) on a vertex with a nonzero normal. `normals` null: no filter.
inline void filter(const Vec3s* normals, int i, Vec3& y) {
  if (!normals) return;
  const Vec3& nrm = (*normals)[i];
  if (nrm.x() != 0.0 || nrm.y() != 0.0 || nrm.z() != 0.0) y -= nrm * nrm.dot(y);
}
}  // namespace

double FilteredPCG::dot(const Vec3s& a, const Vec3s& b, int threads) {
  return chunked_sum<kChunk>(
      static_cast<int>(a.size()), threads, [&](int i) { return a[i].dot(b[i]); }, &partial_);
}

double FilteredPCG::partial_total() const {
  double sum = 0.0;
  for (double p : partial_) sum += p;
  return sum;
}

void FilteredPCG::apply_multigrid(const Vec3s& r, Vec3s& out, const Vec3s* normals, int threads) {
  mg_.apply(r, out, threads);
  if (normals)
    for (int i = 0; i < static_cast<int>(out.size()); ++i) filter(normals, i, out[i]);
}

void FilteredPCG::start(const BlockMatrix& A, const Vec3s& b, const std::vector<char>& fixed, Vec3s& dv,
                        bool warm_start, const Vec3s* normals, const std::vector<Mat3>& pinv, bool given,
                        int t) {
  const int n = A.size();
  // Block-Jacobi preconditioner; Δv starts at z (fixed) / 0 (free); s = P⁻¹ b.
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
  for (int i = 0; i < n; ++i) {
    if (fixed[i]) {
      if (!given) pinv_[i].setZero();
    } else {
      if (!warm_start || !dv[i].allFinite()) dv[i].setZero();
      if (!given) {
        const Mat3* d = A.find(i, i);
        pinv_[i] = d ? diagonal_inverse(*d) : Mat3::Identity();
      }
      filter(normals, i, dv[i]);
    }
    Vec3 bi = b[i];
    filter(normals, i, bi);
    s_[i] = pinv[i] * bi;
    filter(normals, i, s_[i]);
  }
  if (precond_ == Preconditioner::kMultigrid) {
    // s = B filter(b) (the cycle reads free rows only and returns 0 on fixed ones).
    mg_.setup(A, fixed, t, &pinv);  // its finest D⁻¹ is pinv (the same inverses, computed above or given)
    apply_multigrid(b, s_, normals, t);
  }
}

void FilteredPCG::initial_residual(const BlockMatrix& A, const Vec3s& b, const std::vector<char>& fixed,
                                   const Vec3s& dv, const Vec3s* normals, const std::vector<Mat3>& pinv,
                                   int t) {
  const int n = A.size();
  // r = filter(b - AΔv), c = P⁻¹ r
  multiply(A, dv, q_, t);
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
  for (int i = 0; i < n; ++i) {
    r_[i] = fixed[i] ? Vec3::Zero() : Vec3(b[i] - q_[i]);
    filter(normals, i, r_[i]);
    c_[i] = pinv[i] * r_[i];
    filter(normals, i, c_[i]);
  }
  if (precond_ == Preconditioner::kMultigrid) apply_multigrid(r_, c_, normals, t);
}

double FilteredPCG::filtered_product(const BlockMatrix& A, const std::vector<char>& fixed,
                                     const Vec3s* normals, int t) {
  const int n = A.size();
  const int chunks = (n + kChunk - 1) / kChunk;
  const auto& rs = A.row_start();
  const auto& cols = A.cols();
  const auto& blocks = A.blocks();
  // q = filter(A c), cᵀq
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
  for (int ch = 0; ch < chunks; ++ch) {
    double acc = 0.0;
    const int end = std::min(n, (ch + 1) * kChunk);
    for (int i = ch * kChunk; i < end; ++i) {
      Vec3 y = Vec3::Zero();
      if (!fixed[i])
        for (int k = rs[i]; k < rs[i + 1]; ++k) y += blocks[k] * c_[cols[k]];
      filter(normals, i, y);
      q_[i] = y;
      acc += c_[i].dot(y);
    }
    partial_[ch] = acc;
  }
  return partial_total();
}

double FilteredPCG::step_and_precondition(double alpha, Vec3s& dv, const Vec3s* normals,
                                          const std::vector<Mat3>& pinv, int t) {
  const int n = static_cast<int>(dv.size());
  // Δv += α c, r -= α q, s = P⁻¹ r, rᵀs
  if (precond_ == Preconditioner::kMultigrid) {
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
    for (int i = 0; i < n; ++i) {
      dv[i] += alpha * c_[i];
      r_[i] -= alpha * q_[i];
    }
    apply_multigrid(r_, s_, normals, t);
    return dot(r_, s_, t);
  }
  const int chunks = (n + kChunk - 1) / kChunk;
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
  for (int ch = 0; ch < chunks; ++ch) {
    double acc = 0.0;
    const int end = std::min(n, (ch + 1) * kChunk);
    for (int i = ch * kChunk; i < end; ++i) {
      dv[i] += alpha * c_[i];
      r_[i] -= alpha * q_[i];
      s_[i] = pinv[i] * r_[i];
      filter(normals, i, s_[i]);
      acc += r_[i].dot(s_[i]);
    }
    partial_[ch] = acc;
  }
  return partial_total();
}

PcgResult FilteredPCG::solve(const BlockMatrix& A, const Vec3s& b, const std::vector<char>& fixed, Vec3s& dv,
                             double tol, int max_iterations, int threads, bool warm_start,
                             const Vec3s* normals, const std::vector<Mat3>* diag_inverse) {
  const int n = A.size();
  // Contact filters (S_i = I - n nᵀ) apply only when there is one normal per vertex.
  const Vec3s* filters = normals && static_cast<int>(normals->size()) == n ? normals : nullptr;
  dv.resize(n);
  const bool given = diag_inverse && static_cast<int>(diag_inverse->size()) == n;
  if (!given) pinv_.resize(n);
  const std::vector<Mat3>& pinv = given ? *diag_inverse : pinv_;
  r_.resize(n);
  c_.resize(n);
  s_.resize(n);
  // Below kParallelMin vertices the fork/join costs more than the work: small systems run on one thread
  // (same results either way: every loop is per vertex, every sum is chunked in a fixed order).
  const int t = n >= kParallelMin ? threads : 1;
  start(A, b, fixed, dv, warm_start, filters, pinv, given, t);
  // δ0 = filter(b)ᵀ P⁻¹ filter(b)   (P⁻¹ is zero on fixed vertices, so it filters too)
  const double delta0 = dot(b, s_, t);
  PcgResult res;
  initial_residual(A, b, fixed, dv, filters, pinv, t);
  double delta = dot(r_, c_, t);
  if (!(delta0 > 0.0)) {
    res.converged = true;
    return res;
  }
  const double stop = tol * tol * delta0;
  // Iterations: per-chunk fused loops (3 parallel regions per iteration).
  partial_.assign((n + kChunk - 1) / kChunk, 0.0);
  int it = 0;
  while (delta > stop && it < max_iterations) {
    const double cq = filtered_product(A, fixed, filters, t);
    if (!(cq > 0.0)) break;  // A not positive definite along c: stop with what we have
    const double alpha = delta / cq;
    const double delta_old = delta;
    delta = step_and_precondition(alpha, dv, filters, pinv, t);
    const double beta = delta / delta_old;
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
    for (int i = 0; i < n; ++i) c_[i] = s_[i] + beta * c_[i];
    ++it;
  }
  res.iterations = it;
  res.relative_residual = std::sqrt(std::max(delta, 0.0) / delta0);
  res.converged = delta <= stop;
  return res;
}

}  // namespace loom::cloth
