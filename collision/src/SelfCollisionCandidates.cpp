// Self-collision candidates (SelfCollisionStage.h, step 2): triangle pairs from the cloth BVHs, and the
// vertex-face and edge-edge features of those pairs, each exactly once.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "SelfCollisionInternal.h"
#include "loom/collision/BodyCollisionStage.h"
#include "loom/collision/Ccd.h"
#include "loom/collision/Distance.h"
#include "loom/collision/SelfCollisionStage.h"

namespace loom::collision {

using loom::cloth::Mat3;
using loom::cloth::Tri;
using loom::cloth::Vec3s;
using namespace self_collision_detail;

// I-Cloth's Td x (Td u Ts): triangles with a dirty vertex, queried against every cloth's refitted tree.
// The dirty triangles' queries run in parallel over contiguous chunks of the dirty list, joined in chunk
// order, then sorted: the same pairs for any thread count.
std::vector<TrianglePair> SelfCollisionStage::triangle_pairs_touching(const std::vector<char>& dirty,
                                                                      int threads) {
  PhaseTimer timer(pairs_ms_);
  std::vector<char> td(tris_.size(), 0);
  for (int v = 0; v < static_cast<int>(dirty.size()); ++v)
    if (dirty[v])
      for (int k = vtx_tri_start_[v]; k < vtx_tri_start_[v + 1]; ++k) td[vtx_tri_[k]] = 1;
  std::vector<int> list;
  for (int t = 0; t < static_cast<int>(tris_.size()); ++t)
    if (td[t]) list.push_back(t);
  auto query = [&](long begin, long end, std::vector<TrianglePair>& part) {
    for (long i = begin; i < end; ++i) {
      const int t = list[i];
      const int c = tri_cloth_[t];
      Aabb box;
      for (int k = 0; k < 3; ++k) box.grow(x0_[tris_[t][k]]), box.grow(x1_[tris_[t][k]]);
      box.lo.array() -= 0.5 * cloth_thickness_[c];
      box.hi.array() += 0.5 * cloth_thickness_[c];
      for (int d = 0; d < num_cloths_; ++d) {
        if (d == c && !settings_.self) continue;
        for (int j : bvhs_[d]->query(box)) {
          const int g = tri_offset_[d] + j;
          if (g != t) part.emplace_back(std::min(g, t), std::max(g, t));
        }
      }
    }
  };
  std::vector<TrianglePair> out =
      in_chunks<TrianglePair>(static_cast<long>(list.size()), threads, 512, 8, query);
  sort_pairs(out);
  out.erase(std::unique(out.begin(), out.end()), out.end());
  candidate_pairs_ += static_cast<long>(out.size());
  return out;
}

// Features of the candidate triangle pairs, each exactly once: a vertex-face pair (v, f) comes only from the
// pair (owner(v), f) and an edge-edge pair only from (owner(ea), owner(eb)), owner = the lowest-numbered
// triangle holding the vertex or edge (tri_owns_). That pair is always a candidate when the feature can be:
// the feature's swept box lies inside its owner's leaf box. Feature-level filter: swept boxes of the two
// features (vertex_boxes), inflated by the pair thickness, must overlap (covers the proximity distance at x0
// and the continuous test's separation, which is smaller); rest neighbours (rest_cap) are checked again with
// their capped thickness.
void SelfCollisionStage::extract_features(const TrianglePair* pairs, long n, const std::vector<char>* dirty,
                                          std::vector<Feature>& out) const {
  auto is_dirty = [&](int v) { return !dirty || (*dirty)[v]; };
  const std::vector<Aabb>& vbox = vbox_;
  auto near = [&](Aabb a, const Aabb& b, int ca, int cb, float cap = HUGE_VALF) {
    const double hp = std::min(0.5 * (cloth_thickness_[ca] + cloth_thickness_[cb]), static_cast<double>(cap));
    a.lo.array() -= hp, a.hi.array() += hp;
    return a.overlaps(b);
  };
  for (long i = 0; i < n; ++i) {
    const TrianglePair& p = pairs[i];
    const unsigned own_a = tri_owns_[p.first], own_b = tri_owns_[p.second];
    const Tri& ta = tris_[p.first];
    const Tri& tb = tris_[p.second];
    for (int side = 0; side < 2; ++side) {
      const unsigned own = side ? own_b : own_a;
      if (!(own & 7u)) continue;
      const Tri& tv = side ? tb : ta;
      const Tri& tf = side ? ta : tb;
      const int f = side ? p.first : p.second;
      const bool face_dirty = is_dirty(tf[0]) || is_dirty(tf[1]) || is_dirty(tf[2]);
      bool have_box = false;
      Aabb fb;
      for (int k = 0; k < 3; ++k) {
        if (!(own & (1u << k))) continue;  // not the owner of this vertex
        const int v = tv[k];
        if (v == tf[0] || v == tf[1] || v == tf[2]) continue;
        if (!(face_dirty || is_dirty(v))) continue;
        if (!have_box) {
          fb = vbox[tf[0]], fb.grow(vbox[tf[1]]), fb.grow(vbox[tf[2]]);
          have_box = true;
        }
        const Aabb& vb = vbox[v];
        if (!near(vb, fb, vertex_cloth_[v], tri_cloth_[f])) continue;
        Feature fe{0, v, f};
        fe.cap = rest_cap(fe);
        if (fe.cap < HUGE_VALF && !near(vb, fb, vertex_cloth_[v], tri_cloth_[f], fe.cap)) continue;
        out.push_back(fe);
      }
    }
    if (!(own_a & 56u) || !(own_b & 56u)) continue;
    for (int i2 = 0; i2 < 3; ++i2) {
      if (!(own_a & (8u << i2))) continue;
      const int ea = tri_edges_[p.first][i2];
      const auto& a = edges_[ea];
      Aabb ab = vbox[a[0]];
      ab.grow(vbox[a[1]]);
      for (int j = 0; j < 3; ++j) {
        if (!(own_b & (8u << j))) continue;
        const int eb = tri_edges_[p.second][j];
        const auto& b = edges_[eb];
        if (a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1]) continue;
        if (!(is_dirty(a[0]) || is_dirty(a[1]) || is_dirty(b[0]) || is_dirty(b[1]))) continue;
        Aabb bb = vbox[b[0]];
        bb.grow(vbox[b[1]]);
        if (!near(ab, bb, edge_cloth_[ea], edge_cloth_[eb])) continue;
        Feature fe{1, std::min(ea, eb), std::max(ea, eb)};
        fe.cap = rest_cap(fe);
        if (fe.cap < HUGE_VALF && !near(ab, bb, edge_cloth_[ea], edge_cloth_[eb], fe.cap)) continue;
        out.push_back(fe);
      }
    }
  }
}

