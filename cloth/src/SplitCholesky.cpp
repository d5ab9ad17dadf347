#include "loom/cloth/SplitCholesky.h"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <stdexcept>

namespace loom::cloth {

namespace {

// A's graph (off-diagonal pattern) as adjacency lists in CSR form.
struct Graph {
  std::vector<int> start, adj;
  int degree(int v) const { return start[v + 1] - start[v]; }
};

Graph graph_of(const Eigen::SparseMatrix<double>& a) {
  const int n = static_cast<int>(a.cols());
  Graph g;
  g.start.assign(n + 1, 0);
  for (int j = 0; j < n; ++j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(a, j); it; ++it)
      if (it.row() != j) ++g.start[j + 1];
  for (int j = 0; j < n; ++j) g.start[j + 1] += g.start[j];
  g.adj.resize(g.start[n]);
  for (int j = 0, q = 0; j < n; ++j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(a, j); it; ++it)
      if (it.row() != j) g.adj[q++] = static_cast<int>(it.row());
  return g;
}

// Breadth-first levels from root over root's component (level -1 elsewhere); returns the number of levels.
int bfs_levels(const Graph& g, int root, std::vector<int>& level, std::vector<int>& queue) {
  std::fill(level.begin(), level.end(), -1);
  queue.clear();
  queue.push_back(root);
  level[root] = 0;
  for (size_t q = 0; q < queue.size(); ++q) {
    const int v = queue[q];
    for (int e = g.start[v]; e < g.start[v + 1]; ++e)
      if (level[g.adj[e]] < 0) {
        level[g.adj[e]] = level[v] + 1;
        queue.push_back(g.adj[e]);
      }
  }
  return level[queue.back()] + 1;
}

// part[v] = 0 or 1 for the two halves, 2 for the separator; all 0 when no useful separator is found.
std::vector<int> split_graph(const Graph& g, int n) {
  std::vector<int> part(n, 0);
  std::vector<int> level(n), queue;
  queue.reserve(n);
  // Pseudo-peripheral root (George & Liu): move to a least-degree vertex of the last level while that
  // lengthens the level structure.
  int root = 0;
  int depth = bfs_levels(g, root, level, queue);
  for (int round = 0; round < 8; ++round) {
    int candidate = queue.back();
    for (int q = static_cast<int>(queue.size()) - 1; q >= 0 && level[queue[q]] == depth - 1; --q)
      if (g.degree(queue[q]) < g.degree(candidate)) candidate = queue[q];
    std::vector<int> candidate_level(n);
    std::vector<int> candidate_queue;
    candidate_queue.reserve(n);
    const int candidate_depth = bfs_levels(g, candidate, candidate_level, candidate_queue);
    if (candidate_depth <= depth) break;
    root = candidate;
    depth = candidate_depth;
    level.swap(candidate_level);
    queue.swap(candidate_queue);
  }
  // Too shallow to split, or the root's component holds less than half the vertices.
  if (depth < 3 || 2 * static_cast<int>(queue.size()) < n) return part;
  // The separator is the level where the count of vertices (in BFS order, level by level) crosses half.
  const int reached = static_cast<int>(queue.size());
  const int sep = level[queue[reached / 2]];
  int count[3] = {0, 0, 0};
  for (int v : queue) {
    part[v] = level[v] < sep ? 0 : level[v] > sep ? 1 : 2;
    ++count[part[v]];
  }
  // Vertices of other components touch neither part: they join the smaller one.
  const int rest = count[0] <= count[1] ? 0 : 1;
  for (int v = 0; v < n; ++v)
    if (level[v] < 0) {
      part[v] = rest;
      ++count[rest];
    }
  if (count[0] == 0 || count[1] == 0 || count[2] > n / 4) std::fill(part.begin(), part.end(), 0);
  return part;
}

// AMD order (old indices) of the vertices `members` of A, restricted to their submatrix.
std::vector<int> amd_order(const Eigen::SparseMatrix<double>& a, const std::vector<int>& members,
                           std::vector<int>& local) {
  const int m = static_cast<int>(members.size());
  if (m <= 1) return members;
  for (int k = 0; k < m; ++k) local[members[k]] = k;
  std::vector<Eigen::Triplet<double>> trip;
  for (int k = 0; k < m; ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(a, members[k]); it; ++it)
      if (local[it.row()] >= 0) trip.emplace_back(local[it.row()], k, 1.0);
  Eigen::SparseMatrix<double> sub(m, m);
  sub.setFromTriplets(trip.begin(), trip.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> new_to_old;
  Eigen::AMDOrdering<int>()(sub, new_to_old);  // indices()[new] = old (Eigen's m_Pinv)
  std::vector<int> order(m);
  for (int k = 0; k < m; ++k) order[k] = members[new_to_old.indices()[k]];
  for (int v : members) local[v] = -1;
  return order;
}

}  // namespace

bool SplitCholesky::fail(const char* why) {
  // Leaves an empty factor: solve() refuses it instead of reading arrays of another size.
  *this = SplitCholesky();
  error_ = why;
  return false;
}

void SplitCholesky::copy_factor(const Eigen::SparseMatrix<double>& l) {
  // L's diagonal apart, its strictly lower entries column by column in Eigen's order (rows ascending).
  diag_.assign(n_, 0.0);
  start_.assign(n_ + 1, 0);
  row_.clear();
  value_.clear();
  row_.reserve(l.nonZeros());
  value_.reserve(l.nonZeros());
  for (int j = 0; j < n_; ++j) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(l, j); it; ++it) {
      if (it.row() == j) {
        diag_[j] = it.value();
      } else {
        row_.push_back(static_cast<int>(it.row()));
        value_.push_back(it.value());
      }
    }
    start_[j + 1] = static_cast<int>(row_.size());
  }
}

