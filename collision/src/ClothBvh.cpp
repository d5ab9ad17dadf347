// ClothBvh: material-space AABB tree with refit and quality-triggered rebuild (ClothBvh.h).
#include "loom/collision/ClothBvh.h"

#include <algorithm>
#include <numeric>

#include "loom/collision/Distance.h"

namespace loom::collision {
namespace {

Aabb leaf_box(const loom::cloth::Tri& t, const Vec3s& x0, const Vec3s& x1, double thickness) {
  Aabb b;
  for (int k = 0; k < 3; ++k) b.grow(x0[t[k]]), b.grow(x1[t[k]]);
  b.lo.array() -= thickness;
  b.hi.array() += thickness;
  return b;
}

constexpr int kConeMin = 8;  // triangles; smaller nodes are not worth a contour test

// Normal cone of a triangle over the step: with edges e1(t), e2(t) linear in t, n(t) = e1 x e2 =
// (1-t)^2 b0 + 2t(1-t) b1 + t^2 b2 (Bernstein form), a non-negative combination of b0, b1, b2, so a cone
// holding their directions holds n(t) for every t in [0, 1] (Tang et al. 2009, continuous normal cones).
void leaf_cone(const loom::cloth::Tri& t, const Vec3s& x0, const Vec3s& x1, Vec3& axis, double& angle) {
  const Vec3 p = x0[t[1]] - x0[t[0]], r = x0[t[2]] - x0[t[0]];
  const Vec3 q = x1[t[1]] - x1[t[0]], s = x1[t[2]] - x1[t[0]];
  const Vec3 b[3] = {p.cross(r), 0.5 * (p.cross(s) + q.cross(r)), q.cross(s)};
  angle = M_PI;
  const double l0 = b[0].norm(), l2 = b[2].norm();
  if (!(l0 > 0.0) || !(l2 > 0.0)) return;
  const Vec3 sum = b[0] / l0 + b[2] / l2;
  const double ls = sum.norm();
  if (!(ls > 1e-12)) return;
  axis = sum / ls;
  double cmin = 1.0;
  for (const Vec3& bi : b) {
    const double l = bi.norm();
    if (l > 0.0) cmin = std::min(cmin, axis.dot(bi) / l);
  }
  angle = std::acos(std::max(-1.0, std::min(1.0, cmin)));
}

// Smallest cone holding cones (a, alpha) and (b, beta).
void merge_cones(const Vec3& a, double alpha, const Vec3& b, double beta, Vec3& axis, double& angle) {
  if (alpha >= M_PI || beta >= M_PI) {
    axis = a, angle = M_PI;
    return;
  }
  const double theta = std::acos(std::max(-1.0, std::min(1.0, a.dot(b))));
  if (theta + beta <= alpha) {
    axis = a, angle = alpha;
    return;
  }
  if (theta + alpha <= beta) {
    axis = b, angle = beta;
    return;
  }
  const double gamma = 0.5 * (alpha + theta + beta);
  if (gamma >= 0.5 * M_PI) {  // useless for culling; keep it cheap (a valid, wider cone)
    axis = a, angle = std::min(M_PI, theta + beta);
    return;
  }
  const double st = std::sin(theta), turn = gamma - alpha;  // rotate a towards b by `turn`
  axis = ((std::sin(theta - turn) / st) * a + (std::sin(turn) / st) * b).normalized();
  angle = gamma * (1.0 + 1e-12) + 1e-15;  // rounding: never tighter than the exact cone
}

bool share_vertex(const loom::cloth::Tri& a, const loom::cloth::Tri& b) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a[i] == b[j]) return true;
  return false;
}

}  // namespace