// Per-vertex swept boxes of x0 -> x1 once per search (a vertex is in many features).
void SelfCollisionStage::vertex_boxes(int threads) const {
  const int nv = static_cast<int>(x0_.size());
  vbox_.resize(nv);
#pragma omp parallel for num_threads(threads) if (threads > 1 && nv > 8192) schedule(static)
  for (int v = 0; v < nv; ++v) vbox_[v].lo = x0_[v].cwiseMin(x1_[v]), vbox_[v].hi = x0_[v].cwiseMax(x1_[v]);
}

// Features of `pairs` (extract_features); chunks of pairs are done in parallel and joined in order.
std::vector<SelfCollisionStage::Feature> SelfCollisionStage::features(const std::vector<TrianglePair>& pairs,
                                                                      const std::vector<char>* dirty,
                                                                      int threads) const {
  PhaseTimer timer(features_ms_);
  vertex_boxes(threads);
  std::vector<Feature> out = extract_in_chunks(pairs, dirty, threads);
  features_ += static_cast<long>(out.size());
  return out;
}

// extract_features over `pairs` (vertex boxes already computed): chunks in parallel, joined in pair order.
std::vector<SelfCollisionStage::Feature> SelfCollisionStage::extract_in_chunks(
    const std::vector<TrianglePair>& pairs, const std::vector<char>* dirty, int threads) const {
  return in_chunks<Feature>(static_cast<long>(pairs.size()), threads, 4096, 4,
                            [&](long begin, long end, std::vector<Feature>& out) {
                              extract_features(pairs.data() + begin, end - begin, dirty, out);
                            });
}

