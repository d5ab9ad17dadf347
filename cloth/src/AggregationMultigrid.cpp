#include "loom/cloth/AggregationMultigrid.h"

#include <algorithm>
#include <cmath>

namespace loom::cloth {

namespace {
constexpr int kParallelMin = 2048;  // vertices; smaller levels run on one thread (as FilteredPCG)
}  // namespace

void AggregationMultigrid::aggregate(const Level& l, std::vector<int>& agg) const {
  // Vaněk, Mandel & Brezina 1996 §3: (1) roots whose strong neighbourhood is still free form an aggregate
  // with it; (2) the rest join the aggregate of their strongest aggregated neighbour; (3) what is left groups
  // with its unaggregated strong neighbours.
  const BlockMatrix& A = *l.A;
  const auto& rs = A.row_start();
  const auto& cols = A.cols();
  const auto& blocks = A.blocks();
  const int n = l.n;
  std::vector<double> diag(n, 0.0);
  for (int i = 0; i < n; ++i)
    for (int k = rs[i]; k < rs[i + 1]; ++k)
      if (cols[k] == i) diag[i] = blocks[k].norm();
  auto is_fixed = [&](int i) { return !l.fixed.empty() && l.fixed[i]; };
  // Strength of the coupling (i, j) as a fraction of sqrt(|A_ii| |A_jj|); 0 when not strong.
  auto strength = [&](int i, int k) -> double {
    const int j = cols[k];
    if (j == i || is_fixed(j)) return 0.0;
    const double ref = std::sqrt(diag[i] * diag[j]);
    const double s = ref > 0.0 ? blocks[k].norm() / ref : 0.0;
    return s > s_.strength ? s : 0.0;
  };
  agg.assign(n, -1);
  int next = 0;
  for (int i = 0; i < n; ++i) {
    if (is_fixed(i) || agg[i] >= 0) continue;
    bool free_hood = true, any = false;
    for (int k = rs[i]; k < rs[i + 1] && free_hood; ++k)
      if (strength(i, k) > 0.0) {
        any = true;
        free_hood = agg[cols[k]] < 0;
      }
    if (!free_hood || !any) continue;
    agg[i] = next;
    for (int k = rs[i]; k < rs[i + 1]; ++k)
      if (strength(i, k) > 0.0) agg[cols[k]] = next;
    ++next;
  }
  const std::vector<int> first = agg;
  for (int i = 0; i < n; ++i) {
    if (is_fixed(i) || agg[i] >= 0) continue;
    double best = 0.0;
    for (int k = rs[i]; k < rs[i + 1]; ++k) {
      const double s = strength(i, k);
      if (s > best && first[cols[k]] >= 0) {
        best = s;
        agg[i] = first[cols[k]];
      }
    }
  }
  for (int i = 0; i < n; ++i) {
    if (is_fixed(i) || agg[i] >= 0) continue;
    agg[i] = next;
    for (int k = rs[i]; k < rs[i + 1]; ++k)
      if (strength(i, k) > 0.0 && agg[cols[k]] < 0) agg[cols[k]] = next;
    ++next;
  }
}

void AggregationMultigrid::build_pattern(const BlockMatrix& A, const std::vector<char>& fixed) {
  ++pattern_builds_;
  levels_.clear();
  levels_.emplace_back();
  levels_[0].n = A.size();
  levels_[0].A = &A;
  levels_[0].fixed = fixed;
  while (levels_.back().n > s_.coarsest) {
    Level& l = levels_.back();
    std::vector<int> agg;
    aggregate(l, agg);
    int nc = 0;
    for (int a : agg) nc = std::max(nc, a + 1);
    if (nc == 0 || nc > 0.8 * l.n) break;  // no longer coarsens: solve this level directly
    const BlockMatrix& F = *l.A;
    const auto& rs = F.row_start();
    const auto& cols = F.cols();
    std::vector<std::pair<int, int>> pairs;
    for (int i = 0; i < l.n; ++i)
      for (int k = rs[i]; k < rs[i + 1]; ++k) {
        const int I = agg[i], J = agg[cols[k]];
        if (I >= 0 && J >= 0 && I < J) pairs.emplace_back(I, J);
      }
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    Level c;
    c.n = nc;
    c.own = BlockMatrix(nc, pairs);
    // Members of each aggregate (ascending) and the fine blocks of each coarse block (ascending).
    l.member_start.assign(nc + 1, 0);
    for (int a : agg)
      if (a >= 0) ++l.member_start[a + 1];
    for (int I = 0; I < nc; ++I) l.member_start[I + 1] += l.member_start[I];
    l.members.assign(l.member_start[nc], 0);
    std::vector<int> fill(l.member_start.begin(), l.member_start.end() - 1);
    for (int i = 0; i < l.n; ++i)
      if (agg[i] >= 0) l.members[fill[agg[i]]++] = i;
    const Mat3* base = c.own.blocks().data();
    std::vector<int> target(F.num_blocks(), -1);
    const int ncb = c.own.num_blocks();
    l.source_start.assign(ncb + 1, 0);
    for (int i = 0; i < l.n; ++i)
      for (int k = rs[i]; k < rs[i + 1]; ++k) {
        const int I = agg[i], J = agg[cols[k]];
        if (I < 0 || J < 0) continue;
        target[k] = static_cast<int>(c.own.find(I, J) - base);
        ++l.source_start[target[k] + 1];
      }
    for (int q = 0; q < ncb; ++q) l.source_start[q + 1] += l.source_start[q];
    l.source_blocks.assign(l.source_start[ncb], 0);
    std::vector<int> put(l.source_start.begin(), l.source_start.end() - 1);
    for (int k = 0; k < F.num_blocks(); ++k)
      if (target[k] >= 0) l.source_blocks[put[target[k]]++] = k;
    l.agg = std::move(agg);
    levels_.push_back(std::move(c));
    // The vector may have moved: point every coarse level at its own matrix again.
    for (size_t q = 1; q < levels_.size(); ++q) levels_[q].A = &levels_[q].own;
    // The next aggregation reads this level's couplings.
    coarse_values(static_cast<int>(levels_.size()) - 1, 1);
  }
  for (Level& l : levels_) {
    l.b.assign(l.n, Vec3::Zero());
    l.x.assign(l.n, Vec3::Zero());
    l.res.assign(l.n, Vec3::Zero());
    l.own_dinv.assign(l.n, Mat3::Zero());
    l.dinv = &l.own_dinv;
  }
}

void AggregationMultigrid::coarse_values(int q, int threads) {
  // Galerkin coarse matrix PᵀAP of the aggregates: sums of fine blocks, each in ascending order.
  Level& l = levels_[q];
  const Level& f = levels_[q - 1];
  const auto& fb = f.A->blocks();
  auto& cb = l.own.blocks();
  const int ncb = l.own.num_blocks();
  const int t = f.n >= kParallelMin ? threads : 1;  // the work is the finer level's blocks
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
  for (int p = 0; p < ncb; ++p) {
    Mat3 sum = Mat3::Zero();
    for (int k = f.source_start[p]; k < f.source_start[p + 1]; ++k) sum += fb[f.source_blocks[k]];
    cb[p] = sum;
  }
}

void AggregationMultigrid::setup(const BlockMatrix& A, const std::vector<char>& fixed, int threads,
                                 const std::vector<Mat3>* fine_dinv) {
  if (A.pattern_id() != pattern_id_ || fixed != fixed_key_ || levels_.empty() || levels_[0].n != A.size()) {
    pattern_id_ = A.pattern_id();
    fixed_key_ = fixed;
    build_pattern(A, fixed);
  }
  levels_[0].A = &A;
  for (size_t q = 0; q < levels_.size(); ++q) {
    Level& l = levels_[q];
    const int t = l.n >= kParallelMin ? threads : 1;
    if (q > 0) coarse_values(static_cast<int>(q), threads);
    if (q == 0 && fine_dinv && static_cast<int>(fine_dinv->size()) == l.n) {
      l.dinv = fine_dinv;  // the caller's inverses, read in place
      continue;
    }
    l.dinv = &l.own_dinv;
    const BlockMatrix& M = *l.A;
    auto& dinv = l.own_dinv;
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
    for (int i = 0; i < l.n; ++i) {
      dinv[i].setZero();
      if (!l.fixed.empty() && l.fixed[i]) continue;
      const Mat3* d = M.find(i, i);
      Mat3 inv;
      bool ok = false;
      if (d) d->computeInverseWithCheck(inv, ok);
      dinv[i] = ok && inv.allFinite() ? inv : Mat3::Identity();
    }
  }
  // Coarsest level: dense factorisation (fixed vertices, if any, get identity rows and columns).
  const Level& c = levels_.back();
  Eigen::MatrixXd dense = c.A->to_dense();
  for (int i = 0; i < c.n; ++i)
    if (!c.fixed.empty() && c.fixed[i]) {
      dense.middleRows(3 * i, 3).setZero();
      dense.middleCols(3 * i, 3).setZero();
      dense.block<3, 3>(3 * i, 3 * i).setIdentity();
    }
  coarse_llt_.compute(dense);
  coarse_use_ldlt_ = coarse_llt_.info() != Eigen::Success;
  if (coarse_use_ldlt_) coarse_ldlt_.compute(dense);
}

void AggregationMultigrid::residual(Level& l, const Vec3s& b, const Vec3s& x, int threads) {
  const auto& rs = l.A->row_start();
  const auto& cols = l.A->cols();
  const auto& blocks = l.A->blocks();
  Vec3s& res = l.res;
  const int t = l.n >= kParallelMin ? threads : 1;
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
  for (int i = 0; i < l.n; ++i) {
    if (!l.fixed.empty() && l.fixed[i]) {
      res[i].setZero();
      continue;
    }
    Vec3 y = b[i];
    for (int k = rs[i]; k < rs[i + 1]; ++k) y -= blocks[k] * x[cols[k]];
    res[i] = y;
  }
}

// c.b = Pᵀ v: each aggregate's sum of its members' v (ascending member order: deterministic).
void AggregationMultigrid::restrict_to_coarser(const Level& l, const Vec3s& v, Level& c, int threads) {
  const int tc = l.n >= kParallelMin ? threads : 1;  // reads every vertex of the finer level
#pragma omp parallel for num_threads(tc) if (tc > 1) schedule(static)
  for (int I = 0; I < c.n; ++I) {
    Vec3 sum = Vec3::Zero();
    for (int k = l.member_start[I]; k < l.member_start[I + 1]; ++k) sum += v[l.members[k]];
    c.b[I] = sum;
  }
}

void AggregationMultigrid::cycle(int q, const Vec3s& b, Vec3s& x, int threads) {
  Level& l = levels_[q];
  const int t = l.n >= kParallelMin ? threads : 1;
  const std::vector<Mat3>& dinv = *l.dinv;
  if (q + 1 == static_cast<int>(levels_.size())) {
    coarse_rhs_.resize(3 * l.n);
    for (int i = 0; i < l.n; ++i) {
      const bool fx = !l.fixed.empty() && l.fixed[i];
      coarse_rhs_.segment<3>(3 * i) = fx ? Vec3::Zero() : b[i];
    }
    const Eigen::VectorXd sol = coarse_use_ldlt_ ? Eigen::VectorXd(coarse_ldlt_.solve(coarse_rhs_))
                                                 : Eigen::VectorXd(coarse_llt_.solve(coarse_rhs_));
    for (int i = 0; i < l.n; ++i) {
      const bool fx = !l.fixed.empty() && l.fixed[i];
      x[i] = fx ? Vec3::Zero() : Vec3(sol.segment<3>(3 * i));
    }
    return;
  }
  const double w = q == 0 && s_.cycle == MultigridCycle::kAdditiveFinest ? s_.omega_additive : s_.omega;
  if (q == 0 && s_.cycle == MultigridCycle::kAdditiveFinest) {
    // x = ω D⁻¹ b + P B_c Pᵀ b: both terms from b, no fine-level residual.
    Level& c = levels_[1];
    restrict_to_coarser(l, b, c, threads);
    cycle(1, c.b, c.x, threads);
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
    for (int i = 0; i < l.n; ++i) {
      x[i] = w * (dinv[i] * b[i]);
      if (l.agg[i] >= 0) x[i] += c.x[l.agg[i]];
    }
    return;
  }
  // Pre-smoothing from x = 0: the first sweep is x = ω D⁻¹ b.
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
  for (int i = 0; i < l.n; ++i) x[i] = w * (dinv[i] * b[i]);
  for (int s = 1; s < s_.sweeps; ++s) {
    residual(l, b, x, threads);
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
    for (int i = 0; i < l.n; ++i) x[i] += w * (dinv[i] * l.res[i]);
  }
  // Coarse correction: b_c = Pᵀ (b - A x), x += P x_c.
  residual(l, b, x, threads);
  Level& c = levels_[q + 1];
  restrict_to_coarser(l, l.res, c, threads);
  cycle(q + 1, c.b, c.x, threads);
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
  for (int i = 0; i < l.n; ++i)
    if (l.agg[i] >= 0) x[i] += c.x[l.agg[i]];
  // Post-smoothing: the same sweeps (symmetric cycle).
  for (int s = 0; s < s_.sweeps; ++s) {
    residual(l, b, x, threads);
#pragma omp parallel for num_threads(t) if (t > 1) schedule(static)
    for (int i = 0; i < l.n; ++i) x[i] += w * (dinv[i] * l.res[i]);
  }
}

void AggregationMultigrid::apply(const Vec3s& r, Vec3s& z, int threads) {
  // The finest level works on r and z in place.
  z.resize(levels_[0].n);
  cycle(0, r, z, threads);
}

}  // namespace loom::cloth