void sort_pairs(std::vector<TrianglePair>& pairs) {
  if (pairs.size() < 64) {
    std::sort(pairs.begin(), pairs.end());
    return;
  }
  int n = 0;
  for (const TrianglePair& p : pairs) n = std::max(n, p.first + 1);
  // Counting sort by the first index (stable), then each run of equal first indices (a handful of pairs: a
  // triangle's neighbours) by the second.
  std::vector<int> start(n + 1, 0);
  for (const TrianglePair& p : pairs) ++start[p.first + 1];
  for (int i = 0; i < n; ++i) start[i + 1] += start[i];
  std::vector<TrianglePair> out(pairs.size());
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (const TrianglePair& p : pairs) out[fill[p.first]++] = p;
  for (int i = 0; i < n; ++i) {
    auto b = out.begin() + start[i], e = out.begin() + start[i + 1];
    if (e - b > 1) {
      // Insertion sort: the runs are short.
      for (auto it = b + 1; it != e; ++it)
        for (auto jt = it; jt != b && jt->second < (jt - 1)->second; --jt) std::iter_swap(jt, jt - 1);
    }
  }
  pairs.swap(out);
}

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
  for (int i = 0; i < n; ++i)
    centroids[i] = (points[tris[i][0]] + points[tris[i][1]] + points[tris[i][2]]) / 3.0;
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  nodes_.clear();
  nodes_.reserve(std::max(1, 2 * n - 1));
  leaf_of_.assign(n, -1);
  if (n > 0) build_range(order, centroids, 0, n);
  build_topology();
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
  nodes_[id].count = end - begin;
  return id;
}

// Contours (boundary edges) bottom-up: a node's contour is the symmetric difference of its children's (edges
// in both are inside the patch); the patch is edge-connected if both children are and they share an edge.
// Kept only for nodes of >= kConeMin triangles.
void ClothBvh::build_topology() {
  const auto& tris = mesh_->triangles();
  const int nn = static_cast<int>(nodes_.size());
  contour_.assign(nn, {});
  for (int id = nn - 1; id >= 0; --id) {
    Node& nd = nodes_[id];
    std::vector<EdgeKey>& c = contour_[id];
    if (nd.left < 0) {
      const loom::cloth::Tri& t = tris[nd.triangle];
      for (int k = 0; k < 3; ++k)
        c.emplace_back(std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3]));
      std::sort(c.begin(), c.end());
      nd.connected = true;
      continue;
    }
    const auto& a = contour_[nd.left];
    const auto& b = contour_[nd.right];
    std::set_symmetric_difference(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(c));
    nd.connected = nodes_[nd.left].connected && nodes_[nd.right].connected && c.size() < a.size() + b.size();
    if (nodes_[nd.left].count < kConeMin) std::vector<EdgeKey>().swap(contour_[nd.left]);
    if (nodes_[nd.right].count < kConeMin) std::vector<EdgeKey>().swap(contour_[nd.right]);
  }
}

void ClothBvh::refit_internal(int id, bool cones) {
  Node& nd = nodes_[id];
  if (nd.left < 0) return;
  const Node& l = nodes_[nd.left];
  const Node& r = nodes_[nd.right];
  nd.box = l.box;
  nd.box.grow(r.box);
  if (cones) merge_cones(l.axis, l.angle, r.axis, r.angle, nd.axis, nd.angle);
}

