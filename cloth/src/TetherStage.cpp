#include "loom/cloth/TetherStage.h"

#include <functional>
#include <limits>
#include <queue>

namespace loom::cloth {

void TetherStage::build(const Cloth& cloth, std::vector<Tether>& out) const {
  const ClothState& s = cloth.state();
  const Vec3s& rest = cloth.mesh().rest_positions();
  const int n = s.size();
  std::vector<int> pinned;
  for (int i = 0; i < n; ++i)
    if (s.inv_mass[i] == 0.0) pinned.push_back(i);
  out.clear();
  if (pinned.empty()) return;
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> dist(n, inf);
  std::vector<int> anchor(n, -1);
  if (settings_.geodesic) {
    // Multi-source Dijkstra over the rest mesh (structural, shear and edge springs).
    std::vector<std::vector<std::pair<int, double>>> adj(n);
    for (const SpringDef& d : cloth.mesh().springs())
      if (d.kind == SpringKind::kStructural || d.kind == SpringKind::kShear || d.kind == SpringKind::kEdge) {
        adj[d.i].emplace_back(d.j, d.rest_length);
        adj[d.j].emplace_back(d.i, d.rest_length);
      }
    using Item = std::pair<double, int>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
    for (int p : pinned) {
      dist[p] = 0.0;
      anchor[p] = p;
      queue.emplace(0.0, p);
    }
    while (!queue.empty()) {
      const auto [d, i] = queue.top();
      queue.pop();
      if (d > dist[i]) continue;
      for (const auto& [j, w] : adj[i])
        if (d + w < dist[j]) {
          dist[j] = d + w;
          anchor[j] = anchor[i];
          queue.emplace(dist[j], j);
        }
    }
  } else {
    for (int i = 0; i < n; ++i)
      for (int p : pinned) {
        const double d = (rest[i] - rest[p]).norm();
        if (d < dist[i]) {
          dist[i] = d;
          anchor[i] = p;
        }
      }
  }
  for (int i = 0; i < n; ++i)
    if (s.inv_mass[i] > 0.0 && anchor[i] >= 0)
      out.push_back({i, anchor[i], (1.0 + settings_.slack) * dist[i]});
}

void TetherStage::run(StageContext& ctx) {
  if (tethers_.size() != ctx.cloths.size()) {
    tethers_.assign(ctx.cloths.size(), {});
    for (size_t c = 0; c < ctx.cloths.size(); ++c) build(*ctx.cloths[c], tethers_[c]);
  }
  for (size_t c = 0; c < ctx.cloths.size(); ++c) {
    ClothState& s = ctx.cloths[c]->state();
    for (const Tether& t : tethers_[c]) {
      // Kim et al. 2012: project onto the sphere of radius `length` around the anchor when outside it.
      const Vec3 d = s.x[t.vertex] - s.x[t.anchor];
      const double l = d.norm();
      if (l <= t.length) continue;
      s.x[t.vertex] = s.x[t.anchor] + d * (t.length / l);
      s.v[t.vertex] = (s.x[t.vertex] - s.x_prev[t.vertex]) / ctx.h;
      ++corrections_;
    }
  }
}

std::vector<std::pair<std::string, double>> TetherStage::counters() const {
  long count = 0;
  for (const auto& t : tethers_) count += static_cast<long>(t.size());
  return {{"tethers", static_cast<double>(count)}, {"corrections", static_cast<double>(corrections_)}};
}

}  // namespace loom::cloth
