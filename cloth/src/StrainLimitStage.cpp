#include "loom/cloth/StrainLimitStage.h"

#include <cmath>

namespace loom::cloth {

namespace {
constexpr double kSkip = 1.0 - 1e-9;  // 1, squared-length margin below which a spring is within the limit
}  // namespace

void StrainLimitStage::run(StageContext& ctx) {
  if (limited_.size() != ctx.cloths.size()) {
    limited_.assign(ctx.cloths.size(), {});
    for (size_t c = 0; c < ctx.cloths.size(); ++c) {
      const auto& springs = ctx.cloths[c]->mesh().springs();
      for (int k = 0; k < static_cast<int>(springs.size()); ++k) {
        const SpringKind kind = springs[k].kind;
        if (kind == SpringKind::kStructural || kind == SpringKind::kShear || kind == SpringKind::kEdge)
          limited_[c].push_back(k);
      }
    }
  }
  const double stretch = 1.0 + settings_.max_stretch;
  remaining_ = 0;
  for (size_t c = 0; c < ctx.cloths.size(); ++c) {
    ClothState& s = ctx.cloths[c]->state();
    const auto& springs = ctx.cloths[c]->mesh().springs();
    const std::vector<int>& list = limited_[c];
    const int m = static_cast<int>(list.size());
    moved_.assign(s.size(), 0);
    for (int it = 0; it < settings_.iterations; ++it) {
      const bool forward = it % 2 == 0;
      for (int q = 0; q < m; ++q) {
        const SpringDef& sp = springs[list[forward ? q : m - 1 - q]];
        const double wi = s.inv_mass[sp.i], wj = s.inv_mass[sp.j];
        if (wi + wj == 0.0) continue;
        const Vec3 d = s.x[sp.j] - s.x[sp.i];
        const double l_max = stretch * sp.rest_length;
        // Most springs are well within the limit: a squared test with a margin skips their square root
        // (the exact test below decides the rest, so the result does not depend on the shortcut).
        const double l2 = d.squaredNorm();
        if (l2 < kSkip * l_max * l_max) continue;
        const double l = std::sqrt(l2);
        if (l <= l_max) continue;
        // Provot 1995: move the ends along the spring so that l = (1 + τ) L.
        const Vec3 corr = ((l - l_max) / ((wi + wj) * l)) * d;
        s.x[sp.i] += wi * corr;
        s.x[sp.j] -= wj * corr;
        moved_[sp.i] |= wi > 0.0;
        moved_[sp.j] |= wj > 0.0;
        ++corrections_;
      }
    }
    for (int i = 0; i < s.size(); ++i)
      if (moved_[i]) s.v[i] = (s.x[i] - s.x_prev[i]) / ctx.h;
    for (int k : list) {
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