bool SplitCholesky::compute(const Eigen::SparseMatrix<double>& a) {
  ok_ = false;
  error_.clear();
  n_ = static_cast<int>(a.rows());
  if (a.cols() != n_) return fail("matrix is not square");
  std::vector<int> part(n_, 0);
  if (n_ >= kMinSplit) part = split_graph(graph_of(a), n_);
  std::vector<int> members[3];
  for (int v = 0; v < n_; ++v) members[part[v]].push_back(v);
  end0_ = static_cast<int>(members[0].size());
  end1_ = end0_ + static_cast<int>(members[1].size());
  if (end0_ == n_) {
    // Not split: Eigen's own factorisation (AMD order) and, in solve(), its substitutions' operations, so the
    // solve has the bits of SimplicialLLT::solve.
    const Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt(a);
    if (llt.info() != Eigen::Success) return fail("matrix is not positive definite");
    const auto& pinv = llt.permutationPinv().indices();  // [new] = old
    old_of_new_.assign(pinv.data(), pinv.data() + pinv.size());
    if (old_of_new_.empty())
      for (int k = 0; k < n_; ++k) old_of_new_.push_back(k);
    copy_factor(llt.matrixL().nestedExpression());
  } else {
    std::vector<int> local(n_, -1);
    old_of_new_.clear();
    old_of_new_.reserve(n_);
    for (const auto& m : members) {
      const std::vector<int> order = amd_order(a, m, local);
      old_of_new_.insert(old_of_new_.end(), order.begin(), order.end());
    }
    std::vector<int> new_of_old(n_);
    for (int k = 0; k < n_; ++k) new_of_old[old_of_new_[k]] = k;
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(a.nonZeros());
    for (int j = 0; j < n_; ++j)
      for (Eigen::SparseMatrix<double>::InnerIterator it(a, j); it; ++it)
        trip.emplace_back(new_of_old[it.row()], new_of_old[j], it.value());
    Eigen::SparseMatrix<double> permuted(n_, n_);
    permuted.setFromTriplets(trip.begin(), trip.end());
    const Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> llt(
        permuted);
    if (llt.info() != Eigen::Success) return fail("matrix is not positive definite");
    copy_factor(llt.matrixL().nestedExpression());
  }
  y_.assign(3 * static_cast<size_t>(n_), 0.0);
  for (auto& buffer : s_buffer_) buffer.assign(3 * static_cast<size_t>(n_ - end1_), 0.0);
  ok_ = true;
  return true;
}

