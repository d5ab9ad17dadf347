#include "loom/cloth/StrainLimitStage.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

namespace loom::cloth {

namespace {
constexpr double kSkip = 1.0 - 1e-9;  // 1, squared-length margin below which a spring is within the limit

// Provot 1995: moves the ends of spring (i, j) of rest length `rest` along it, in the ratio of the inverse
// masses wi, wj, so that l = stretch x rest when it is longer; returns whether it moved them (moved[v] =
// sweep + 1 for each end moved). Most springs are well within the limit: a squared test with a margin skips
// their square root (the exact test decides the rest, so the result does not depend on the shortcut).
bool clamp_spring(ClothState& s, int i, int j, double rest, double wi, double wj, double stretch, int sweep,
                  std::vector<int>& moved) {
  if (wi + wj == 0.0) return false;
  const Vec3 d = s.x[j] - s.x[i];
  const double l_max = stretch * rest;
  const double l2 = d.squaredNorm();
  if (l2 < kSkip * l_max * l_max) return false;
  const double l = std::sqrt(l2);
  if (l <= l_max) return false;
  const Vec3 corr = ((l - l_max) / ((wi + wj) * l)) * d;
  s.x[i] += wi * corr;
  s.x[j] -= wj * corr;
  if (wi > 0.0) moved[i] = sweep + 1;
  if (wj > 0.0) moved[j] = sweep + 1;
  return true;
}
}  // namespace

std::vector<int> limited_springs(const ClothMesh& mesh) {
  std::vector<int> list;
  const auto& springs = mesh.springs();
  for (int k = 0; k < static_cast<int>(springs.size()); ++k) {
    const SpringKind kind = springs[k].kind;
    if (kind == SpringKind::kStructural || kind == SpringKind::kShear || kind == SpringKind::kEdge)
      list.push_back(k);
  }
  return list;
}

long limit_stretch(const ClothMesh& mesh, const std::vector<int>& list, double max_stretch, int sweeps,
                   const std::vector<char>& held, ClothState& s, std::vector<int>& moved) {
  const auto& springs = mesh.springs();
  const double stretch = 1.0 + max_stretch;
  const int m = static_cast<int>(list.size());
  const bool any_held = !held.empty();
  long corrections = 0;
  for (int it = 0; it < sweeps; ++it) {
    const bool forward = it % 2 == 0;
    long sweep_corrections = 0;
    for (int q = 0; q < m; ++q) {
      const SpringDef& sp = springs[list[forward ? q : m - 1 - q]];
      // A spring the previous sweep left within the limit stays so while neither end moves: after the first
      // sweep only springs with an end moved in the previous sweep or in this one are tested (moved holds
      // 1 + the last sweep that moved the vertex).
      if (it > 0 && moved[sp.i] < it && moved[sp.j] < it) continue;
      double wi = s.inv_mass[sp.i], wj = s.inv_mass[sp.j];
      if (any_held && held[sp.i] != held[sp.j]) (held[sp.i] ? wi : wj) = 0.0;
      if (clamp_spring(s, sp.i, sp.j, sp.rest_length, wi, wj, stretch, it, moved)) ++sweep_corrections;
    }
    corrections += sweep_corrections;
    if (sweep_corrections == 0) break;
  }
  return corrections;
}

OutwardOrder outward_order(const ClothMesh& mesh, const std::vector<int>& list,
                           const std::vector<double>& inv_mass) {
  const auto& springs = mesh.springs();
  const int nv = static_cast<int>(inv_mass.size());
  const int far = std::numeric_limits<int>::max();
  std::vector<int> dist(nv, far), queue;
  for (int i = 0; i < nv; ++i)
    if (inv_mass[i] == 0.0) {
      dist[i] = 0;
      queue.push_back(i);
    }
  OutwardOrder out;
  if (queue.empty()) return out;
  std::vector<std::vector<int>> adj(nv);
  for (int k : list) {
    adj[springs[k].i].push_back(springs[k].j);
    adj[springs[k].j].push_back(springs[k].i);
  }
  for (size_t q = 0; q < queue.size(); ++q)  // breadth-first hop distances
    for (int b : adj[queue[q]])
      if (dist[b] == far) {
        dist[b] = dist[queue[q]] + 1;
        queue.push_back(b);
      }
  out.springs = list;
  auto key = [&](int k) {
    const int a = dist[springs[k].i], b = dist[springs[k].j];
    return std::make_tuple(std::max(a, b), std::min(a, b), k);
  };
  std::sort(out.springs.begin(), out.springs.end(), [&](int x, int y) { return key(x) < key(y); });
  for (int k : out.springs) {
    const int a = dist[springs[k].i], b = dist[springs[k].j];
    out.links.push_back({springs[k].i, springs[k].j, springs[k].rest_length, a < b ? 1 : b < a ? 2 : 0});
  }
  return out;
}

long limit_stretch_outward(const ClothMesh&, const OutwardOrder& order, double max_stretch, int sweeps,
                           ClothState& s, std::vector<int>& moved) {
  const double stretch = 1.0 + max_stretch;
  const int m = static_cast<int>(order.springs.size());
  long corrections = 0;
  for (int it = 0; it < sweeps; ++it) {
    long sweep_corrections = 0;
    for (int q = 0; q < m; ++q) {
      const OutwardOrder::Link& sp = order.links[q];
      const double wi = sp.lead == 1 ? 0.0 : s.inv_mass[sp.i], wj = sp.lead == 2 ? 0.0 : s.inv_mass[sp.j];
      if (clamp_spring(s, sp.i, sp.j, sp.rest_length, wi, wj, stretch, it, moved)) ++sweep_corrections;
    }
    corrections += sweep_corrections;
    if (sweep_corrections == 0) break;
  }
  return corrections;
}

void StrainLimitStage::run(StageContext& ctx) {
  if (limited_.size() != ctx.cloths.size()) {
    limited_.assign(ctx.cloths.size(), {});
    outward_.assign(ctx.cloths.size(), {});
    outward_kinematic_.assign(ctx.cloths.size(), {});
    for (size_t c = 0; c < ctx.cloths.size(); ++c) limited_[c] = limited_springs(ctx.cloths[c]->mesh());
  }
  // The outward order follows the kinematic vertices: rebuilt when a pin is added or released.
  if (settings_.outward)
    for (size_t c = 0; c < ctx.cloths.size(); ++c) {
      const std::vector<double>& w = ctx.cloths[c]->state().inv_mass;
      bool same = outward_kinematic_[c].size() == w.size();
      for (size_t i = 0; i < w.size() && same; ++i) same = (outward_kinematic_[c][i] != 0) == (w[i] == 0.0);
      if (same) continue;
      outward_kinematic_[c].resize(w.size());
      for (size_t i = 0; i < w.size(); ++i) outward_kinematic_[c][i] = w[i] == 0.0;
      outward_[c] = outward_order(ctx.cloths[c]->mesh(), limited_[c], w);
    }
  const double stretch = 1.0 + settings_.max_stretch;
  remaining_ = 0;
  const std::vector<char> none;
  for (size_t c = 0; c < ctx.cloths.size(); ++c) {
    ClothState& s = ctx.cloths[c]->state();
    const auto& springs = ctx.cloths[c]->mesh().springs();
    const std::vector<int>& list = limited_[c];
    moved_.assign(s.size(), 0);
    const bool outward = settings_.outward && !outward_[c].springs.empty();
    if (outward)
      corrections_ += limit_stretch_outward(ctx.cloths[c]->mesh(), outward_[c], settings_.max_stretch,
                                            settings_.iterations, s, moved_);
    else
      corrections_ += limit_stretch(ctx.cloths[c]->mesh(), list, settings_.max_stretch, settings_.iterations,
                                    none, s, moved_);
    // The sweeps stopped early (no vertex moved by the last allowed one, moved_ < iterations everywhere):
    // the last sweep found every spring it tested within the limit and the others have not moved since
    // theirs, so only springs between two kinematic vertices (never corrected) can be above it. The outward
    // sweeps move one end only and make no such promise: their count tests every limited spring.
    bool converged = !outward;
    for (int i = 0; i < s.size(); ++i) {
      if (!moved_[i]) continue;
      s.v[i] = (s.x[i] - s.x_prev[i]) / ctx.h;
      converged = converged && moved_[i] < settings_.iterations;
    }
    if (converged) {
      if (kinematic_.size() != ctx.cloths.size())
        kinematic_.assign(ctx.cloths.size(), {}), kinematic_mass_.assign(ctx.cloths.size(), {});
      if (kinematic_mass_[c] != s.inv_mass) {
        kinematic_mass_[c] = s.inv_mass;
        kinematic_[c].clear();
        for (int k : list)
          if (s.inv_mass[springs[k].i] + s.inv_mass[springs[k].j] == 0.0) kinematic_[c].push_back(k);
      }
    }
    for (int k : converged ? kinematic_[c] : list) {
      const SpringDef& sp = springs[k];
      const double l_max = stretch * sp.rest_length * (1.0 + 1e-9);
      const double l2 = (s.x[sp.j] - s.x[sp.i]).squaredNorm();
      if (l2 >= kSkip * l_max * l_max && std::sqrt(l2) > l_max) ++remaining_;
    }
  }
}

std::vector<std::pair<std::string, double>> StrainLimitStage::counters() const {
  return {{"corrections", static_cast<double>(corrections_)},
          {"remaining_violations", static_cast<double>(remaining_)}};
}

}  // namespace loom::cloth
