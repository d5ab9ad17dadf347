// Self- and cloth-cloth collision stage (SelfCollisionStage.h).
#include "loom/collision/SelfCollisionStage.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include "loom/collision/BodyCollisionStage.h"
#include "loom/collision/Ccd.h"
#include "loom/collision/Distance.h"

namespace loom::collision {

using loom::cloth::Mat3;
using loom::cloth::Tri;
using loom::cloth::Vec3s;

namespace {

// Adds the wall time of its scope to `ms` (ms): the stage's phase timers in the profile.
class PhaseTimer {
 public:
  explicit PhaseTimer(double& ms) : ms_(ms), start_(std::chrono::steady_clock::now()) {}
  ~PhaseTimer() { ms_ += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  double& ms_;
  std::chrono::steady_clock::time_point start_;
};

int find_root(std::vector<int>& parent, int v) {
  while (parent[v] != v) {
    parent[v] = parent[parent[v]];
    v = parent[v];
  }
  return v;
}

constexpr long kZoneCcdBoxes = 4096;  // the impact zones' budget of inclusion boxes per continuous test

// Unit vector along `d`, or along `fallback` oriented like `side` when d is (nearly) zero.
bool contact_normal(const Vec3& d, const Vec3& fallback, const Vec3& side, Vec3& n) {
  const double len = d.norm();
  if (len > 1e-12 * std::max(1.0, fallback.norm())) {
    n = d / len;
    return true;
  }
  const double fl = fallback.norm();
  if (!(fl > 0.0)) return false;
  n = fallback / fl;
  if (n.dot(side) < 0.0) n = -n;
  return true;
}


// A float at most d (d >= 0): float rounding is within 2^-24 relatively, the factor keeps it below.
float lower_float(double d) { return d > 0.0 ? static_cast<float>(d) * 0.999999f : 0.0f; }

// The per-chunk lists of a parallel loop joined in chunk order (the serial order, whatever the thread count).
template <class T>
std::vector<T> join_chunks(std::vector<std::vector<T>>& parts) {
  if (parts.size() == 1) return std::move(parts[0]);
  std::vector<T> out;
  size_t total = 0;
  for (const auto& p : parts) total += p.size();
  out.reserve(total);
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

// Runs body(begin, end, out) over contiguous chunks of [0, n) in parallel, each chunk appending to its own
// list, and returns the lists joined in chunk order: the serial order whatever the thread count. Below
// `serial_below` one chunk; else `per_thread` chunks per thread (dynamic schedule: chunks of uneven cost).
template <class T, class Body>
std::vector<T> in_chunks(long n, int threads, long serial_below, int per_thread, Body body) {
  const int chunks = n < serial_below ? 1 : std::max(1, threads) * per_thread;
  std::vector<std::vector<T>> parts(chunks);
#pragma omp parallel for num_threads(threads) if (threads > 1 && chunks > 1) schedule(dynamic, 1)
  for (int ch = 0; ch < chunks; ++ch) body(n * ch / chunks, n * (ch + 1) / chunks, parts[ch]);
  return join_chunks(parts);
}

}  // namespace

std::vector<std::pair<std::string, double>> SelfCollisionStage::counters() const {
  return {{"candidate_pairs", static_cast<double>(candidate_pairs_)},
          {"features", static_cast<double>(features_)},
          {"culled_nodes", static_cast<double>(culled_nodes_)},
          {"contacts", static_cast<double>(contacts_)},
          {"passes", static_cast<double>(passes_)},
          {"impact_zones", static_cast<double>(impact_zones_)},
          {"zone_iterations", static_cast<double>(zone_iterations_)},
          {"projections", static_cast<double>(projections_)},
          {"rigid_zones", static_cast<double>(rigid_zones_)},
          {"bvh_rebuilds", static_cast<double>(bvh_rebuilds_)},
          {"ccd_tests", static_cast<double>(ccd_tests_)},
          {"ccd_boxes", static_cast<double>(ccd_boxes_)},
          {"ccd_start_hits", static_cast<double>(ccd_start_hits_)},
          {"unresolved", static_cast<double>(unresolved_)},
          {"collider_fixes", static_cast<double>(collider_fixes_)},
          {"collider_rounds", static_cast<double>(collider_rounds_)},
          {"zone_ccd_cut", static_cast<double>(zone_ccd_cut_)},
          {"bvh_ms", bvh_ms_},
          {"pairs_ms", pairs_ms_},
          {"features_ms", features_ms_},
          {"proximity_ms", proximity_ms_},
          {"ccd_ms", ccd_ms_},
          {"zones_ms", zones_ms_}};
}

void SelfCollisionStage::setup(loom::cloth::StageContext& ctx) {
  num_cloths_ = static_cast<int>(ctx.cloths.size());
  vertex_offset_.assign(num_cloths_ + 1, 0);
  tri_offset_.assign(num_cloths_ + 1, 0);
  vertex_cloth_.clear(), tri_cloth_.clear(), edge_cloth_.clear();
  tris_.clear(), edges_.clear(), tri_edges_.clear();
  cloth_thickness_.assign(num_cloths_, 0.0);
  cloth_friction_.assign(num_cloths_, 0.0);
  bvhs_.clear();
  for (int c = 0; c < num_cloths_; ++c) {
    const loom::cloth::Cloth& cloth = *ctx.cloths[c];
    const loom::cloth::ClothMesh& mesh = cloth.mesh();
    const int vo = vertex_offset_[c];
    vertex_offset_[c + 1] = vo + mesh.num_vertices();
    tri_offset_[c + 1] = tri_offset_[c] + mesh.num_triangles();
    vertex_cloth_.insert(vertex_cloth_.end(), mesh.num_vertices(), c);
    const double given = c < static_cast<int>(settings_.thickness.size()) ? settings_.thickness[c] : 0.0;
    cloth_thickness_[c] = given > 0.0 ? given : cloth.material().thickness;
    cloth_friction_[c] = cloth.material().friction;
    const int eo = static_cast<int>(edges_.size());
    std::map<std::pair<int, int>, int> edge_id;
    for (size_t e = 0; e < mesh.edges().size(); ++e) {
      const auto& ed = mesh.edges()[e];
      edge_id[{std::min(ed.i, ed.j), std::max(ed.i, ed.j)}] = eo + static_cast<int>(e);
      edges_.push_back({vo + ed.i, vo + ed.j});
      edge_cloth_.push_back(c);
    }
    for (const Tri& t : mesh.triangles()) {
      tris_.push_back({vo + t[0], vo + t[1], vo + t[2]});
      tri_cloth_.push_back(c);
      std::array<int, 3> te{};
      for (int k = 0; k < 3; ++k) {
        const int i = t[k], j = t[(k + 1) % 3];
        te[k] = edge_id.at({std::min(i, j), std::max(i, j)});
      }
      tri_edges_.push_back(te);
    }
    bvhs_.push_back(std::make_unique<ClothBvh>(cloth.mesh_ptr()));
  }
  // Friction per cloth pair: the scene's pair table, else the global coefficients, else the mean of the two
  // materials' coefficient (static = kinetic).
  pair_mu_k_.assign(num_cloths_ * num_cloths_, 0.0);
  pair_mu_s_.assign(num_cloths_ * num_cloths_, 0.0);
  for (int a = 0; a < num_cloths_; ++a)
    for (int b = 0; b < num_cloths_; ++b) {
      const double k = settings_.friction >= 0.0 ? settings_.friction : 0.5 * (cloth_friction_[a] + cloth_friction_[b]);
      pair_mu_k_[a * num_cloths_ + b] = k;
      pair_mu_s_[a * num_cloths_ + b] = std::max(k, settings_.static_friction >= 0.0 ? settings_.static_friction : k);
    }
  for (const FrictionPair& fp : settings_.friction_pairs) {
    if (fp.other_cloth < 0 || fp.cloth >= num_cloths_ || fp.other_cloth >= num_cloths_) continue;
    for (const int ab : {fp.cloth * num_cloths_ + fp.other_cloth, fp.other_cloth * num_cloths_ + fp.cloth}) {
      pair_mu_k_[ab] = fp.friction;
      pair_mu_s_[ab] = std::max(fp.friction, fp.static_friction);
    }
  }
  edge_owner_.assign(edges_.size(), -1);
  for (int t = static_cast<int>(tris_.size()) - 1; t >= 0; --t)
    for (int k = 0; k < 3; ++k) edge_owner_[tri_edges_[t][k]] = t;
  const int nv = vertex_offset_[num_cloths_];
  vtx_tri_start_.assign(nv + 1, 0);
  for (const Tri& t : tris_)
    for (int k = 0; k < 3; ++k) ++vtx_tri_start_[t[k] + 1];
  for (int v = 0; v < nv; ++v) vtx_tri_start_[v + 1] += vtx_tri_start_[v];
  vtx_tri_.assign(vtx_tri_start_[nv], 0);
  cx0_.assign(num_cloths_, {}), cx1_.assign(num_cloths_, {});
  std::vector<int> fill(vtx_tri_start_.begin(), vtx_tri_start_.end() - 1);
  for (int t = 0; t < static_cast<int>(tris_.size()); ++t)
    for (int k = 0; k < 3; ++k) vtx_tri_[fill[tris_[t][k]]++] = t;
  // Owner masks: bit k (k < 3) = the triangle is its vertex k's owner (the lowest-numbered triangle holding
  // it), bit 3 + k = the owner of its edge k (extract_features).
  tri_owns_.assign(tris_.size(), 0);
  for (int t = 0; t < static_cast<int>(tris_.size()); ++t)
    for (int k = 0; k < 3; ++k) {
      if (vtx_tri_[vtx_tri_start_[tris_[t][k]]] == t) tri_owns_[t] |= static_cast<unsigned char>(1u << k);
      if (edge_owner_[tri_edges_[t][k]] == t) tri_owns_[t] |= static_cast<unsigned char>(8u << k);
    }
  setup_rest_neighbours(ctx);
}

// Rest neighbours: when a mesh's edges are about its thickness (twisting sheet at 225x113 nodes: 2.2 mm
// edges, 2 mm thickness), features that share no vertex but are neighbours in the rest mesh (a vertex and the
// triangle across the diagonal of its quad: 1.6 mm apart) lie within the thickness at rest, so they would be
// "in contact" for good: a repulsion impulse against the cloth's own elasticity every step on every such
// feature, vertices moved everywhere, every triangle pair searched again. Such a pair is one patch of cloth,
// not two surfaces touching; its pair thickness is capped at half its rest distance (min(thickness, d_rest /
// 2): continuous in d_rest, so only features closer than twice the thickness at rest are affected). Like
// every feature it stays in the continuous passes and the impact zones, with the capped (non-zero)
// separation, so it can never cross: no intersection is given up. Pairs between cloths are never capped (no
// rest relation between two cloths).
void SelfCollisionStage::setup_rest_neighbours(const loom::cloth::StageContext& ctx) {
  struct Near {
    int a, b;
    float cap;
    bool operator<(const Near& o) const { return a != o.a ? a < o.a : b < o.b; }
  };
  std::vector<Near> vf, ee;
  for (int c = 0; c < num_cloths_ && settings_.self; ++c) {
    const Vec3s& r = ctx.cloths[c]->mesh().rest_positions();
    const int vo = vertex_offset_[c], to = tri_offset_[c];
    const double reach = 2.0 * cloth_thickness_[c];  // m: rest distances below it give a cap below the thickness
    if (!(reach > 0.0)) continue;
    // Candidate triangle pairs: rest boxes inflated by half the reach on each side overlap.
    ClothBvh rest_tree(ctx.cloths[c]->mesh_ptr());
    rest_tree.refit(r, r, 0.5 * reach);
    for (const TrianglePair& p : rest_tree.self_pairs(false)) {
      const int ga = to + p.first, gb = to + p.second;
      for (int side = 0; side < 2; ++side) {
        const Tri& tv = tris_[side ? gb : ga];
        const Tri& tf = tris_[side ? ga : gb];
        const int f = side ? ga : gb;
        for (int k = 0; k < 3; ++k) {
          const int v = tv[k];
          if (v == tf[0] || v == tf[1] || v == tf[2]) continue;
          const double d2 = point_triangle_closest(r[v - vo], r[tf[0] - vo], r[tf[1] - vo], r[tf[2] - vo]).distance_squared;
          if (d2 < reach * reach) vf.push_back({v, f, static_cast<float>(0.5 * std::sqrt(d2))});
        }
      }
      for (int k = 0; k < 3; ++k)
        for (int m = 0; m < 3; ++m) {
          const int ea = tri_edges_[ga][k], eb = tri_edges_[gb][m];
          const auto& a = edges_[ea];
          const auto& b = edges_[eb];
          if (a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1]) continue;
          const double d2 = segment_segment_closest(r[a[0] - vo], r[a[1] - vo], r[b[0] - vo], r[b[1] - vo]).distance_squared;
          if (d2 < reach * reach) ee.push_back({std::min(ea, eb), std::max(ea, eb), static_cast<float>(0.5 * std::sqrt(d2))});
        }
    }
  }
  // CSR by the first index, sorted by the second, duplicates (a feature seen from several pairs) removed.
  auto csr = [](std::vector<Near>& in, int n, std::vector<int>& start, std::vector<std::pair<int, float>>& out) {
    std::sort(in.begin(), in.end());
    in.erase(std::unique(in.begin(), in.end(), [](const Near& x, const Near& y) { return x.a == y.a && x.b == y.b; }),
             in.end());
    start.assign(n + 1, 0);
    for (const Near& e : in) ++start[e.a + 1];
    for (int i = 0; i < n; ++i) start[i + 1] += start[i];
    out.resize(in.size());
    for (size_t i = 0; i < in.size(); ++i) out[i] = {in[i].b, in[i].cap};
  };
  csr(vf, vertex_offset_[num_cloths_], rest_vf_start_, rest_vf_);
  csr(ee, static_cast<int>(edges_.size()), rest_ee_start_, rest_ee_);
}

float SelfCollisionStage::rest_cap(const Feature& f) const {
  const std::vector<int>& start = f.type == 0 ? rest_vf_start_ : rest_ee_start_;
  const std::vector<std::pair<int, float>>& list = f.type == 0 ? rest_vf_ : rest_ee_;
  const auto end = list.begin() + start[f.a + 1];
  const auto it = std::lower_bound(list.begin() + start[f.a], end, f.b,
                                   [](const std::pair<int, float>& e, int b) { return e.first < b; });
  return it != end && it->first == f.b ? it->second : HUGE_VALF;
}

void SelfCollisionStage::update_bvhs(int threads, bool full_update) {
  PhaseTimer timer(bvh_ms_);
  for (int c = 0; c < num_cloths_; ++c) {
    const int vo = vertex_offset_[c], n = vertex_offset_[c + 1] - vo;
    Vec3s& a = cx0_[c];
    Vec3s& b = cx1_[c];
    if (full_update) a.assign(x0_.begin() + vo, x0_.begin() + vo + n);  // x0 is fixed during the step
    b.assign(x1_.begin() + vo, x1_.begin() + vo + n);
    const double half = 0.5 * cloth_thickness_[c];
    if (full_update) {
      bvh_rebuilds_ += bvhs_[c]->update(a, b, half, threads);
    } else {
      // Within the step only box queries follow (triangle_pairs_touching): the cones, a third of a full
      // refit's time (an acos per leaf, an acos and two sines per node), wait for the next step.
      bvhs_[c]->refit(a, b, half, threads, false);
    }
  }
}

// I-Cloth's Td x (Td u Ts): triangles with a dirty vertex, queried against every cloth's refitted tree.
// The dirty triangles' queries run in parallel over contiguous chunks of the dirty list, joined in chunk
// order, then sorted: the same pairs for any thread count.
std::vector<TrianglePair> SelfCollisionStage::triangle_pairs_touching(const std::vector<char>& dirty, int threads) {
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
  std::vector<TrianglePair> out = in_chunks<TrianglePair>(static_cast<long>(list.size()), threads, 512, 8, query);
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
std::vector<SelfCollisionStage::Feature> SelfCollisionStage::extract_in_chunks(const std::vector<TrianglePair>& pairs,
                                                                              const std::vector<char>* dirty,
                                                                              int threads) const {
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
      const std::vector<std::pair<int, int>> tasks = bvh.self_pair_tasks(cx0_[c], cx1_[c], cloth_thickness_[c], &culled);
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
      for (const TrianglePair& p : bvhs_[c]->self_pairs(false)) pairs.emplace_back(tri_offset_[c] + p.first, tri_offset_[c] + p.second);
    for (int d = c + 1; d < num_cloths_; ++d)
      for (const TrianglePair& p : bvhs_[c]->cross_pairs(*bvhs_[d])) pairs.emplace_back(tri_offset_[c] + p.first, tri_offset_[d] + p.second);
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

// Shares beta_k of a contact's velocity change dv per vertex (vertex k changes by beta_k dv), with
// sum_k w_k beta_k = 1 so the contact's relative velocity changes by dv. Bridson et al. 2002, Sec. 7.1 take
// the least mass-weighted change, beta_k = lambda w_k m_k^-1 with lambda = 1 / sum_j w_j^2 m_j^-1 (m^-1 = the
// stage's inverse masses `im`). The same least change under the bound |beta_k| <= cap: beta_k =
// sign(w_k) min(cap, lambda |w_k| m_k^-1), with lambda raised until the constraint holds again (the vertices
// over the bound are capped one round at a time; once capped, a vertex stays capped as lambda only grows).
// Without the bound, a contact point next to a vertex the body stage left near a collider (1000 times heavier
// here) is moved by flicking the feature's far vertex at 1/w_k times the contact's change. Where only
// vertices that cannot move (m^-1 = 0) could take the rest, every vertex that can move takes the bound and
// the rest of the change is left to the next pass and the impact zones (Bridson's unbounded shares would
// flick a free vertex at many times the contact's change there).
bool capped_shares(const double w[4], const double im[4], int first, double cap, double beta[4]) {
  double denom = 0.0;
  for (int k = 0; k < 4; ++k) denom += w[k] * w[k] * im[k];
  if (!(denom > 0.0)) return false;
  for (int k = 0; k < 4; ++k) beta[k] = w[k] * im[k] / denom;
  if (!(cap > 0.0)) return true;
  bool capped[4] = {false, false, false, false};
  for (;;) {  // each further round caps at least one more movable vertex: at most 5 rounds
    double rest = 1.0, free_denom = 0.0;
    for (int k = 0; k < 4; ++k) {
      if (capped[k]) rest -= cap * std::abs(w[k]);
      else free_denom += w[k] * w[k] * im[k];
    }
    // Infeasible: every movable vertex of the contact is at the bound (or, by rounding, the capped ones
    // already give the whole change). Every movable vertex of both features takes the bound on its feature's
    // side, those with w_k = 0 too (a contact on a triangle's edge): each feature moves as a block and keeps
    // its shape. Moving only the w_k != 0 vertices sheared the features: the 30 cm box with PBD then failed
    // with 65 new intersecting triangle pairs (tests/stability, crushed_in_shrinking_box_to_30_cm_pbd).
    if (!(free_denom > 0.0) || !(rest > 0.0)) {
      for (int k = 0; k < 4; ++k) beta[k] = im[k] > 0.0 ? (k < first ? cap : -cap) : 0.0;
      return true;
    }
    const double lambda = rest / free_denom;
    bool more = false;
    for (int k = 0; k < 4; ++k)
      if (!capped[k] && lambda * std::abs(w[k]) * im[k] > cap * (1.0 + 1e-9)) capped[k] = more = true;  // rounding
    if (more) continue;
    for (int k = 0; k < 4; ++k) beta[k] = capped[k] ? std::copysign(cap, w[k]) : lambda * w[k] * im[k];
    return true;
  }
}

// Per-contact velocity changes dv[4] (m/s) are applied per vertex: averaged over the vertex's contacts, in
// the contacts' (sorted) order, so the result does not depend on the thread count.
namespace {

struct Impulse {  // a contact's velocity changes (m/s) of its four vertices; inactive: a hit without one
  int v[4] = {0, 0, 0, 0};
  Vec3 dv[4];
  bool active = false;
};

// Runs body(i, out) for every feature i in [0, n) (in_chunks): the impulses in the order of i whatever the
// thread count, with no per-feature storage (most features give nothing).
template <class Body>
std::vector<Impulse> collect_impulses(long n, int threads, Body body) {
  return in_chunks<Impulse>(n, threads, 4096, 8, [&](long begin, long end, std::vector<Impulse>& out) {
    for (long i = begin; i < end; ++i) body(i, out);
  });
}

void apply_impulses(const std::vector<Impulse>& imp, double h, Vec3s& x1, std::vector<char>* moved) {
  std::vector<int> touched;
  static thread_local std::vector<Vec3> sum;
  static thread_local std::vector<int> count;
  if (sum.size() < x1.size()) sum.assign(x1.size(), Vec3::Zero()), count.assign(x1.size(), 0);
  for (const Impulse& im : imp) {
    if (!im.active) continue;
    for (int k = 0; k < 4; ++k) {
      const int v = im.v[k];
      if (im.dv[k].isZero(0.0)) continue;
      if (count[v] == 0) touched.push_back(v);
      sum[v] += im.dv[k];
      ++count[v];
    }
  }
  for (int v : touched) {
    x1[v] += h * (sum[v] / count[v]);
    if (moved) (*moved)[v] = 1;
    sum[v].setZero();
    count[v] = 0;
  }
}

}  // namespace

// Bridson et al. 2002, Sec. 7.2: pairs closer than the thickness at the step's start get an impulse that
// removes `repulsion` of the overlap per step along the normal; Sec. 7.3: Coulomb friction clamps the
// tangential relative velocity by mu * (normal velocity change) (static: stop it entirely).
void SelfCollisionStage::proximity(std::vector<Feature>& fs, int threads, std::vector<char>& moved) {
  PhaseTimer timer(proximity_ms_);
  const long n = static_cast<long>(fs.size());
  const std::vector<Impulse> imp = collect_impulses(n, threads, [&](long i, std::vector<Impulse>& out) {
    const Contact c = contact_of(fs[i]);
    const double hp = pair_thickness(c);
    const Vec3& p0 = x0_[c.v[0]];
    const Vec3& p1 = x0_[c.v[1]];
    const Vec3& p2 = x0_[c.v[2]];
    const Vec3& p3 = x0_[c.v[3]];
    {
      // Cheap rejection: the two features' boxes at x0 farther apart than the thickness on some axis.
      Aabb ba, bb;
      ba.grow(p0);
      (fs[i].type == 0 ? bb : ba).grow(p1);
      bb.grow(p2), bb.grow(p3);
      if (!ba.overlaps_within(bb, hp)) {
        fs[i].d0 = lower_float(ba.gap(bb));  // the largest axis gap of the boxes: below the distance
        return;
      }
    }
    double w[4];
    double d2;
    Vec3 fallback;
    if (fs[i].type == 0) {
      const PointTriangleClosest r = point_triangle_closest(p0, p1, p2, p3);
      d2 = r.distance_squared;
      w[0] = 1.0, w[1] = -r.weights[0], w[2] = -r.weights[1], w[3] = -r.weights[2];
      fallback = (p2 - p1).cross(p3 - p1);
    } else {
      const SegmentSegmentClosest r = segment_segment_closest(p0, p1, p2, p3);
      d2 = r.distance_squared;
      w[0] = 1.0 - r.s, w[1] = r.s, w[2] = -(1.0 - r.t), w[3] = -r.t;
      fallback = (p1 - p0).cross(p3 - p2);
    }
    const double d = std::sqrt(d2);
    fs[i].d0 = lower_float(d);
    if (!(d2 < hp * hp)) return;
    Vec3 diff = Vec3::Zero(), vrel = Vec3::Zero();
    double im_k[4], beta[4];
    for (int k = 0; k < 4; ++k) {
      diff += w[k] * x0_[c.v[k]];
      vrel += w[k] * (x1_[c.v[k]] - x0_[c.v[k]]) / h_;
      im_k[k] = w_[c.v[k]];
    }
    if (!capped_shares(w, im_k, fs[i].type == 0 ? 1 : 2, settings_.max_share, beta)) return;
    Vec3 nrm;
    if (!contact_normal(diff, fallback, vrel, nrm)) return;
    const double vn = vrel.dot(nrm);
    const double target = settings_.repulsion * (hp - d) / h_;  // m/s
    if (!(vn < target)) return;
    const double dvn = target - vn;
    const double mu_k = pair_mu_k_[c.cloth_a * num_cloths_ + c.cloth_b];
    const double mu_s = pair_mu_s_[c.cloth_a * num_cloths_ + c.cloth_b];
    const Vec3 vt = vrel - vn * nrm;
    const double vtn = vt.norm();
    Vec3 dv = dvn * nrm;
    if (vtn <= mu_s * dvn) {
      dv -= vt;  // static friction: the tangential relative motion stops
    } else if (vtn > 0.0) {
      dv -= (mu_k * dvn / vtn) * vt;  // kinetic: reduced by mu * dvn, never reversed (vtn > mu_s dvn >= ...)
    }
    Impulse& im = out.emplace_back();
    im.active = true;
    for (int k = 0; k < 4; ++k) im.v[k] = c.v[k], im.dv[k] = beta[k] * dv;
  });
  contacts_ += static_cast<long>(imp.size());
  apply_impulses(imp, h_, x1_, &moved);
}

// The first continuous pass's features from the proximity phase's `fs` (I-Cloth's incremental sets): the
// features of triangle pairs with no vertex moved by proximity impulses are unchanged (same boxes, same
// features); those of pairs touching a moved vertex are dropped and found again from the refitted trees
// (triangle_pairs_touching, not culled). A feature belongs to one pair only (its owner pair, see features()).
void SelfCollisionStage::first_pass_features(std::vector<Feature>& fs, const std::vector<char>& moved, int threads) {
  if (std::none_of(moved.begin(), moved.end(), [](char m) { return m != 0; })) return;
  update_bvhs(threads, false);
  std::vector<char> td(tris_.size(), 0);  // triangles with a moved vertex
  for (int v = 0; v < static_cast<int>(moved.size()); ++v)
    if (moved[v])
      for (int k = vtx_tri_start_[v]; k < vtx_tri_start_[v + 1]; ++k) td[vtx_tri_[k]] = 1;
  fs.erase(std::remove_if(fs.begin(), fs.end(),
                          [&](const Feature& f) {
                            return f.type == 0 ? td[vtx_tri_[vtx_tri_start_[f.a]]] || td[f.b]
                                               : td[edge_owner_[f.a]] || td[edge_owner_[f.b]];
                          }),
           fs.end());
  const std::vector<Feature> redo = features(triangle_pairs_touching(moved, threads), nullptr, threads);
  fs.insert(fs.end(), redo.begin(), redo.end());
}

// Continuous test of every feature on x0 -> x1 with minimum separation; hits approaching along the contact
// normal at the time of impact get the inelastic impulse that cancels the approach (Bridson 2002, Sec. 7.4).
bool SelfCollisionStage::ccd_pass(const std::vector<Feature>& fs, int threads, std::vector<char>& dirty) {
  PhaseTimer timer(ccd_ms_);
  const long n = static_cast<long>(fs.size());
  long tests = 0, boxes = 0, start_hits = 0;
  // Every hit is recorded (its vertices are retested next pass); `active` when it gives an impulse.
  const std::vector<Impulse> imp = collect_impulses(n, threads, [&](long i, std::vector<Impulse>& out) {
    const Contact c = contact_of(fs[i]);
    const Vec3 *a0[4], *a1[4];
    for (int k = 0; k < 4; ++k) a0[k] = &x0_[c.v[k]], a1[k] = &x1_[c.v[k]];
    // Cheap rejection: swept boxes farther apart than the separation on some axis.
    const double sep = settings_.separation * pair_thickness(c);
    Aabb ba, bb;
    const int split = fs[i].type == 0 ? 1 : 2;
    for (int k = 0; k < 4; ++k) (k < split ? ba : bb).grow(*a0[k]), (k < split ? ba : bb).grow(*a1[k]);
    ba.lo.array() -= sep, ba.hi.array() += sep;
    if (!ba.overlaps(bb)) return;
    // Cheap rejection 2: distance at t = 0 minus how much it can shrink during the step. For points moving
    // linearly, the distance between the two features changes by at most the largest relative displacement
    // |dx_i - dx_j| over one vertex i of the first feature and one vertex j of the second (a point of either
    // feature is a fixed convex combination of its vertices), so d(0) > sep + that bound proves d(t) > sep
    // on the whole step: the continuous test could only find a false positive.
    bool at_start = false;  // closer than the separation at t = 0 already
    {
      Vec3 dx[4];
      for (int k = 0; k < 4; ++k) dx[k] = *a1[k] - *a0[k];
      double reach2 = 0.0;
      for (int k = 0; k < split; ++k)
        for (int m = split; m < 4; ++m) reach2 = std::max(reach2, (dx[k] - dx[m]).squaredNorm());
      const double bound = (sep + std::sqrt(reach2)) * (1.0 + 1e-9);
      if (fs[i].d0 > bound) return;  // the proximity phase's lower bound on d(0) already proves it
      const double d0 = std::sqrt(fs[i].type == 0 ? point_triangle_closest(*a0[0], *a0[1], *a0[2], *a0[3]).distance_squared
                                                   : segment_segment_closest(*a0[0], *a0[1], *a0[2], *a0[3]).distance_squared);
      if (d0 > bound) return;
      at_start = d0 <= sep;
    }
    // A pair closer than the separation at the step's start is a contact at t = 0: reported as a hit with
    // time of impact 0 without the continuous test, whose answer could only be a hit with a time of impact
    // near 0, found after refining its boxes down to the tolerance (a hit cost 200-270 boxes, a miss 8, on
    // the Sphere at 50k triangles). A hit is always allowed (conservative), so nothing can be missed this
    // way.
    CcdResult r;
    if (at_start) {
      r.hit = true;
      r.toi = 0.0;
#pragma omp atomic
      ++start_hits;
    } else {
      CcdOptions opt;
      opt.min_separation = sep;
      opt.tolerance = 1e-4;     // of the query's extent: a few micrometres at cloth scale, well below sep
      opt.toi_tolerance = 1e-2;  // the time of impact only places the contact normal
      opt.toi_max_boxes = 64;
      r = fs[i].type == 0 ? vertex_face_ccd(*a0[0], *a0[1], *a0[2], *a0[3], *a1[0], *a1[1], *a1[2], *a1[3], opt)
                          : edge_edge_ccd(*a0[0], *a0[1], *a0[2], *a0[3], *a1[0], *a1[1], *a1[2], *a1[3], opt);
#pragma omp atomic
      ++tests;
#pragma omp atomic
      boxes += r.boxes;
    }
    if (!r.hit) return;
    Impulse& im = out.emplace_back();
    for (int k = 0; k < 4; ++k) im.v[k] = c.v[k];
    Vec3 q[4];
    for (int k = 0; k < 4; ++k) q[k] = *a0[k] + r.toi * (*a1[k] - *a0[k]);
    double w[4];
    Vec3 fallback;
    if (fs[i].type == 0) {
      const PointTriangleClosest cl = point_triangle_closest(q[0], q[1], q[2], q[3]);
      w[0] = 1.0, w[1] = -cl.weights[0], w[2] = -cl.weights[1], w[3] = -cl.weights[2];
      fallback = (q[2] - q[1]).cross(q[3] - q[1]);
    } else {
      const SegmentSegmentClosest cl = segment_segment_closest(q[0], q[1], q[2], q[3]);
      w[0] = 1.0 - cl.s, w[1] = cl.s, w[2] = -(1.0 - cl.t), w[3] = -cl.t;
      fallback = (q[1] - q[0]).cross(q[3] - q[2]);
    }
    Vec3 diff = Vec3::Zero(), side = Vec3::Zero(), vrel = Vec3::Zero();
    double im_k[4], beta[4];
    for (int k = 0; k < 4; ++k) {
      diff += w[k] * q[k];
      side += w[k] * *a0[k];
      vrel += w[k] * (*a1[k] - *a0[k]) / h_;
      im_k[k] = w_[c.v[k]];
    }
    if (!capped_shares(w, im_k, fs[i].type == 0 ? 1 : 2, settings_.max_share, beta)) return;
    Vec3 nrm;
    if (!contact_normal(diff, fallback, side, nrm)) return;
    const double vn = vrel.dot(nrm);
    if (!(vn < 0.0)) return;
    im.active = true;
    const Vec3 dv = -vn * nrm;
    for (int k = 0; k < 4; ++k) im.dv[k] = beta[k] * dv;
  });
  ccd_tests_ += tests;
  ccd_boxes_ += boxes;
  ccd_start_hits_ += start_hits;
  std::fill(dirty.begin(), dirty.end(), 0);
  for (const Impulse& im : imp) {
    contacts_ += im.active;
    for (int k = 0; k < 4; ++k) dirty[im.v[k]] = 1;  // retested next pass even if not moved
  }
  apply_impulses(imp, h_, x1_, &dirty);
  return !imp.empty();
}

// Provot 1997 rigid impact zone: velocities (x1 - x0) / h of the zone's vertices replaced by the rigid motion
// with the same linear and angular momentum about the centre of mass at x0 (linearised rotation).
// With kinematic (pinned) vertices: those keep their end positions; the others follow the pinned vertices'
// best-fit rotation and translation (Kabsch 1976), translation only when fewer than three non-collinear
// pinned vertices leave the rotation undetermined. That case is not guaranteed.
void SelfCollisionStage::apply_rigid_zone(const std::vector<int>& verts_in) {
  std::vector<int> pinned, free;
  for (int v : verts_in) {
    if (fixed_[v]) fixed_[v] = 0, w_[v] = w_free_[v];  // held for a collider: moves with the zone, checked again
    (w_[v] == 0.0 ? pinned : free).push_back(v);
  }
  if (!pinned.empty()) {
    Vec3 c0 = Vec3::Zero(), c1 = Vec3::Zero();
    for (int v : pinned) c0 += x0_[v], c1 += x1_[v];
    c0 /= static_cast<double>(pinned.size()), c1 /= static_cast<double>(pinned.size());
    Mat3 R = Mat3::Identity();
    if (pinned.size() >= 3) {
      Mat3 H = Mat3::Zero();
      for (int v : pinned) H += (x0_[v] - c0) * (x1_[v] - c1).transpose();
      Eigen::JacobiSVD<Mat3> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Mat3 D = Mat3::Identity();
      if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0) D(2, 2) = -1.0;
      const Eigen::Vector3d sv = svd.singularValues();
      if (sv[1] > 1e-9 * sv[0]) R = svd.matrixV() * D * svd.matrixU().transpose();
    }
    for (int v : free) x1_[v] = c1 + R * (x0_[v] - c0);
    return;
  }
  const std::vector<int>& verts = free;
  {
    double mass = 0.0;
    Vec3 xc = Vec3::Zero(), vc = Vec3::Zero();
    for (int v : verts) {
      mass += m_[v];
      xc += m_[v] * x0_[v];
      vc += m_[v] * (x1_[v] - x0_[v]) / h_;
    }
    if (!(mass > 0.0)) return;
    xc /= mass, vc /= mass;
    Vec3 L = Vec3::Zero();
    Mat3 I = Mat3::Zero();
    for (int v : verts) {
      const Vec3 r = x0_[v] - xc;
      L += m_[v] * r.cross((x1_[v] - x0_[v]) / h_ - vc);
      I += m_[v] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
    }
    const Vec3 omega = I.completeOrthogonalDecomposition().solve(L);
    for (int v : verts) x1_[v] = x0_[v] + h_ * (vc + omega.cross(x0_[v] - xc));
  }
}

// Harmon, Vouga, Tamstorf, Grinspun 2008, "Robust treatment of simultaneous collisions", Sec. 4 (inelastic
// projection): the zone's end positions x1 are changed as little as possible in the mass metric,
//   min sum_k m_k |x1'_k - x1_k|^2  s.t.  n_c . sum_i w_ci x1'_ci >= b_c  for every contact c of the zone,
// (the relative position along the contact normal at the end of the step at least a small gap past the one at
// the time of impact), which cancels the approach along the normals but keeps tangential (sliding) motion.
// Solved by projected Gauss-Seidel on the multipliers (lambda_c >= 0) in constraint order, so the result does
// not depend on the thread count. Kinematic vertices (inverse mass 0) do not move. Returns false if it did
// not converge (the constraints can be infeasible, e.g. a layer squeezed between two others); the caller then
// restores the zone and moves it rigidly.
bool SelfCollisionStage::project_zone(const std::vector<int>& constraints) {
  const int nc = static_cast<int>(constraints.size());
  std::vector<double> lambda(nc, 0.0), denom(nc, 0.0);
  for (int k = 0; k < nc; ++k) {
    const ZoneConstraint& c = zone_constraints_[constraints[k]];
    for (int i = 0; i < 4; ++i) denom[k] += c.w[i] * c.w[i] * w_[c.v[i]];
  }
  for (int it = 0; it < 200; ++it) {
    double worst = 0.0;
    for (int k = 0; k < nc; ++k) {
      if (!(denom[k] > 0.0)) continue;
      const ZoneConstraint& c = zone_constraints_[constraints[k]];
      double g = -c.b;
      for (int i = 0; i < 4; ++i) g += c.w[i] * c.n.dot(x1_[c.v[i]]);
      const double dl = std::max(-lambda[k], -g / denom[k]);
      if (dl == 0.0) continue;
      lambda[k] += dl;
      for (int i = 0; i < 4; ++i) x1_[c.v[i]] += (dl * c.w[i] * w_[c.v[i]]) * c.n;
      worst = std::max(worst, std::abs(dl) * denom[k]);
    }
    if (worst < 1e-10) return true;  // m: every constraint met to 0.1 nm
  }
  return false;
}

// Impact-zone fail-safe: test pairs touching `dirty` vertices (continuous, separation 0); vertices of hits
// are merged into zones (union-find); every changed zone is first handled by inelastic projection over all
// the contacts it has collected this step (project_zone); a zone that still collides after `kProjections`
// projections, or that merges with a rigid one, moves rigidly from then on (Provot's rigid impact zone, the
// last resort, apply_rigid_zone). Repeat until no hit. Pairs inside one rigid zone are skipped (it moves
// affinely from its intersection-free start). Returns false if the iteration cap forced one global zone.
bool SelfCollisionStage::impact_zones(std::vector<char> dirty, int threads) {
  PhaseTimer timer(zones_ms_);
  constexpr int kProjections = 4;
  const int nv = static_cast<int>(x0_.size());
  zone_parent_.assign(nv, -1);
  zone_constraints_.clear();
  std::vector<int> zone_rounds(nv, 0);  // per root: rounds done (> kProjections: moved rigidly)
  auto root_of = [&](int v) {
    while (zone_parent_[v] != v) v = zone_parent_[v];
    return v;
  };
  for (int it = 0; it < settings_.max_zone_iterations; ++it) {
    if (std::none_of(dirty.begin(), dirty.end(), [](char d) { return d != 0; })) return true;
    update_bvhs(threads, false);
    const std::vector<Feature> fs = features(triangle_pairs_touching(dirty, threads), &dirty, threads);
    const long n = static_cast<long>(fs.size());
    std::vector<char> hit(n, 0);
    std::vector<ZoneConstraint> found(n);
    // A query that has not settled after kZoneCcdBoxes boxes is a hit (conservative: the zone gets one
    // constraint more). Features crushed flat against each other, just outside the separation over a whole
    // patch, otherwise refine that patch at the 1e-6 tolerance to the default budget of 2^18 boxes: in the
    // 30 cm crushed box (test_stability_collisions.cpp, desbrun) the 7,146 queries that spent that budget
    // took 1.87e9 of the run's 2.55e9 boxes and the run 135 s; 16 s with this budget (of the 36 collision
    // stability rows, one other ends with other figures, still within every bound).
    CcdOptions opt;
    opt.toi_tolerance = 1e-2;
    opt.toi_max_boxes = 32;
    opt.max_boxes = kZoneCcdBoxes;
    long cut = 0;
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(dynamic, 256) reduction(+ : cut)
    for (long i = 0; i < n; ++i) {
      const Contact c = contact_of(fs[i]);
      // Pairs inside one rigid zone move affinely with it and stay apart.
      if (zone_parent_[c.v[0]] >= 0) {
        const int r = root_of(c.v[0]);
        bool same = zone_rounds[r] > kProjections;
        for (int k = 1; k < 4 && same; ++k) same = zone_parent_[c.v[k]] >= 0 && root_of(c.v[k]) == r;
        if (same) continue;
      }
      const Vec3 *a0[4], *a1[4];
      for (int k = 0; k < 4; ++k) a0[k] = &x0_[c.v[k]], a1[k] = &x1_[c.v[k]];
      Aabb ba, bb;
      const int split = fs[i].type == 0 ? 1 : 2;
      for (int k = 0; k < 4; ++k) (k < split ? ba : bb).grow(*a0[k]), (k < split ? ba : bb).grow(*a1[k]);
      if (!ba.overlaps(bb)) continue;
      const CcdResult r = fs[i].type == 0 ? vertex_face_ccd(*a0[0], *a0[1], *a0[2], *a0[3], *a1[0], *a1[1], *a1[2], *a1[3], opt)
                                          : edge_edge_ccd(*a0[0], *a0[1], *a0[2], *a0[3], *a1[0], *a1[1], *a1[2], *a1[3], opt);
      cut += r.budget_exhausted;
      if (!r.hit) continue;
      hit[i] = 1;
      // The constraint of this contact: normal and weights at the time of impact; the gap to keep at the end
      // of the step is a tenth of the pair thickness past the relative position at the time of impact.
      Vec3 q[4];
      for (int k = 0; k < 4; ++k) q[k] = *a0[k] + r.toi * (*a1[k] - *a0[k]);
      ZoneConstraint& zc = found[i];
      Vec3 fallback;
      if (fs[i].type == 0) {
        const PointTriangleClosest cl = point_triangle_closest(q[0], q[1], q[2], q[3]);
        zc.w[0] = 1.0, zc.w[1] = -cl.weights[0], zc.w[2] = -cl.weights[1], zc.w[3] = -cl.weights[2];
        fallback = (q[2] - q[1]).cross(q[3] - q[1]);
      } else {
        const SegmentSegmentClosest cl = segment_segment_closest(q[0], q[1], q[2], q[3]);
        zc.w[0] = 1.0 - cl.s, zc.w[1] = cl.s, zc.w[2] = -(1.0 - cl.t), zc.w[3] = -cl.t;
        fallback = (q[1] - q[0]).cross(q[3] - q[2]);
      }
      Vec3 diff = Vec3::Zero(), side = Vec3::Zero();
      for (int k = 0; k < 4; ++k) diff += zc.w[k] * q[k], side += zc.w[k] * *a0[k];
      for (int k = 0; k < 4; ++k) zc.v[k] = c.v[k];
      if (!contact_normal(diff, fallback, side, zc.n)) {
        zc.n = Vec3::Zero();  // no usable normal: the zone will have to go rigid
        continue;
      }
      zc.b = zc.n.dot(diff) + 0.1 * pair_thickness(c);
    }
    zone_ccd_cut_ += cut;
    // Merge (serial, in feature order).
    std::vector<int> roots_changed;
    bool any = false;
    for (long i = 0; i < n; ++i) {
      if (!hit[i]) continue;
      any = true;
      const Contact c = contact_of(fs[i]);
      for (int k = 0; k < 4; ++k)
        if (zone_parent_[c.v[k]] < 0) zone_parent_[c.v[k]] = c.v[k], ++impact_zones_;
      for (int k = 1; k < 4; ++k) {
        const int a = find_root(zone_parent_, c.v[0]), b = find_root(zone_parent_, c.v[k]);
        if (a != b) {
          const int lo = std::min(a, b), hi = std::max(a, b);
          zone_parent_[hi] = lo, --impact_zones_;
          zone_rounds[lo] = std::max(zone_rounds[lo], zone_rounds[hi]);
        }
      }
      if (found[i].n.isZero(0.0)) {
        zone_rounds[find_root(zone_parent_, c.v[0])] = kProjections;
      } else {
        zone_constraints_.push_back(found[i]);
      }
      roots_changed.push_back(c.v[0]);
    }
    std::fill(dirty.begin(), dirty.end(), 0);
    if (!any) return true;
    ++zone_iterations_;
    std::vector<char> root_mark(nv, 0);
    for (int v : roots_changed) root_mark[find_root(zone_parent_, v)] = 1;
    std::vector<std::vector<int>> zones, constraints;
    std::vector<int> zone_index(nv, -1);
    for (int v = 0; v < nv; ++v) {
      if (zone_parent_[v] < 0) continue;
      const int r = find_root(zone_parent_, v);
      if (!root_mark[r]) continue;
      if (zone_index[r] < 0) zone_index[r] = static_cast<int>(zones.size()), zones.emplace_back(), constraints.emplace_back();
      zones[zone_index[r]].push_back(v);
    }
    for (int k = 0; k < static_cast<int>(zone_constraints_.size()); ++k) {
      const int z = zone_index[find_root(zone_parent_, zone_constraints_[k].v[0])];
      if (z >= 0) constraints[z].push_back(k);
    }
    for (size_t z = 0; z < zones.size(); ++z) {
      int& rounds = zone_rounds[find_root(zone_parent_, zones[z][0])];
      bool done = false;
      if (rounds < kProjections) {
        std::vector<Vec3> saved(zones[z].size());
        for (size_t k = 0; k < zones[z].size(); ++k) saved[k] = x1_[zones[z][k]];
        ++projections_;
        done = project_zone(constraints[z]);
        if (!done) {
          for (size_t k = 0; k < zones[z].size(); ++k) x1_[zones[z][k]] = saved[k];
          rounds = kProjections;  // not solvable by projection: rigid now
        }
      }
      if (!done) {
        if (rounds == kProjections) ++rigid_zones_;
        apply_rigid_zone(zones[z]);
      }
      ++rounds;
      for (int v : zones[z]) dirty[v] = 1;
    }
  }
  // Last resort: everything moves as one rigid zone (Provot 1997: from an intersection-free start, the
  // linearised rigid motion is an invertible affine map at every t).
  std::vector<int> all(nv);
  for (int v = 0; v < nv; ++v) all[v] = v;
  apply_rigid_zone(all);
  ++unresolved_;
  return false;
}

// Steps 3-4: continuous passes (the first over `first` when given, every candidate pair's features, else over
// pairs touching `dirty`), then the impact-zone fail-safe if a pass still hit.
void SelfCollisionStage::resolve(std::vector<char>& dirty, const std::vector<Feature>* first, int threads) {
  bool hits = true;
  for (int pass = 0; pass < settings_.passes && hits; ++pass) {
    if (pass == 0 && first) {
      hits = ccd_pass(*first, threads, dirty);  // the trees are up to date with x1 (first_pass_features)
    } else {
      update_bvhs(threads, false);
      hits = ccd_pass(features(triangle_pairs_touching(dirty, threads), &dirty, threads), threads, dirty);
    }
    ++passes_;
  }
  if (hits) impact_zones(dirty, threads);
}

// One collider round: every free vertex this stage moved is handed back to the body stage
// (BodyCollisionStage::revisit_vertex). Those it acts on take its position and velocity, become fixed
// (inverse mass 0 here) and are marked in `dirty` (cleared first). Returns whether any was acted on.
bool SelfCollisionStage::collider_round(loom::cloth::StageContext& ctx, std::vector<char>& dirty, int threads) {
  const int nv = static_cast<int>(x1_.size());
  std::fill(dirty.begin(), dirty.end(), 0);
  std::vector<int> moved;
  for (int v = 0; v < nv; ++v)
    if (w_[v] > 0.0 && !(x1_[v] - x1_solver_[v]).isZero(0.0)) moved.push_back(v);
  const long n = static_cast<long>(moved.size());
  std::vector<char> acted(n, 0);
  std::vector<Vec3> vel(n);
  std::vector<std::vector<BodyCollisionStage::Reaction>> reactions(n);
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(dynamic, 64)
  for (long k = 0; k < n; ++k) {
    const int v = moved[k];
    const int c = vertex_cloth_[v];
    const int i = v - vertex_offset_[c];
    // The velocity this stage gives the vertex so far: the solver's, plus its position change over h.
    vel[k] = ctx.cloths[c]->state().v[i] + (x1_[v] - x1_solver_[v]) / h_;
    Vec3 x = x1_[v];
    acted[k] = body_->revisit_vertex(c, x0_[v], x1_solver_[v], x, vel[k], ctx.cloths[c]->state().mass[i], 0.5,
                                     reactions[k]);
    if (acted[k]) x1_[v] = x;
  }
  bool any = false;
  for (long k = 0; k < n; ++k) {
    if (!acted[k]) continue;
    const int v = moved[k];
    any = true;
    fixed_[v] = 1;
    fixed_v_[v] = vel[k];
    w_[v] = 0.0;
    dirty[v] = 1;
    ++collider_fixes_;
    body_->add_reactions(reactions[k]);
  }
  return any;
}

void SelfCollisionStage::run(loom::cloth::StageContext& ctx) {
  if (num_cloths_ != static_cast<int>(ctx.cloths.size())) setup(ctx);
  h_ = ctx.h;
  const int threads = ctx.threads;
  const int nv = vertex_offset_[num_cloths_];
  x0_.resize(nv), x1_.resize(nv), w_.resize(nv), m_.resize(nv), near_.resize(nv), fixed_v_.resize(nv), w_free_.resize(nv);
  for (int c = 0; c < num_cloths_; ++c) {
    const loom::cloth::ClothState& s = ctx.cloths[c]->state();
    const int vo = vertex_offset_[c];
    const std::vector<char>* near = body_ ? body_->near_collider(c) : nullptr;
    if (near && static_cast<int>(near->size()) != s.size()) near = nullptr;
    for (int i = 0; i < s.size(); ++i) {
      x0_[vo + i] = s.x_prev[i];
      x1_[vo + i] = s.x[i];
      near_[vo + i] = near && (*near)[i];
      const double f = near_[vo + i] ? settings_.near_body_mass : 1.0;
      w_[vo + i] = s.inv_mass[i] / f;
      w_free_[vo + i] = w_[vo + i];
      m_[vo + i] = s.mass[i] * f;
    }
  }
  x1_solver_ = x1_;
  fixed_.assign(nv, 0);

  update_bvhs(threads, true);
  // One search over all pairs per step: proximity uses its features, the first continuous pass the same ones
  // with those around vertices that proximity moved found again.
  std::vector<Feature> fs = all_features(threads);
  std::vector<char> dirty(nv, 0);
  proximity(fs, threads, dirty);
  first_pass_features(fs, dirty, threads);
  resolve(dirty, &fs, threads);
  // Colliders: the responses above may have moved a free vertex into a collider (or its path through one).
  // Such a vertex gets the body stage's vertex response again (continuous test, projection to the thickness,
  // velocity relative to the surface with friction) and is then held (inverse mass 0) for the rest of the
  // step; the vertices it was moved against are resolved again around it. Until none is left, at most
  // kColliderRounds rounds; the last round's projections stand, so no free vertex ends the step closer than
  // half its thickness to a collider.
  if (body_) {
    for (int round = 0;; ++round) {
      if (!collider_round(ctx, dirty, threads)) break;
      ++collider_rounds_;
      if (round == kColliderRounds) break;
      resolve(dirty, nullptr, threads);
    }
  }

  for (int c = 0; c < num_cloths_; ++c) {
    loom::cloth::ClothState& s = ctx.cloths[c]->state();
    const int vo = vertex_offset_[c];
    for (int i = 0; i < s.size(); ++i) {
      if (fixed_[vo + i]) {  // velocity from the collider response
        s.x[i] = x1_[vo + i];
        s.v[i] = fixed_v_[vo + i];
        continue;
      }
      const Vec3 dx = x1_[vo + i] - x1_solver_[vo + i];
      if (dx.isZero(0.0)) continue;
      s.x[i] = x1_[vo + i];
      s.v[i] += dx / h_;
    }
  }
}

}  // namespace loom::collision
