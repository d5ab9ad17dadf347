#pragma once
// ElementGather: deterministic per-vertex sums of per-element vertex forces, for elements with K vertices
// (triangles: 3, hinges: 4). A term computes the force on each corner of every element in parallel into
// a scratch array (element e, corner k at index K e + k), then each vertex adds its corners in a fixed
// order, so results are bit-identical for any thread count (the same scheme as PairGather).
#include <array>
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::cloth {

class ElementGather {
 public:
  ElementGather() = default;
  template <size_t K>
  ElementGather(int num_vertices, const std::vector<std::array<int, K>>& elements) {
    start_.assign(num_vertices + 1, 0);
    for (const auto& e : elements)
      for (int v : e) ++start_[v + 1];
    for (int i = 0; i < num_vertices; ++i) start_[i + 1] += start_[i];
    slot_.resize(start_[num_vertices]);
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    for (size_t e = 0; e < elements.size(); ++e)
      for (size_t k = 0; k < K; ++k) slot_[fill[elements[e][k]]++] = static_cast<int>(K * e + k);
  }

  // Sum over the corners of vertex i of corner_force[K e + k].
  Vec3 sum(int i, const Vec3s& corner_force) const {
    Vec3 acc = Vec3::Zero();
    for (int q = start_[i]; q < start_[i + 1]; ++q) acc += corner_force[slot_[q]];
    return acc;
  }

 private:
  std::vector<int> start_;  // CSR over vertices
  std::vector<int> slot_;   // K * element + corner
};

}  // namespace loom::cloth