long SplitCholesky::entries_joining_the_parts() const {
  long count = 0;
  for (int j = 0; j < end0_; ++j)
    for (int k = start_[j]; k < start_[j + 1]; ++k) count += row_[k] >= end0_ && row_[k] < end1_;
  return count;
}

void SplitCholesky::forward(int begin, int end, double* y, double* s_rows) const {
  // Column-oriented L y = b over columns [begin, end); updates of S's rows go to s_rows when given. The
  // operations are Eigen's (divide by L_jj, then subtract L_ij y_j), so an unsplit factor solves bit for bit
  // like SimplicialLLT.
  for (int j = begin; j < end; ++j) {
    double* yj = y + 3 * static_cast<size_t>(j);
    const double d = diag_[j];
    const double y0 = yj[0] / d, y1 = yj[1] / d, y2 = yj[2] / d;
    yj[0] = y0;
    yj[1] = y1;
    yj[2] = y2;
    for (int k = start_[j]; k < start_[j + 1]; ++k) {
      const int i = row_[k];
      const double l = value_[k];
      double* yi =
          s_rows && i >= end1_ ? s_rows + 3 * static_cast<size_t>(i - end1_) : y + 3 * static_cast<size_t>(i);
      yi[0] -= l * y0;
      yi[1] -= l * y1;
      yi[2] -= l * y2;
    }
  }
}

void SplitCholesky::backward(int begin, int end, double* y) const {
  // Lᵀ x = y over columns [begin, end), last first; x overwrites y. Reads rows below, already solved.
  for (int j = end - 1; j >= begin; --j) {
    double* yj = y + 3 * static_cast<size_t>(j);
    double r0 = yj[0], r1 = yj[1], r2 = yj[2];
    for (int k = start_[j]; k < start_[j + 1]; ++k) {
      const double* yi = y + 3 * static_cast<size_t>(row_[k]);
      const double l = value_[k];
      r0 -= l * yi[0];
      r1 -= l * yi[1];
      r2 -= l * yi[2];
    }
    const double d = diag_[j];
    yj[0] = r0 / d;
    yj[1] = r1 / d;
    yj[2] = r2 / d;
  }
}

void SplitCholesky::solve(const Eigen::MatrixX3d& b, Eigen::MatrixX3d& x, int threads) {
  if (!ok_ || b.rows() != n_)
    throw std::logic_error(!ok_ ? "SplitCholesky::solve without a factor"
                                : "SplitCholesky::solve: wrong row count");
  const int n = n_;
  const bool split = end1_ < n;
  const bool parallel = threads > 1 && split;
  double* y = y_.data();
#pragma omp parallel for num_threads(2) if (parallel) schedule(static)
  for (int k = 0; k < n; ++k)
    for (int c = 0; c < 3; ++c) y[3 * static_cast<size_t>(k) + c] = b(old_of_new_[k], c);
  if (!split) {
    forward(0, n, y, nullptr);
    backward(0, n, y);
  } else {
    const int begin[2] = {0, end0_}, end[2] = {end0_, end1_};
#pragma omp parallel for num_threads(2) if (parallel) schedule(static, 1)
    for (int p = 0; p < 2; ++p) {
      std::fill(s_buffer_[p].begin(), s_buffer_[p].end(), 0.0);
      forward(begin[p], end[p], y, s_buffer_[p].data());
    }
    // S's rows: b_S, then part 0's updates, then part 1's (a fixed order: the same bits on any thread count).
    double* ys = y + 3 * static_cast<size_t>(end1_);
    for (size_t k = 0; k < s_buffer_[0].size(); ++k) ys[k] = (ys[k] + s_buffer_[0][k]) + s_buffer_[1][k];
    forward(end1_, n, y, nullptr);
    backward(end1_, n, y);
#pragma omp parallel for num_threads(2) if (parallel) schedule(static, 1)
    for (int p = 0; p < 2; ++p) backward(begin[p], end[p], y);
  }
  x.resize(n, 3);
#pragma omp parallel for num_threads(2) if (parallel) schedule(static)
  for (int k = 0; k < n; ++k)
    for (int c = 0; c < 3; ++c) x(old_of_new_[k], c) = y[3 * static_cast<size_t>(k) + c];
}

}  // namespace loom::cloth
