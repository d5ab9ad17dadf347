#pragma once
// ClothBvh: the cloth's bounding-volume hierarchy for self- and cloth-cloth collision
// (docs/collision.md). An AABB tree over the triangles, built in material (rest) space as in PSCC
// (Tang et al., I3D 2018), so grouping stays patch-coherent under deformation; leaves are swept boxes of
// x_t and x_t+1 inflated by the thickness; refit every step (leaves in parallel, then parents bottom-up);
// rebuilt from the current positions when its summed node surface area grows past `rebuild_ratio` times the
// value after the last (re)build (Lauterbach et al. 2006), or after `rebuild_every` steps.
// Normal cones (Volino & Magnenat-Thalmann 1994; Provot 1997; continuous form as in Tang et al. 2009): every
// node keeps a cone that holds the normal of each of its triangles at every t of the step (the normal of a
// linearly moving triangle is a quadratic in t whose Bernstein coefficients the leaf cone contains).
// self_pairs_culled() skips a node's internal pairs when its patch cannot touch itself during the step: the
// patch is edge-connected, its cone's half-angle is below 90 degrees (so at every t it is a height field over
// the cone axis) and its contour, projected along the axis, stays simple over the whole step (no two contour
// edges sharing no vertex come closer than `margin` in projection, bounded through their motion).
#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "loom/cloth/ClothMesh.h"

namespace loom::collision {

using loom::cloth::Vec3;
using loom::cloth::Vec3s;

struct Aabb {
  Vec3 lo = Vec3::Constant(HUGE_VAL);   // m
  Vec3 hi = Vec3::Constant(-HUGE_VAL);  // m
  void grow(const Vec3& p) { lo = lo.cwiseMin(p), hi = hi.cwiseMax(p); }
  void grow(const Aabb& b) { lo = lo.cwiseMin(b.lo), hi = hi.cwiseMax(b.hi); }
  bool overlaps(const Aabb& b) const {
    return (lo.array() <= b.hi.array()).all() && (b.lo.array() <= hi.array()).all();
  }
  // Overlap after inflating this box by `margin` (m) on every side.
  bool overlaps_within(const Aabb& b, double margin) const {
    return (lo.array() - margin <= b.hi.array()).all() && (b.lo.array() <= hi.array() + margin).all();
  }
  // m: the largest gap between the two boxes along an axis (<= 0 when they overlap), a lower bound on the
  // distance between any point of one and any point of the other.
  double gap(const Aabb& b) const { return std::max((lo - b.hi).maxCoeff(), (b.lo - hi).maxCoeff()); }
  double surface_area() const;  // m^2
};

struct ClothBvhSettings {
  double rebuild_ratio = 1.5;  // 1; rebuild when summed surface area > ratio x the value after the last build
  int rebuild_every = 100;     // steps; rebuild at least this often (0: never by count)
};

using TrianglePair = std::pair<int, int>;  // (i, j), i < j

class ClothBvh {
 public:
  // Builds the tree over the mesh's rest positions (material space); boxes are the rest triangles.
  explicit ClothBvh(std::shared_ptr<const loom::cloth::ClothMesh> mesh, ClothBvhSettings settings = {});

  // Leaf boxes = box(triangle at x0, triangle at x1) inflated by thickness (m); parents refitted. With
  // `cones` false only the boxes are refitted (queries within a step need no cones): the cones are then
  // marked stale and no node is culled until the next refit with cones.
  void refit(const Vec3s& x0, const Vec3s& x1, double thickness, int threads = 1, bool cones = true);
  // New topology from the triangle centroids at x1, then refit.
  void rebuild(const Vec3s& x0, const Vec3s& x1, double thickness, int threads = 1);
  // One step's update: refit, and rebuild if the quality dropped or rebuild_every steps passed. Returns
  // whether it rebuilt.
  bool update(const Vec3s& x0, const Vec3s& x1, double thickness, int threads = 1);

