#pragma once
// BlockScatter: adds per-element 3x3 blocks into a BlockMatrix without a search per block. It remembers the
// storage slot of every (element, row, column) block and checks it on every use (the slot must lie in the
// row and hold the column), falling back to BlockMatrix::find when the matrix's pattern differs; so one
// cache serves every matrix built from the same pattern (K, D and A of an implicit solver).
#include <vector>

#include "loom/cloth/BlockMatrix.h"

namespace loom::cloth {

class BlockScatter {
 public:
  // Adds `block` at (i, j); q numbers the block within the term (0 .. count-1), the same every call.
  void add(BlockMatrix& m, int q, int i, int j, const Mat3& block) {
    if (q >= static_cast<int>(slots_.size())) slots_.resize(q + 1, -1);
    int s = slots_[q];
    const auto& rs = m.row_start();
    if (s < rs[i] || s >= rs[i + 1] || m.cols()[s] != j) {
      s = static_cast<int>(&m.block(i, j) - m.blocks().data());
      slots_[q] = s;
    }
    m.blocks()[s] += block;
  }

 private:
  std::vector<int> slots_;
};

}  // namespace loom::cloth
