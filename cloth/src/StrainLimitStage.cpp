#include "loom/cloth/StrainLimitStage.h"

#include <cmath>

namespace loom::cloth {

namespace {
constexpr double kSkip = 1.0 - 1e-9;  // 1, squared-length margin below which a spring is within the limit
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
      if (wi + wj == 0.0) continue;
      const Vec3 d = s.x[sp.j] - s.x[sp.i];
      const double l_max = stretch * sp.rest_length;
      // Most springs are well within the limit: a squared test with a margin skips their square root
      // (the exact test below decides the rest, so the result does not depend on the shortcut).
      const double l2 = d.squaredNorm();
      if (l2 < kSkip * l_max * l_max) continue;
      const double l = std::sqrt(l2);
      if (l <= l_max) continue;
      if (any_held && held[sp.i] != held[sp.j]) (held[sp.i] ? wi : wj) = 0.0;
      if (wi + wj == 0.0) continue;
      // Provot 1995: move the ends along the spring so that l = (1 + τ) L.
      const Vec3 corr = ((l - l_max) / ((wi + wj) * l)) * d;
      s.x[sp.i] += wi * corr;
      s.x[sp.j] -= wj * corr;
      if (wi > 0.0) moved[sp.i] = it + 1;
      if (wj > 0.0) moved[sp.j] = it + 1;
      ++sweep_corrections;
    }
    corrections += sweep_corrections;
    if (sweep_corrections == 0) break;
  }
  return corrections;
}

void StrainLimitStage::run(StageContext& ctx) {
  if (limited_.size() != ctx.cloths.size()) {
    limited_.assign(ctx.cloths.size(), {});
    for (size_t c = 0; c < ctx.cloths.size(); ++c) limited_[c] = limited_springs(ctx.cloths[c]->mesh());
  }
  const double stretch = 1.0 + settings_.max_stretch;
  remaining_ = 0;
  const std::vector<char> none;
  for (size_t c = 0; c < ctx.cloths.size(); ++c) {
    ClothState& s = ctx.cloths[c]->state();
    const auto& springs = ctx.cloths[c]->mesh().springs();
    const std::vector<int>& list = limited_[c];
    moved_.assign(s.size(), 0);
    corrections_ += limit_stretch(ctx.cloths[c]->mesh(), list, settings_.max_stretch, settings_.iterations,
                                  none, s, moved_);
    // The sweeps stopped early (no vertex moved by the last allowed one, moved_ < iterations everywhere):
    // the last sweep found every spring it tested within the limit and the others have not moved since
    // theirs, so only springs between two kinematic vertices (never corrected) can be above it.
    bool converged = true;
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
