// The guard's intersection check (IntersectionGuardStage.h).
#include "loom/collision/IntersectionGuardStage.h"

#include <algorithm>
#include <cstdint>
#include <iterator>

#include "loom/cloth/Error.h"

namespace loom::collision {
namespace {

// m, contour clearance of the normal-cone culling (MultiClothCensus.h): a patch whose projected contour
// comes closer to itself than this is checked pair by pair.
constexpr double kConeMargin = 1e-6;

}  // namespace

std::vector<IntersectingPair> IntersectionGuardStage::find(
    const std::vector<std::unique_ptr<cloth::Cloth>>& cloths, int threads) {
  std::vector<CensusInput> in;
  std::vector<const ClothBvh*> trees;
  const bool fresh = trees_.size() != cloths.size();
  if (fresh) trees_.clear();
  for (size_t i = 0; i < cloths.size(); ++i) {
    const cloth::Vec3s& x = cloths[i]->state().x;
    in.push_back({&cloths[i]->mesh(), &x});
    if (fresh) {
      trees_.push_back(std::make_unique<ClothBvh>(cloths[i]->mesh_ptr()));
      trees_.back()->rebuild(x, x, 0.0, threads);
    } else {
      trees_[i]->update(x, x, 0.0, threads);
    }
    trees.push_back(trees_[i].get());
  }
  return intersecting_pairs(in, trees, threads, kConeMargin);
}

void IntersectionGuardStage::prime(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths, int threads) {
  pairs_ = find(cloths, threads);
}

void IntersectionGuardStage::run(cloth::StageContext& ctx) {
  ++steps_;
  violation_.clear();
  for (const auto& c : ctx.cloths)
    if (!c->state().is_finite())
      return;  // the guard rejects the step anyway; the predicates need finite input
  std::vector<IntersectingPair> now = find(ctx.cloths, ctx.threads);
  std::vector<IntersectingPair> added;
  std::set_difference(now.begin(), now.end(), pairs_.begin(), pairs_.end(), std::back_inserter(added));
  worst_new_ = std::max(worst_new_, static_cast<long>(added.size()));
  if (!added.empty()) {
    ++violations_;
    const IntersectingPair& p = added.front();
    const std::string& a = ctx.cloths[p.cloth_a]->name();
    const std::string where =
        p.cloth_a == p.cloth_b
            ? "cloth '" + a + "': triangles " + std::to_string(p.tri_a) + " and " + std::to_string(p.tri_b)
            : "triangle " + std::to_string(p.tri_a) + " of cloth '" + a + "' and triangle " +
                  std::to_string(p.tri_b) + " of cloth '" + ctx.cloths[p.cloth_b]->name() + "'";
    violation_ = "cloth intersections: " + std::to_string(added.size()) + " intersecting triangle pair" +
                 (added.size() == 1 ? "" : "s") + " the step start did not have (" + where + ")";
  }
  pairs_ = std::move(now);  // a rejected step is rolled back with the state (load_state)
}

std::vector<std::pair<std::string, double>> IntersectionGuardStage::counters() const {
  return {{"pairs", static_cast<double>(pairs_.size())},
          {"worst_new", static_cast<double>(worst_new_)},
          {"steps", static_cast<double>(steps_)},
          {"violations", static_cast<double>(violations_)}};
}

void IntersectionGuardStage::save_state(cloth::StateWriter& out) const {
  out.tag("intersection_guard");
  out.i64(static_cast<long>(pairs_.size()));
  for (const IntersectingPair& p : pairs_) {
    out.i64(p.cloth_a);
    out.i64(p.tri_a);
    out.i64(p.cloth_b);
    out.i64(p.tri_b);
  }
}

void IntersectionGuardStage::load_state(cloth::StateReader& in) {
  in.tag("intersection_guard");
  const std::int64_t n = in.i64();
  if (n < 0) throw Error(in.source(), "intersection_guard", "negative pair count " + std::to_string(n));
  pairs_.clear();
  for (std::int64_t k = 0; k < n; ++k) {  // each read checks that the archive holds it
    IntersectingPair p;
    p.cloth_a = static_cast<int>(in.i64());
    p.tri_a = static_cast<int>(in.i64());
    p.cloth_b = static_cast<int>(in.i64());
    p.tri_b = static_cast<int>(in.i64());
    pairs_.push_back(p);
  }
  violation_.clear();
}

}  // namespace loom::collision
