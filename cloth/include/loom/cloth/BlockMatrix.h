#pragma once
// BlockMatrix: a block-sparse matrix of 3x3 blocks with a fixed pattern (CSR over vertices). Terms add
// their Jacobian blocks (df/dx, df/dv) into it; implicit solvers multiply with it or export it to Eigen.
#include <Eigen/Sparse>
#include <cstdint>
#include <utility>
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::cloth {

class BlockMatrix {
 public:
  BlockMatrix() = default;
  // n vertices; `pairs` are coupled vertex pairs (both (i,j) and (j,i) get a block); the diagonal is always
  // in.
  BlockMatrix(int n, const std::vector<std::pair<int, int>>& pairs);

  int size() const { return n_; }
  void set_zero();
  // The block (i, j); it must be in the pattern (asserted).
  Mat3& block(int i, int j);
  const Mat3* find(int i, int j) const;  // nullptr if (i, j) is not in the pattern
  void add(int i, int j, const Mat3& m) { block(i, j) += m; }
  void multiply(const Vec3s& x, Vec3s& y) const;  // y = A x
  Eigen::MatrixXd to_dense() const;
  Eigen::SparseMatrix<double> to_sparse() const;
  int num_blocks() const { return static_cast<int>(cols_.size()); }
  // Raw CSR access for solvers that combine matrices of the same pattern (blocks of row i are
  // blocks()[row_start()[i] .. row_start()[i+1]), in column order cols()).
  const std::vector<int>& row_start() const { return row_start_; }
  const std::vector<int>& cols() const { return cols_; }
  std::vector<Mat3>& blocks() { return blocks_; }
  const std::vector<Mat3>& blocks() const { return blocks_; }
  // Identifies the pattern: unique per constructed pattern, kept by copies (so K, D and A of a solver, copied
  // from one matrix, share it). Caches of slot indices (BlockGather) key on it; 0 = the empty matrix.
  std::uint64_t pattern_id() const { return pattern_id_; }

 private:
  int n_ = 0;
  std::uint64_t pattern_id_ = 0;
  std::vector<int> row_start_;  // n + 1
  std::vector<int> cols_;       // sorted within a row
  std::vector<Mat3> blocks_;
};

}  // namespace loom::cloth
