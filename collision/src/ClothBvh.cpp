// ClothBvh: material-space AABB tree with refit and quality-triggered rebuild (ClothBvh.h).
#include "loom/collision/ClothBvh.h"

#include <algorithm>
#include <numeric>

namespace loom::collision {
namespace {

Aabb leaf_box(const loom::cloth::Tri& t, const Vec3s& x0, const Vec3s& x1, double thickness) {
  Aabb b;
  for (int k = 0; k < 3; ++k) b.grow(x0[t[k]]), b.grow(x1[t[k]]);
  b.lo.array() -= thickness;
  b.hi.array() += thickness;
  return b;
}

bool share_vertex(const loom::cloth::Tri& a, const loom::cloth::Tri& b) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a[i] == b[j]) return true;
  return false;
}

}  // namespace

double Aabb::surface_area() const {
  const Vec3 d = (hi - lo).cwiseMax(0.0);
  return 2.0 * (d.x() * d.y() + d.y() * d.z() + d.z() * d.x());
}

ClothBvh::ClothBvh(std::shared_ptr<const loom::cloth::ClothMesh> mesh, ClothBvhSettings settings)
    : mesh_(std::move(mesh)), settings_(settings) {
  build(mesh_->rest_positions());
  refit(mesh_->rest_positions(), mesh_->rest_positions(), 0.0);
}

void ClothBvh::build(const Vec3s& points) {
  const auto& tris = mesh_->triangles();
  const int n = static_cast<int>(tris.size());
  std::vector<Vec3> centroids(n);
  for (int i = 0; i < n; ++i) centroids[i] = (points[tris[i][0]] + points[tris[i][1]] + points[tris[i][2]]) / 3.0;
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  nodes_.clear();
  nodes_.reserve(std::max(1, 2 * n - 1));
  leaf_of_.assign(n, -1);
  if (n > 0) build_range(order, centroids, 0, n);
  rebuilt_pending_ = true;
  steps_since_build_ = 0;
}

// Top-down median split along the longest axis of the centroids' box (ties broken by triangle index, so the
// tree depends only on the input).
int ClothBvh::build_range(std::vector<int>& tris, const std::vector<Vec3>& centroids, int begin, int end) {
  const int id = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  if (end - begin == 1) {
    nodes_[id].triangle = tris[begin];
    leaf_of_[tris[begin]] = id;
    return id;
  }
  Aabb c;
  for (int i = begin; i < end; ++i) c.grow(centroids[tris[i]]);
  int axis = 0;
  (c.hi - c.lo).maxCoeff(&axis);
  const int mid = begin + (end - begin) / 2;
  std::nth_element(tris.begin() + begin, tris.begin() + mid, tris.begin() + end, [&](int a, int b) {
    return centroids[a][axis] < centroids[b][axis] || (centroids[a][axis] == centroids[b][axis] && a < b);
  });
  const int left = build_range(tris, centroids, begin, mid);
  const int right = build_range(tris, centroids, mid, end);
  nodes_[id].left = left;
  nodes_[id].right = right;
  return id;
}

void ClothBvh::refit(const Vec3s& x0, const Vec3s& x1, double thickness, int threads) {
  const auto& tris = mesh_->triangles();
  const int n = static_cast<int>(tris.size());
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
  for (int i = 0; i < n; ++i) nodes_[leaf_of_[i]].box = leaf_box(tris[i], x0, x1, thickness);
  // Children come after their parent, so a reverse sweep sees both children first.
  for (int id = static_cast<int>(nodes_.size()) - 1; id >= 0; --id) {
    Node& nd = nodes_[id];
    if (nd.left < 0) continue;
    nd.box = nodes_[nd.left].box;
    nd.box.grow(nodes_[nd.right].box);
  }
  if (rebuilt_pending_) {
    area_after_build_ = surface_area_sum();
    rebuilt_pending_ = false;
  }
}

void ClothBvh::rebuild(const Vec3s& x0, const Vec3s& x1, double thickness, int threads) {
  build(x1);
  ++rebuilds_;
  refit(x0, x1, thickness, threads);
}

