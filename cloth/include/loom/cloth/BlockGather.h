#pragma once
// BlockGather: parallel, deterministic assembly of per-element 3x3 blocks into a BlockMatrix, without
// atomics. A term computes its element blocks in parallel into a source array; the gather then walks the
// matrix row by row (rows split statically over threads) and adds to each stored block the sources that land
// on it, in the order the term listed them. A block's additions are thus the same floating-point operations
// in the same order as a serial "for each element: block(i, j) += ±source" loop: the result is bit-identical
// to that loop for any thread count. The slot lists are built once per matrix pattern
// (BlockMatrix::pattern_id()) and reused while the pattern and the number of sources stay the same.
#include <cstdint>
#include <utility>
#include <vector>

#include "loom/cloth/BlockMatrix.h"

namespace loom::cloth {

class BlockGather {
 public:
  // True if the slot lists were built for m's pattern and `sources` source blocks.
  bool ready(const BlockMatrix& m, int sources) const {
    return id_ != 0 && id_ == m.pattern_id() && sources_ == sources && n_ == m.size();
  }

  // Rebuilds the slot lists. `each(emit)` must call emit(i, j, source, negate) for every contribution, in the
  // order a serial assembly would add them: block (i, j) receives source[source] (negated if `negate`). (i,
  // j) must be in m's pattern.
  template <class Each>
  void build(const BlockMatrix& m, int sources, const Each& each) {
    std::vector<std::pair<int, int>> contrib;  // (slot, source * 2 + negate), in emit order
    const Mat3* base = m.blocks().data();
    each([&](int i, int j, int source, bool negate) {
      const Mat3* b = m.find(i, j);
      contrib.emplace_back(static_cast<int>(b - base), 2 * source + (negate ? 1 : 0));
    });
    // Stable counting sort by slot: each slot keeps its contributions in emit order.
    start_.assign(m.num_blocks() + 1, 0);
    for (const auto& c : contrib) ++start_[c.first + 1];
    for (int k = 0; k < m.num_blocks(); ++k) start_[k + 1] += start_[k];
    entry_.resize(contrib.size());
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    for (const auto& c : contrib) entry_[fill[c.first]++] = c.second;
    id_ = m.pattern_id();
    sources_ = sources;
    n_ = m.size();
  }

  // m.blocks()[slot] += ±source[...] for every listed contribution (ready() must hold).
  void add(BlockMatrix& m, const std::vector<Mat3>& source, int threads) const {
    const int n = m.size();
    const auto& rs = m.row_start();
    auto& blocks = m.blocks();
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
    for (int i = 0; i < n; ++i)
      for (int k = rs[i]; k < rs[i + 1]; ++k) {
        if (start_[k] == start_[k + 1]) continue;
        Mat3 acc = blocks[k];
        for (int q = start_[k]; q < start_[k + 1]; ++q) {
          const int e = entry_[q];
          if (e & 1)
            acc -= source[e >> 1];
          else
            acc += source[e >> 1];
        }
        blocks[k] = acc;
      }
  }

 private:
  std::uint64_t id_ = 0;
  int sources_ = -1;
  int n_ = -1;
  std::vector<int> start_;  // per stored block of the pattern: its contributions are entry_[start_[k] ..)
  std::vector<int> entry_;  // source index * 2 + 1 if negated
};

}  // namespace loom::cloth
