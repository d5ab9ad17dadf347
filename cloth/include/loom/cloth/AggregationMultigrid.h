#pragma once
// Aggregation multigrid preconditioner for FilteredPCG: one cycle per application, P⁻¹ ≈ A⁻¹ on
// the free vertices. Unsmoothed aggregation on 3x3 blocks (Vaněk, Mandel & Brezina 1996 "Algebraic multigrid
// by smoothed aggregation" §3 for the aggregation; Notay 2010 "An aggregation-based algebraic multigrid
// method" for plain aggregates under a Krylov method): vertices are grouped into aggregates along strong
// couplings |A_ij|_F > θ sqrt(|A_ii|_F |A_jj|_F); the prolongation P copies an aggregate's 3-vector to each
// of its vertices (the three translations), so the Galerkin coarse matrix PᵀAP is again block-sparse 3x3 with
// A_c(I, J) = Σ_{i∈I, j∈J} A_ij — summing blocks, no matrix products. Levels until <= `coarsest` vertices,
// solved there by a dense Cholesky factorisation.
// V-cycle: ν damped block-Jacobi sweeps x += ω D⁻¹ (b - A x) before and after the coarse correction (the same
// sweeps both sides, so the cycle is a symmetric operator, Jacobi being self-adjoint in the A inner product);
// SPD as long as ω D⁻¹ A has spectral radius below 2 (ω = 2/3 here).
// Additive finest level (MultigridCycle::kAdditiveFinest, the default): on the finest level the smoother and
// the coarse correction are added instead of applied in turn (a two-level additive Schwarz / BPX-type
// operator, Bramble, Pasciak & Xu 1990), B = ω_a D⁻¹ + P B_c Pᵀ, symmetric and SPD on the free subspace. It
// needs no fine-level matrix product, so one application costs a fraction of the PCG's own product, where the
// multiplicative V-cycle costs two. On the accuracy bench it takes more CG iterations than the V-cycle and
// far fewer than block-Jacobi, in the least time (docs/benchmarks.md).
// Filter: fixed vertices are in no aggregate and have D⁻¹ = 0, so the cycle maps a filtered residual to a
// correction that is exactly 0 on them: the operator is S B S with B SPD on the free subspace, as the
// filtered PCG needs.
// The aggregates, coarse patterns and the lists that sum fine blocks into coarse ones are built when A's
// pattern (BlockMatrix::pattern_id) or the fixed set changes; setup() refreshes the values only (one pass
// over A's blocks, the diagonal inverses, the coarsest factorisation). Every loop is per vertex or per coarse
// block with its sums in a fixed order: results are bit-identical for any thread count. A loop runs on
// several threads when the level it reads has >= 2048 vertices (the coarse sums and restrictions read the
// finer level).
#include <Eigen/Cholesky>
#include <cstdint>
#include <vector>

#include "loom/cloth/BlockMatrix.h"
#include "loom/cloth/Types.h"

namespace loom::cloth {

enum class MultigridCycle {
  kVCycle,          // multiplicative on every level (the V-cycle above)
  kAdditiveFinest,  // finest level additive, B = ω_a D⁻¹ + P B_c Pᵀ with B_c the V-cycle of the coarse levels
};

struct MultigridSettings {
  MultigridCycle cycle = MultigridCycle::kAdditiveFinest;
  double strength = 0.08;  // 1, θ: couplings weaker than θ sqrt(|A_ii| |A_jj|) (Frobenius) do not aggregate
  double omega = 2.0 / 3.0;  // 1, block-Jacobi damping of the smoother
  int sweeps = 1;            // smoothing sweeps before and after the coarse correction, per level
  int coarsest = 48;  // vertices: a level this small (or one that no longer coarsens) is solved directly
  double omega_additive = 1.0;  // 1, weight of the block-Jacobi term of the additive finest level
};

class AggregationMultigrid {
 public:
  explicit AggregationMultigrid(MultigridSettings s = {}) : s_(s) {}
  void set_settings(const MultigridSettings& s) { s_ = s; }
  // Hierarchy for A restricted to the free vertices (fixed[i] == 0). A must outlive the following apply()
  // calls.
  // `fine_dinv`, if given, is (A_ii)⁻¹ of the finest level as the caller already computed it (0 on fixed
  // vertices, identity where A_ii is singular): read in place (it must outlive the apply() calls too) instead
  // of inverted again.
  void setup(const BlockMatrix& A, const std::vector<char>& fixed, int threads,
             const std::vector<Mat3>* fine_dinv = nullptr);
  // z = B r (one V-cycle from zero); z is 0 on fixed vertices, r is read on free vertices only. r and z must
  // be distinct; the finest level works on them in place (no copies).
  void apply(const Vec3s& r, Vec3s& z, int threads);
  int levels() const { return static_cast<int>(levels_.size()); }
  int vertices(int level) const { return levels_[level].n; }
  long pattern_builds() const { return pattern_builds_; }  // hierarchies built (pattern or fixed set changed)

 private:
  struct Level {
    int n = 0;
    const BlockMatrix* A = nullptr;  // level 0: the caller's matrix; coarser: `own`
    BlockMatrix own;
    std::vector<char> fixed;  // level 0 only (coarse levels have no fixed vertices)
    std::vector<Mat3>
        own_dinv;  // (A_ii)⁻¹ on free vertices, 0 on fixed (unless the caller's is used, level 0)
    const std::vector<Mat3>* dinv = nullptr;  // own_dinv or the caller's fine_dinv
    // To the next coarser level (absent on the coarsest):
    std::vector<int> agg;                          // aggregate of each vertex, -1 for fixed vertices
    std::vector<int> member_start, members;        // CSR: the vertices of each aggregate, ascending
    std::vector<int> source_start, source_blocks;  // CSR: per coarse block, the fine blocks summed into it
    Vec3s b, x, res;
  };
  void build_pattern(const BlockMatrix& A, const std::vector<char>& fixed);
  void aggregate(const Level& l, std::vector<int>& agg) const;
  void coarse_values(int level, int threads);  // level's blocks from the finer level's
  // One cycle on `level` for the right-hand side b into x (level 0: the caller's r and z; coarser: the
  // level's own).
  void cycle(int level, const Vec3s& b, Vec3s& x, int threads);
  static void residual(Level& l, const Vec3s& b, const Vec3s& x,
                       int threads);  // l.res = b - A x (0 on fixed)
  static void restrict_to_coarser(const Level& l, const Vec3s& v, Level& c, int threads);  // c.b = Pᵀ v

  MultigridSettings s_;
  std::vector<Level> levels_;
  std::uint64_t pattern_id_ = 0;
  std::vector<char> fixed_key_;
  Eigen::LLT<Eigen::MatrixXd> coarse_llt_;
  Eigen::LDLT<Eigen::MatrixXd> coarse_ldlt_;  // fallback if the coarsest matrix is not numerically SPD
  bool coarse_use_ldlt_ = false;
  Eigen::VectorXd coarse_rhs_;
  long pattern_builds_ = 0;
};

}  // namespace loom::cloth
