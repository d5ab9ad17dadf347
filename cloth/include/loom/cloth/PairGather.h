#pragma once
// PairGather: deterministic per-vertex sums of per-pair forces. A pair term computes the force on end i of
// every pair (in parallel), then each vertex adds the forces of its incident pairs in a fixed order (+ for
// end i, - for end j), so results are bit-identical for any thread count.
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::cloth {

class PairGather {
 public:
  PairGather() = default;
  // `pairs` is any vector of structs with int members i and j.
  template <class Pair>
  PairGather(int num_vertices, const std::vector<Pair>& pairs) {
    start_.assign(num_vertices + 1, 0);
    for (const Pair& p : pairs) {
      ++start_[p.i + 1];
      ++start_[p.j + 1];
    }
    for (int i = 0; i < num_vertices; ++i) start_[i + 1] += start_[i];
    incident_.resize(start_[num_vertices]);
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    for (int s = 0; s < static_cast<int>(pairs.size()); ++s) {
      incident_[fill[pairs[s].i]++] = 2 * s;
      incident_[fill[pairs[s].j]++] = 2 * s + 1;
    }
  }

  int num_vertices() const { return static_cast<int>(start_.size()) - 1; }

  // Sum over the pairs incident to vertex i of ±pair_force (the force on each pair's end i).
  Vec3 sum(int i, const Vec3s& pair_force) const {
    Vec3 acc = Vec3::Zero();
    for (int q = start_[i]; q < start_[i + 1]; ++q) {
      const int e = incident_[q];
      if (e & 1)
        acc -= pair_force[e >> 1];
      else
        acc += pair_force[e >> 1];
    }
    return acc;
  }

 private:
  std::vector<int> start_;     // CSR over vertices
  std::vector<int> incident_;  // pair index * 2 + (1 if the vertex is end j)
};

}  // namespace loom::cloth