  // Pairs of distinct triangles whose leaf boxes overlap, sorted; with skip_adjacent, pairs that share a
  // vertex are left out. No culling: the reference (census, tests).
  std::vector<TrianglePair> self_pairs(bool skip_adjacent) const;
  // The same pairs minus those inside nodes culled by their normal cone and contour (see above); x0, x1 must
  // be the positions of the last refit, margin (m) the contour clearance. In parallel (top-level subtrees and
  // pairs of subtrees as tasks), sorted. `culled` (optional) receives the number of culled nodes.
  std::vector<TrianglePair> self_pairs_culled(const Vec3s& x0, const Vec3s& x1, double margin,
                                              bool skip_adjacent, int threads = 1,
                                              long* culled = nullptr) const;
  // The same search split into tasks, for callers that consume the pairs as they come (without the sort):
  // {a, a} = pairs below node a, {a, b} = pairs between subtrees a and b. The split does not depend on the
  // thread count, so visiting the tasks in order gives the same pairs in the same order for any thread count.
  // margin < 0: nothing is culled (x0, x1 unused).
  std::vector<std::pair<int, int>> self_pair_tasks(const Vec3s& x0, const Vec3s& x1, double margin,
                                                   long* culled = nullptr) const;
  // The pairs of one task, in traversal order (unsorted), appended to `out`; `culled` counts culled nodes.
  void self_pairs_of_task(std::pair<int, int> task, const Vec3s& x0, const Vec3s& x1, double margin,
                          bool skip_adjacent, std::vector<TrianglePair>& out, long& culled) const;
  // Walks without storing them: `visit(i, j)` is called for each pair of the task (the pairs
  // self_pairs_of_task would append with no culling; margin < 0 in self_pair_tasks culls nothing), in any
  // order, and returns false to end the walk; the walk returns false when it was ended. Memory: the tree's
  // depth, whatever the number of pairs (a census of a cloth piled onto itself meets every pair of it).
  bool walk_self_task(std::pair<int, int> task, bool skip_adjacent,
                      const std::function<bool(int, int)>& visit) const;
  // Tasks covering cross_pairs(other) ({a, b}: leaf pairs below node a of this tree and node b of `other`),
  // about 64 when the trees overlap that much, the same for every thread count; and the walk of one task as
  // above (pairs (i in this tree, j in other)).
  std::vector<std::pair<int, int>> cross_pair_tasks(const ClothBvh& other) const;
  bool walk_cross_task(const ClothBvh& other, std::pair<int, int> task,
                       const std::function<bool(int, int)>& visit) const;
  // Triangles whose leaf box overlaps `box`, sorted.
  std::vector<int> query(const Aabb& box) const;
  // Pairs (i in this tree, j in `other`) whose leaf boxes overlap, sorted: cloth-cloth candidates.
  std::vector<TrianglePair> cross_pairs(const ClothBvh& other) const;

  // The root's box (every leaf box; an empty box for a mesh without triangles).
  Aabb root_box() const { return nodes_.empty() ? Aabb{} : nodes_[0].box; }
  double surface_area_sum() const;  // m^2, over the internal nodes
  // Normal cone of a node (root = 0): unit axis and half-angle (rad, pi when none exists).
  std::pair<Vec3, double> cone(int node) const { return {nodes_[node].axis, nodes_[node].angle}; }
  int num_nodes() const { return static_cast<int>(nodes_.size()); }
  int rebuilds() const { return rebuilds_; }  // rebuilds since construction (the first build not counted)

 private:
  struct Node {
    Aabb box;
    Vec3 axis = Vec3::UnitZ();  // normal cone axis (unit)
    double angle = M_PI;        // rad, normal cone half-angle
    int left = -1, right = -1;  // children (index > this node's), -1 for a leaf
    int triangle = -1;          // leaf: the triangle
    int count = 1;              // triangles below; the subtree is [id, id + 2 count - 1)
    bool connected = true;      // the triangles form one edge-connected patch
  };
  using EdgeKey = std::pair<int, int>;  // vertex pair, first < second
  void build_topology();
  void refit_internal(int id, bool cones);
  bool cullable(int n, const Vec3s& x0, const Vec3s& x1, double margin) const;
  void self_recurse_culled(int n, bool skip_adjacent, const Vec3s& x0, const Vec3s& x1, double margin,
                           std::vector<TrianglePair>& out, long& culled) const;
  void build(const Vec3s& points);
  int build_range(std::vector<int>& tris, const std::vector<Vec3>& centroids, int begin, int end);
  void self_recurse(int n, bool skip_adjacent, std::vector<TrianglePair>& out) const;
  void cross_recurse(int a, int b, bool skip_adjacent, std::vector<TrianglePair>& out) const;
  bool adjacent(int i, int j) const;
  // The two child pairs of nodes a and b (not both leaves) in `out`: the internal one with more triangles
  // (a on a tie) is split, as in cross_recurse.
  static void split_pair(const Node& na, int a, const Node& nb, int b, std::vector<std::pair<int, int>>& out);
  void two_tree_recurse(int a, const ClothBvh& other, int b, std::vector<TrianglePair>& out) const;

  std::shared_ptr<const loom::cloth::ClothMesh> mesh_;
  ClothBvhSettings settings_;
  std::vector<Node> nodes_;   // root = 0; children after parents (pre-order)
  std::vector<int> leaf_of_;  // triangle -> leaf node
  std::vector<std::vector<EdgeKey>>
      contour_;                  // node -> its patch's boundary edges (nodes of >= kConeMin tris)
  double area_after_build_ = 0;  // m^2; surface_area_sum() right after the last (re)build and refit
  int steps_since_build_ = 0;
  int rebuilds_ = 0;
  bool rebuilt_pending_ = false;  // build() ran; the next refit records area_after_build_
  bool cones_valid_ = true;       // the cones hold the last refit's motion (false after a box-only refit)
};

// Sorts pairs of non-negative indices (lexicographically), in time linear in the count and the largest first
// index (a counting sort; std::sort of the candidate pairs was a tenth of the self-collision stage).
void sort_pairs(std::vector<TrianglePair>& pairs);

// Brute force over all triangle pairs, with the same leaf boxes: the reference for tests.
std::vector<TrianglePair> brute_force_pairs(const loom::cloth::ClothMesh& mesh, const Vec3s& x0,
                                            const Vec3s& x1, double thickness, bool skip_adjacent);

}  // namespace loom::collision