void ClothBvh::refit(const Vec3s& x0, const Vec3s& x1, double thickness, int threads, bool cones) {
  const auto& tris = mesh_->triangles();
  const int n = static_cast<int>(tris.size());
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(static)
  for (int i = 0; i < n; ++i) {
    Node& leaf = nodes_[leaf_of_[i]];
    leaf.box = leaf_box(tris[i], x0, x1, thickness);
    if (cones) leaf_cone(tris[i], x0, x1, leaf.axis, leaf.angle);
  }
  cones_valid_ = cones;
  // Internal nodes: children come after their parent (pre-order), so a reverse sweep sees both children
  // first. In parallel: the subtrees below a frontier of >= 4 x threads nodes (each a contiguous index range)
  // as tasks, then the nodes above the frontier.
  std::vector<int> frontier, top;
  if (!nodes_.empty()) frontier.push_back(0);
  if (threads > 1) {
    while (static_cast<int>(frontier.size()) < 4 * threads) {
      std::vector<int> next;
      for (int id : frontier) {
        if (nodes_[id].left < 0) {
          next.push_back(id);
        } else {
          top.push_back(id);
          next.push_back(nodes_[id].left);
          next.push_back(nodes_[id].right);
        }
      }
      if (next.size() == frontier.size()) break;
      frontier.swap(next);
    }
  }
  const int nf = static_cast<int>(frontier.size());
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(dynamic, 1)
  for (int f = 0; f < nf; ++f) {
    const int root = frontier[f];
    for (int id = root + 2 * nodes_[root].count - 2; id >= root; --id) refit_internal(id, cones);
  }
  std::sort(top.begin(), top.end());
  for (auto it = top.rbegin(); it != top.rend(); ++it) refit_internal(*it, cones);
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

bool ClothBvh::adjacent(int i, int j) const {
  return share_vertex(mesh_->triangles()[i], mesh_->triangles()[j]);
}

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
  // Descend the larger (or the only internal) node; larger = more triangles (a node's box grows with its
  // patch, and the count costs nothing to compare).
  if (nb.left < 0 || (na.left >= 0 && na.count >= nb.count)) {
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
  sort_pairs(out);
  return out;
}

// The node's patch cannot touch itself over the step (see ClothBvh.h): edge-connected, cone half-angle below
// 90 degrees, contour simple in projection along the axis at every t. For the contour, two edges i, j sharing
// no vertex must be farther apart at t = 0 than their largest projected endpoint displacements d_i + d_j plus
// the margin: a point of a linearly moving segment moves at most as far as its farthest endpoint, so their
// distance can shrink by at most d_i + d_j during the step.
// Contour edges closer than the margin in the rest mesh (material space: a fine mesh whose edges are about
// the margin, e.g. two edges one diagonal apart) are close at rest and need only stay apart: for them the
// margin is dropped, never the strict bound, so the contour is still proven simple (Volino &
// Magnenat-Thalmann 1994 need nothing more) and fine meshes keep their culling.
bool ClothBvh::cullable(int n, const Vec3s& x0, const Vec3s& x1, double margin) const {
  const Node& nd = nodes_[n];
  if (!cones_valid_ || margin < 0.0) return false;  // stale cones (box-only refit), or no culling asked
  if (nd.count < kConeMin || !nd.connected || !(nd.angle < 0.5 * M_PI * (1.0 - 1e-9))) return false;
  const std::vector<EdgeKey>& c = contour_[n];
  const Vec3 d = nd.axis;
  const Vec3 u = (std::abs(d.x()) < 0.7 ? Vec3::UnitX() : Vec3::UnitY()).cross(d).normalized();
  const Vec3 w = d.cross(u);
  auto proj = [&](const Vec3& p) { return Vec3(p.dot(u), p.dot(w), 0.0); };
  struct Seg {
    Vec3 a, b;        // projected at t = 0
    double disp;      // m, displacement bound
    double reach;     // m, displacement bound + half the margin
    double lo, hi;    // box along u
    double wlo, whi;  // box along w
    int i, j;         // vertices
  };
  std::vector<Seg> segs(c.size());
  for (size_t k = 0; k < c.size(); ++k) {
    Seg& sg = segs[k];
    sg.i = c[k].first, sg.j = c[k].second;
    sg.a = proj(x0[sg.i]), sg.b = proj(x0[sg.j]);
    const double disp = std::max(proj(x1[sg.i] - x0[sg.i]).norm(), proj(x1[sg.j] - x0[sg.j]).norm());
    sg.disp = disp;
    sg.reach = disp + 0.5 * margin;
    sg.lo = std::min(sg.a.x(), sg.b.x()) - sg.reach, sg.hi = std::max(sg.a.x(), sg.b.x()) + sg.reach;
    sg.wlo = std::min(sg.a.y(), sg.b.y()) - sg.reach, sg.whi = std::max(sg.a.y(), sg.b.y()) + sg.reach;
  }
  std::sort(segs.begin(), segs.end(), [](const Seg& p, const Seg& q) { return p.lo < q.lo; });
  for (size_t k = 0; k < segs.size(); ++k) {
    const Seg& p = segs[k];
    for (size_t m = k + 1; m < segs.size() && segs[m].lo <= p.hi; ++m) {
      const Seg& q = segs[m];
      if (q.whi < p.wlo || p.whi < q.wlo) continue;
      if (p.i == q.i || p.i == q.j || p.j == q.i || p.j == q.j) continue;  // adjacent contour edges
      const double reach = p.reach + q.reach;
      const double d2 = segment_segment_closest(p.a, p.b, q.a, q.b).distance_squared;
      if (d2 > reach * reach) continue;
      const double strict = p.disp + q.disp;
      if (d2 <= strict * strict) return false;
      const Vec3s& r = mesh_->rest_positions();
      if (segment_segment_closest(r[p.i], r[p.j], r[q.i], r[q.j]).distance_squared >= margin * margin)
        return false;
    }
  }
  return true;
}

void ClothBvh::self_recurse_culled(int n, bool skip_adjacent, const Vec3s& x0, const Vec3s& x1, double margin,
                                   std::vector<TrianglePair>& out, long& culled) const {
  const Node& nd = nodes_[n];
  if (nd.left < 0) return;
  if (cullable(n, x0, x1, margin)) {
    ++culled;
    return;
  }
  self_recurse_culled(nd.left, skip_adjacent, x0, x1, margin, out, culled);
  self_recurse_culled(nd.right, skip_adjacent, x0, x1, margin, out, culled);
  cross_recurse(nd.left, nd.right, skip_adjacent, out);
}

std::vector<std::pair<int, int>> ClothBvh::self_pair_tasks(const Vec3s& x0, const Vec3s& x1, double margin,
                                                           long* culled) const {
  long n_culled = 0;
  std::vector<std::pair<int, int>> tasks, done;
  if (!nodes_.empty()) tasks.push_back({0, 0});
  // The self tasks of the top levels are split (after their own cull test) until there are kTasks tasks:
  // enough for dynamic scheduling on a few threads, and the same for every thread count.
  constexpr size_t kTasks = 64;
  while (!tasks.empty() && tasks.size() + done.size() < kTasks) {
    std::vector<std::pair<int, int>> next;
    bool split = false;
    for (const auto& t : tasks) {
      const Node& nd = nodes_[t.first];
      if (t.first != t.second || nd.left < 0) {
        done.push_back(t);
        continue;
      }
      if (cullable(t.first, x0, x1, margin)) {
        ++n_culled;
        continue;
      }
      next.push_back({nd.left, nd.left});
      next.push_back({nd.right, nd.right});
      done.push_back({nd.left, nd.right});
      split = true;
    }
    tasks.swap(next);
    if (!split) break;
  }
  done.insert(done.end(), tasks.begin(), tasks.end());
  if (culled) *culled = n_culled;
  return done;
}

void ClothBvh::self_pairs_of_task(std::pair<int, int> task, const Vec3s& x0, const Vec3s& x1, double margin,
                                  bool skip_adjacent, std::vector<TrianglePair>& out, long& culled) const {
  const auto [a, b] = task;
  if (a == b) {
    self_recurse_culled(a, skip_adjacent, x0, x1, margin, out, culled);
  } else {
    cross_recurse(a, b, skip_adjacent, out);
  }
}

std::vector<TrianglePair> ClothBvh::self_pairs_culled(const Vec3s& x0, const Vec3s& x1, double margin,
                                                      bool skip_adjacent, int threads, long* culled) const {
  long n_culled = 0;
  const std::vector<std::pair<int, int>> tasks = self_pair_tasks(x0, x1, margin, &n_culled);
  const int nt = static_cast<int>(tasks.size());
  std::vector<std::vector<TrianglePair>> parts(nt);
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(dynamic, 1) reduction(+ : n_culled)
  for (int k = 0; k < nt; ++k)
    self_pairs_of_task(tasks[k], x0, x1, margin, skip_adjacent, parts[k], n_culled);
  std::vector<TrianglePair> out;
  size_t total = 0;
  for (const auto& p : parts) total += p.size();
  out.reserve(total);
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  sort_pairs(out);
  if (culled) *culled = n_culled;
  return out;
}

void ClothBvh::split_pair(const Node& na, int a, const Node& nb, int b,
                          std::vector<std::pair<int, int>>& out) {
  if (nb.left < 0 || (na.left >= 0 && na.count >= nb.count)) {
    out.push_back({na.left, b});
    out.push_back({na.right, b});
  } else {
    out.push_back({a, nb.left});
    out.push_back({a, nb.right});
  }
}

bool ClothBvh::walk_self_task(std::pair<int, int> task, bool skip_adjacent,
                              const std::function<bool(int, int)>& visit) const {
  // An explicit stack of node pairs: {n, n} = pairs below n, {a, b} = pairs between a and b.
  std::vector<std::pair<int, int>> stack{task};
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    const Node& na = nodes_[a];
    if (a == b) {
      if (na.left < 0) continue;
      stack.push_back({na.left, na.left});
      stack.push_back({na.right, na.right});
      stack.push_back({na.left, na.right});
      continue;
    }
    const Node& nb = nodes_[b];
    if (!na.box.overlaps(nb.box)) continue;
    if (na.left < 0 && nb.left < 0) {
      if (skip_adjacent && adjacent(na.triangle, nb.triangle)) continue;
      if (!visit(std::min(na.triangle, nb.triangle), std::max(na.triangle, nb.triangle))) return false;
    } else {
      split_pair(na, a, nb, b, stack);
    }
  }
  return true;
}

