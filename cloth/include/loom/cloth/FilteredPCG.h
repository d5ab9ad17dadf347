#pragma once
// Filtered (projected) preconditioned conjugate gradients for A Δv = b with per-vertex constraints
// (Baraff & Witkin 1998 §5.3, modified PCG, written with a consistent
// preconditioner P⁻¹ ≈ A⁻¹). Each vertex has a filter S_i: I (free) or 0 (pinned: Δv_i is prescribed,
// z_i). The solution satisfies S(b - AΔv) ≈ 0 and (I - S)Δv = z exactly: a pinned vertex gets exactly
// its prescribed velocity. With S_i in {0, I}, MPCG is the exact PCG of the system restricted to the free
// vertices (Ascher & Boxerman 2003), so the usual CG convergence holds.
// Preconditioner: 3x3 block-Jacobi, P⁻¹_i = (A_ii)⁻¹ on free vertices (default), or one V-cycle of the
// aggregation multigrid (AggregationMultigrid.h), which carries the pins' load across the cloth in one
// application where block-Jacobi moves it about one vertex per iteration.
// Dot products are summed in fixed-size chunks in a fixed order: bit-identical for any thread count.
#include <vector>

#include "loom/cloth/AggregationMultigrid.h"
#include "loom/cloth/BlockMatrix.h"
#include "loom/cloth/Types.h"

namespace loom::cloth {

struct PcgResult {
  int iterations = 0;
  double relative_residual = 0.0;  // sqrt(rᵀP⁻¹r / bᵀP⁻¹b) at exit (filtered)
  bool converged = false;
};

enum class Preconditioner { kBlockJacobi, kMultigrid };

class FilteredPCG {
 public:
  void set_preconditioner(Preconditioner p, MultigridCycle cycle = MultigridCycle::kAdditiveFinest) {
    precond_ = p;
    MultigridSettings s;
    s.cycle = cycle;
    mg_.set_settings(s);
  }
  Preconditioner preconditioner() const { return precond_; }
  const AggregationMultigrid& multigrid() const { return mg_; }

  // fixed[i] != 0: vertex i is constrained (S_i = 0). `dv` holds z (prescribed values) on entry for fixed
  // vertices and, with warm_start, the initial guess on free ones (otherwise they start at 0); the
  // solution on exit. Stops when rᵀP⁻¹r <= tol² bᵀP⁻¹b (filtered b) or after max_iterations.
  // `normals` (optional, per vertex; a zero vector: none): a free vertex with a unit normal n_i gets the
  // filter S_i = I - n_i n_iᵀ with z_i = 0 along n_i (Baraff & Witkin 1998 Sec. 5.3: a contact constrains one
  // direction): its Δv keeps no component along n_i, the other two are solved for.
  // `diag_inverse` (optional): the block-Jacobi inverses as the caller already computed them, exactly as
  // solve() would: 0 on fixed vertices, (A_ii)⁻¹ on free ones (identity where A_ii is singular or the inverse
  // not finite).
  PcgResult solve(const BlockMatrix& A, const Vec3s& b, const std::vector<char>& fixed, Vec3s& dv, double tol,
                  int max_iterations, int threads, bool warm_start = false, const Vec3s* normals = nullptr,
                  const std::vector<Mat3>* diag_inverse = nullptr);
  // The block-Jacobi inverse of one free vertex's diagonal block, as solve() computes it.
  static Mat3 diagonal_inverse(const Mat3& a_ii) {
    Mat3 inv;
    bool ok = false;
    a_ii.computeInverseWithCheck(inv, ok);
    return ok && inv.allFinite() ? inv : Mat3::Identity();
  }

 private:
  double dot(const Vec3s& a, const Vec3s& b, int threads);
  // Sum of partial_ in index order (the per-chunk sums of the last fused loop).
  double partial_total() const;
  // out = B r (one multigrid cycle), then the contact filters (`normals` null: none).
  void apply_multigrid(const Vec3s& r, Vec3s& out, const Vec3s* normals, int threads);
  // Fills pinv_ (unless `given`), sets the starting Δv and s = P⁻¹ filter(b).
  void start(const BlockMatrix& A, const Vec3s& b, const std::vector<char>& fixed, Vec3s& dv, bool warm_start,
             const Vec3s* normals, const std::vector<Mat3>& pinv, bool given, int t);
  // r = filter(b - AΔv), c = P⁻¹ r.
  void initial_residual(const BlockMatrix& A, const Vec3s& b, const std::vector<char>& fixed, const Vec3s& dv,
                        const Vec3s* normals, const std::vector<Mat3>& pinv, int t);
  // q = filter(A c); returns cᵀq.
  double filtered_product(const BlockMatrix& A, const std::vector<char>& fixed, const Vec3s* normals, int t);
  // Δv += α c, r -= α q, s = P⁻¹ r; returns rᵀs.
  double step_and_precondition(double alpha, Vec3s& dv, const Vec3s* normals, const std::vector<Mat3>& pinv,
                               int t);
  Preconditioner precond_ = Preconditioner::kBlockJacobi;
  AggregationMultigrid mg_;
  std::vector<Mat3> pinv_;
  Vec3s r_, c_, q_, s_;
  std::vector<double> partial_;
};

}  // namespace loom::cloth