// The step's search over all pairs, features straight from the traversal: the self pairs of each cloth
// (normal- cone culled when enabled) go to extract_features task by task as the tree yields them (ClothBvh::
// self_pair_tasks: the same tasks and order for any thread count), never stored, sorted or joined whole;
// pairs between every two cloths (never culled: layers lie on each other, flat, and must always be tested)
// are searched and extracted as before.
std::vector<SelfCollisionStage::Feature> SelfCollisionStage::all_features(int threads) {
  PhaseTimer timer(pairs_ms_);
  vertex_boxes(threads);
  std::vector<Feature> out;
  for (int c = 0; c < num_cloths_; ++c) {
    if (settings_.self && settings_.normal_cones) {
      const ClothBvh& bvh = *bvhs_[c];
      long culled = 0, npairs = 0;
      const std::vector<std::pair<int, int>> tasks =
          bvh.self_pair_tasks(cx0_[c], cx1_[c], cloth_thickness_[c], &culled);
      const int nt = static_cast<int>(tasks.size()), to = tri_offset_[c];
      std::vector<std::vector<Feature>> parts(nt);
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(dynamic, 1) reduction(+ : culled, npairs)
      for (int k = 0; k < nt; ++k) {
        static thread_local std::vector<TrianglePair> buf;
        buf.clear();
        bvh.self_pairs_of_task(tasks[k], cx0_[c], cx1_[c], cloth_thickness_[c], false, buf, culled);
        npairs += static_cast<long>(buf.size());
        if (to != 0)
          for (TrianglePair& p : buf) p.first += to, p.second += to;
        extract_features(buf.data(), static_cast<long>(buf.size()), nullptr, parts[k]);
      }
      culled_nodes_ += culled;
      candidate_pairs_ += npairs;
      std::vector<Feature> fc = join_chunks(parts);
      if (out.empty()) {
        out.swap(fc);
      } else {
        out.insert(out.end(), fc.begin(), fc.end());
      }
    }
    std::vector<TrianglePair> pairs;
    if (settings_.self && !settings_.normal_cones)
      for (const TrianglePair& p : bvhs_[c]->self_pairs(false))
        pairs.emplace_back(tri_offset_[c] + p.first, tri_offset_[c] + p.second);
    for (int d = c + 1; d < num_cloths_; ++d)
      for (const TrianglePair& p : bvhs_[c]->cross_pairs(*bvhs_[d]))
        pairs.emplace_back(tri_offset_[c] + p.first, tri_offset_[d] + p.second);
    if (pairs.empty()) continue;
    candidate_pairs_ += static_cast<long>(pairs.size());
    const std::vector<Feature> fc = extract_in_chunks(pairs, nullptr, threads);
    out.insert(out.end(), fc.begin(), fc.end());
  }
  features_ += static_cast<long>(out.size());
  // In the order of their first vertex (a stable counting sort): the phases after this one then read the
  // positions almost sequentially, as the sorted pair order of a separate search did.
  const int nv = static_cast<int>(x0_.size());
  auto key = [&](const Feature& f) { return f.type == 0 ? f.a : edges_[f.a][0]; };
  std::vector<int> start(nv + 1, 0);
  for (const Feature& f : out) ++start[key(f) + 1];
  for (int v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<Feature> sorted(out.size());
  for (const Feature& f : out) sorted[start[key(f)]++] = f;
  return sorted;
}

SelfCollisionStage::Contact SelfCollisionStage::contact_of(const Feature& f) const {
  Contact c;
  if (f.type == 0) {
    const Tri& t = tris_[f.b];
    c.v[0] = f.a, c.v[1] = t[0], c.v[2] = t[1], c.v[3] = t[2];
    c.cloth_a = vertex_cloth_[f.a], c.cloth_b = tri_cloth_[f.b];
  } else {
    c.v[0] = edges_[f.a][0], c.v[1] = edges_[f.a][1], c.v[2] = edges_[f.b][0], c.v[3] = edges_[f.b][1];
    c.cloth_a = edge_cloth_[f.a], c.cloth_b = edge_cloth_[f.b];
  }
  c.cap = f.cap;
  return c;
}

double SelfCollisionStage::pair_thickness(const Contact& c) const {
  return std::min(0.5 * (cloth_thickness_[c.cloth_a] + cloth_thickness_[c.cloth_b]), c.cap);
}

}  // namespace loom::collision
