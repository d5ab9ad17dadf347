#pragma once
// SplitCholesky: a sparse Cholesky factorisation P A Pᵀ = L Lᵀ of a scalar symmetric positive definite
// matrix A (n x n) whose solves with three right-hand sides (x, y, z) run on two threads with the same bits
// as on one. Projective dynamics' global step and desbrun's filter solve with it every iteration.
//
// Ordering (one level of nested dissection): a breadth-first level structure of A's graph from a
// pseudo-peripheral vertex; the level S where the vertex count crosses half separates the vertices of the
// lower levels (part 0) from those of the higher levels (part 1), since an entry of A joins vertices of
// equal or adjacent levels. Each part is ordered by AMD (Eigen's AMDOrdering), S last. Eliminating a
// vertex of one part creates fill only among its part and S, so L has no entry joining the two parts: the
// columns of the two parts are independent in both substitutions, and only the columns of S (a few % of n
// on a cloth) are serial. Each part adds its updates of S's rows into a buffer of its own; the buffers are
// added in a fixed order, so the result does not depend on the thread count.
//
// The substitutions read L once for the three columns (rows of 3 doubles), where Eigen's solve of a
// three-column right-hand side reads it once per column: the solves are memory bound.
#include <Eigen/SparseCore>
#include <array>
#include <string>
#include <vector>

namespace loom::cloth {

class SplitCholesky {
 public:
  // Matrices smaller than this are not split (one part, no separator): two threads gain nothing there.
  static constexpr int kMinSplit = 2048;

  // Factorises A (both triangles stored, symmetric). Returns false if A is not positive definite; error()
  // then says why.
  bool compute(const Eigen::SparseMatrix<double>& a);
  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }

  // x = A⁻¹ b for the three columns of b, on up to two threads; the same bits for any thread count. Uses
  // scratch buffers of the object (not reentrant). Throws std::logic_error without a successful compute()
  // or when b has another row count.
  void solve(const Eigen::MatrixX3d& b, Eigen::MatrixX3d& x, int threads);

  int size() const { return n_; }
  // Vertices in part 0, part 1 and the separator S (S = 0 and part 1 = 0 when A is not split).
  std::array<int, 3> part_sizes() const { return {end0_, end1_ - end0_, n_ - end1_}; }
  // Stored entries of L below the diagonal, in total and joining part 0 with part 1 (0 by construction;
  // exposed so that tests can check it).
  long off_diagonal_entries() const { return static_cast<long>(row_.size()); }
  long entries_joining_the_parts() const;

 private:
  bool fail(const char* why);
  void copy_factor(const Eigen::SparseMatrix<double>& l);
  void forward(int begin, int end, double* y, double* s_rows) const;
  void backward(int begin, int end, double* y) const;

  int n_ = 0;
  int end0_ = 0, end1_ = 0;  // part 0 = [0, end0_), part 1 = [end0_, end1_), S = [end1_, n_) (new numbering)
  bool ok_ = false;
  std::string error_;
  std::vector<int> old_of_new_;  // permutation: old index of each new index
  std::vector<double> diag_;     // L_jj
  std::vector<int> start_;       // CSC of L's strictly lower part, rows ascending within a column
  std::vector<int> row_;
  std::vector<double> value_;
  std::vector<double> y_;                        // 3 n, rows of (x, y, z)
  std::array<std::vector<double>, 2> s_buffer_;  // each part's updates of S's rows, 3 |S|
};

}  // namespace loom::cloth