std::vector<std::pair<int, int>> ClothBvh::cross_pair_tasks(const ClothBvh& other) const {
  std::vector<std::pair<int, int>> tasks, next;
  if (nodes_.empty() || other.nodes_.empty()) return tasks;
  tasks.push_back({0, 0});
  // Overlapping internal pairs are split breadth-first until there are about kTasks of them.
  constexpr size_t kTasks = 64;
  bool split = true;
  while (split && tasks.size() < kTasks) {
    split = false;
    next.clear();
    for (const auto& [a, b] : tasks) {
      const Node& na = nodes_[a];
      const Node& nb = other.nodes_[b];
      if (!na.box.overlaps(nb.box)) continue;
      if (na.left < 0 && nb.left < 0) {
        next.push_back({a, b});
      } else {
        split_pair(na, a, nb, b, next);
        split = true;
      }
    }
    tasks.swap(next);
  }
  return tasks;
}

bool ClothBvh::walk_cross_task(const ClothBvh& other, std::pair<int, int> task,
                               const std::function<bool(int, int)>& visit) const {
  std::vector<std::pair<int, int>> stack{task};
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    const Node& na = nodes_[a];
    const Node& nb = other.nodes_[b];
    if (!na.box.overlaps(nb.box)) continue;
    if (na.left < 0 && nb.left < 0) {
      if (!visit(na.triangle, nb.triangle)) return false;
    } else {
      split_pair(na, a, nb, b, stack);
    }
  }
  return true;
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
  sort_pairs(out);
  return out;
}

std::vector<TrianglePair> brute_force_pairs(const loom::cloth::ClothMesh& mesh, const Vec3s& x0,
                                            const Vec3s& x1, double thickness, bool skip_adjacent) {
  const auto& tris = mesh.triangles();
  const int n = static_cast<int>(tris.size());
  std::vector<Aabb> boxes(n);
  for (int i = 0; i < n; ++i) boxes[i] = leaf_box(tris[i], x0, x1, thickness);
  std::vector<TrianglePair> out;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if (boxes[i].overlaps(boxes[j]) && !(skip_adjacent && share_vertex(tris[i], tris[j])))
        out.emplace_back(i, j);
  return out;
}

}  // namespace loom::collision
