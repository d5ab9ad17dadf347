#include "loom/cloth/BlockMatrix.h"

#include <algorithm>
#include <atomic>
#include <cassert>

namespace loom::cloth {

namespace {
std::atomic<std::uint64_t> next_pattern_id{1};
}  // namespace

BlockMatrix::BlockMatrix(int n, const std::vector<std::pair<int, int>>& pairs)
    : n_(n), pattern_id_(next_pattern_id++) {
  std::vector<std::vector<int>> rows(n);
  for (int i = 0; i < n; ++i) rows[i].push_back(i);
  for (const auto& [i, j] : pairs) {
    rows[i].push_back(j);
    rows[j].push_back(i);
  }
  row_start_.assign(n + 1, 0);
  for (int i = 0; i < n; ++i) {
    std::sort(rows[i].begin(), rows[i].end());
    rows[i].erase(std::unique(rows[i].begin(), rows[i].end()), rows[i].end());
    row_start_[i + 1] = row_start_[i] + static_cast<int>(rows[i].size());
  }
  cols_.reserve(row_start_[n]);
  for (int i = 0; i < n; ++i) cols_.insert(cols_.end(), rows[i].begin(), rows[i].end());
  blocks_.assign(cols_.size(), Mat3::Zero());
}

void BlockMatrix::set_zero() { std::fill(blocks_.begin(), blocks_.end(), Mat3::Zero()); }

const Mat3* BlockMatrix::find(int i, int j) const {
  const auto begin = cols_.begin() + row_start_[i], end = cols_.begin() + row_start_[i + 1];
  const auto it = std::lower_bound(begin, end, j);
  if (it == end || *it != j) return nullptr;
  return &blocks_[it - cols_.begin()];
}

Mat3& BlockMatrix::block(int i, int j) {
  const Mat3* b = find(i, j);
  assert(b && "block not in the pattern");
  return const_cast<Mat3&>(*b);
}

void BlockMatrix::multiply(const Vec3s& x, Vec3s& y) const {
  y.resize(n_);
  for (int i = 0; i < n_; ++i) {
    Vec3 acc = Vec3::Zero();
    for (int k = row_start_[i]; k < row_start_[i + 1]; ++k) acc += blocks_[k] * x[cols_[k]];
    y[i] = acc;
  }
}

Eigen::MatrixXd BlockMatrix::to_dense() const {
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(3 * n_, 3 * n_);
  for (int i = 0; i < n_; ++i)
    for (int k = row_start_[i]; k < row_start_[i + 1]; ++k) d.block<3, 3>(3 * i, 3 * cols_[k]) = blocks_[k];
  return d;
}

Eigen::SparseMatrix<double> BlockMatrix::to_sparse() const {
  std::vector<Eigen::Triplet<double>> trips;
  trips.reserve(cols_.size() * 9);
  for (int i = 0; i < n_; ++i)
    for (int k = row_start_[i]; k < row_start_[i + 1]; ++k)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) trips.emplace_back(3 * i + r, 3 * cols_[k] + c, blocks_[k](r, c));
  Eigen::SparseMatrix<double> s(3 * n_, 3 * n_);
  s.setFromTriplets(trips.begin(), trips.end());
  return s;
}

}  // namespace loom::cloth
