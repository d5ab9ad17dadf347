#pragma once
// IntersectionGuardStage: the intersection side of the non-finite / explosion guard (cloth/Guard.h,
// scene key `guard.intersections`). The pipeline stage "intersection_guard", last (after body and self
// collision and the contact guard). After every step it finds every intersecting triangle pair of the cloths
// at the step's end (`x`): within each cloth the pairs sharing no vertex, between cloths all pairs; exact
// predicates, the very pairs of the census `loom run --census` counts (MultiClothCensus.h). Candidates come
// from one ClothBvh per cloth kept across steps (leaves = the triangles at x, refit every step, rebuilt when
// their quality drops; the pairs found do not depend on the tree).
// A pair the step's start did not have is a violation (Stage::violation(): "cloth intersections: N
// intersecting triangle pairs the step start did not have (cloth 'C': triangles A and B)"), so the guard
// rolls the frame back, retries it with smaller steps and, failing that, stops the run with it. The pairs at
// the start of the run (prime(); an input that is already tangled) and at the end of every accepted step are
// the next step's allowance, so a run that starts clean must stay at 0 pairs after every step.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "loom/cloth/Cloth.h"
#include "loom/cloth/Stage.h"
#include "loom/collision/ClothBvh.h"
#include "loom/collision/MultiClothCensus.h"

namespace loom::collision {

class IntersectionGuardStage final : public cloth::Stage {
 public:
  const char* name() const override { return "intersection_guard"; }
  // The pairs of the cloths as they are now (the start of the run): allowed in the first step. Without it
  // the first step is allowed none.
  void prime(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths, int threads);
  void run(cloth::StageContext& ctx) override;
  std::string violation() const override { return violation_; }
  // pairs: intersecting pairs at the end of the last step; worst_new: most new pairs in one step (rejected
  // steps included); steps; violations: rejected steps.
  std::vector<std::pair<std::string, double>> counters() const override;
  void save_state(cloth::StateWriter& out) const override;
  void load_state(cloth::StateReader& in) override;
  const std::vector<IntersectingPair>& pairs() const { return pairs_; }

 private:
  std::vector<IntersectingPair> find(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths, int threads);

  std::vector<std::unique_ptr<ClothBvh>> trees_;  // one per cloth; not state (the pairs do not depend on it)
  std::vector<IntersectingPair> pairs_;           // at the end of the last step (the next step's allowance)
  std::string violation_;                         // of the last step
  long steps_ = 0, violations_ = 0, worst_new_ = 0;
};

}  // namespace loom::collision