bool ClothBvh::update(const Vec3s& x0, const Vec3s& x1, double thickness, int threads) {
  refit(x0, x1, thickness, threads);
  ++steps_since_build_;
  const bool by_count = settings_.rebuild_every > 0 && steps_since_build_ >= settings_.rebuild_every;
  if (by_count || surface_area_sum() > settings_.rebuild_ratio * area_after_build_) {
    rebuild(x0, x1, thickness, threads);
    return true;
  }
  return false;
}

double ClothBvh::surface_area_sum() const {
  double s = 0;
  for (const Node& nd : nodes_)
    if (nd.left >= 0) s += nd.box.surface_area();
  return s;
}

bool ClothBvh::adjacent(int i, int j) const { return share_vertex(mesh_->triangles()[i], mesh_->triangles()[j]); }

void ClothBvh::self_recurse(int n, bool skip_adjacent, std::vector<TrianglePair>& out) const {
  const Node& nd = nodes_[n];
  if (nd.left < 0) return;
  self_recurse(nd.left, skip_adjacent, out);
  self_recurse(nd.right, skip_adjacent, out);
  cross_recurse(nd.left, nd.right, skip_adjacent, out);
}

void ClothBvh::cross_recurse(int a, int b, bool skip_adjacent, std::vector<TrianglePair>& out) const {
  const Node& na = nodes_[a];
  const Node& nb = nodes_[b];
  if (!na.box.overlaps(nb.box)) return;
  if (na.left < 0 && nb.left < 0) {
    if (skip_adjacent && adjacent(na.triangle, nb.triangle)) return;
    out.emplace_back(std::min(na.triangle, nb.triangle), std::max(na.triangle, nb.triangle));
    return;
  }
  // Descend the larger (or the only internal) node.
  if (nb.left < 0 || (na.left >= 0 && na.box.surface_area() >= nb.box.surface_area())) {
    cross_recurse(na.left, b, skip_adjacent, out);
    cross_recurse(na.right, b, skip_adjacent, out);
  } else {
    cross_recurse(a, nb.left, skip_adjacent, out);
    cross_recurse(a, nb.right, skip_adjacent, out);
  }
}

std::vector<TrianglePair> ClothBvh::self_pairs(bool skip_adjacent) const {
  std::vector<TrianglePair> out;
  if (!nodes_.empty()) self_recurse(0, skip_adjacent, out);
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<int> ClothBvh::query(const Aabb& box) const {
  std::vector<int> out, stack;
  if (!nodes_.empty()) stack.push_back(0);
  while (!stack.empty()) {
    const Node& nd = nodes_[stack.back()];
    stack.pop_back();
    if (!nd.box.overlaps(box)) continue;
    if (nd.left < 0) {
      out.push_back(nd.triangle);
    } else {
      stack.push_back(nd.left);
      stack.push_back(nd.right);
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

void ClothBvh::two_tree_recurse(int a, const ClothBvh& other, int b, std::vector<TrianglePair>& out) const {
  const Node& na = nodes_[a];
  const Node& nb = other.nodes_[b];
  if (!na.box.overlaps(nb.box)) return;
  if (na.left < 0 && nb.left < 0) {
    out.emplace_back(na.triangle, nb.triangle);
    return;
  }
  if (nb.left < 0 || (na.left >= 0 && na.box.surface_area() >= nb.box.surface_area())) {
    two_tree_recurse(na.left, other, b, out);
    two_tree_recurse(na.right, other, b, out);
  } else {
    two_tree_recurse(a, other, nb.left, out);
    two_tree_recurse(a, other, nb.right, out);
  }
}

std::vector<TrianglePair> ClothBvh::cross_pairs(const ClothBvh& other) const {
  std::vector<TrianglePair> out;
  if (!nodes_.empty() && !other.nodes_.empty()) two_tree_recurse(0, other, 0, out);
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<TrianglePair> brute_force_pairs(const loom::cloth::ClothMesh& mesh, const Vec3s& x0, const Vec3s& x1,
                                            double thickness, bool skip_adjacent) {
  const auto& tris = mesh.triangles();
  const int n = static_cast<int>(tris.size());
  std::vector<Aabb> boxes(n);
  for (int i = 0; i < n; ++i) boxes[i] = leaf_box(tris[i], x0, x1, thickness);
  std::vector<TrianglePair> out;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if (boxes[i].overlaps(boxes[j]) && !(skip_adjacent && share_vertex(tris[i], tris[j]))) out.emplace_back(i, j);
  return out;
}

}  // namespace loom::collision
