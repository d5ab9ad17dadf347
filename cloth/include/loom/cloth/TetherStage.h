#pragma once
// Long-range attachments (Kim, Chentanez & Müller-Fischer 2012, "Long range attachments"), as a pipeline
// stage after the solver, usable with any solver. Each free vertex is tethered to its nearest kinematic
// (pinned) vertex; the tether is an inequality |x_i - x_a| <= (1 + slack) D_i, with D_i the rest distance:
// geodesic (shortest path along the structural, shear and edge springs at rest, Dijkstra from all pinned
// vertices at once) or euclidean (straight line at rest). A vertex outside its sphere is projected onto it
// (the anchor does not move) and its velocity is recomputed, v = (x_corr - x_prev) / h.
// Tethers are built at the first step from the vertices that are kinematic then.
#include <vector>

#include "loom/cloth/Stage.h"

namespace loom::cloth {

struct TetherSettings {
  double slack = 0.0;    // 1, allowed extra length relative to the rest distance
  bool geodesic = true;  // rest distance along the mesh (true) or straight (false)
};

struct Tether {
  int vertex = 0, anchor = 0;
  double length = 0.0;  // m, (1 + slack) D
};

class TetherStage final : public Stage {
 public:
  explicit TetherStage(TetherSettings settings) : settings_(settings) {}
  const char* name() const override { return "tethers"; }
  void run(StageContext& ctx) override;
  // tethers: number of tethers (all cloths); corrections: projections since the start.
  std::vector<std::pair<std::string, double>> counters() const override;
  // The tethers of a cloth (after the first step); exposed for tests.
  const std::vector<Tether>& tethers(size_t cloth) const { return tethers_[cloth]; }

 private:
  void build(const Cloth& cloth, std::vector<Tether>& out) const;

  TetherSettings settings_;
  std::vector<std::vector<Tether>> tethers_;  // per cloth
  long corrections_ = 0;
};

}  // namespace loom::cloth
