#include "loom/cloth/StrainLimitStage.h"

namespace loom::cloth {

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
        const double l = d.norm();
        const double l_max = stretch * sp.rest_length;
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
      if ((s.x[sp.j] - s.x[sp.i]).norm() > stretch * sp.rest_length * (1.0 + 1e-9)) ++remaining_;
    }
  }
}

std::vector<std::pair<std::string, double>> StrainLimitStage::counters() const {
  return {{"corrections", static_cast<double>(corrections_)},
          {"remaining_violations", static_cast<double>(remaining_)}};
}

}  // namespace loom::cloth
