// Self- and cloth-cloth collision stage (SelfCollisionStage.h).
#include "loom/collision/SelfCollisionStage.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include "SelfCollisionInternal.h"
#include "loom/collision/BodyCollisionStage.h"
#include "loom/collision/Ccd.h"
#include "loom/collision/Distance.h"

namespace loom::collision {

using loom::cloth::Mat3;
using loom::cloth::Tri;
using loom::cloth::Vec3s;
using namespace self_collision_detail;

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
      const double k =
          settings_.friction >= 0.0 ? settings_.friction : 0.5 * (cloth_friction_[a] + cloth_friction_[b]);
      pair_mu_k_[a * num_cloths_ + b] = k;
      pair_mu_s_[a * num_cloths_ + b] =
          std::max(k, settings_.static_friction >= 0.0 ? settings_.static_friction : k);
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
    const double reach =
        2.0 * cloth_thickness_[c];  // m: rest distances below it give a cap below the thickness
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
          const double d2 =
              point_triangle_closest(r[v - vo], r[tf[0] - vo], r[tf[1] - vo], r[tf[2] - vo]).distance_squared;
          if (d2 < reach * reach) vf.push_back({v, f, static_cast<float>(0.5 * std::sqrt(d2))});
        }
      }
      for (int k = 0; k < 3; ++k)
        for (int m = 0; m < 3; ++m) {
          const int ea = tri_edges_[ga][k], eb = tri_edges_[gb][m];
          const auto& a = edges_[ea];
          const auto& b = edges_[eb];
          if (a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1]) continue;
          const double d2 = segment_segment_closest(r[a[0] - vo], r[a[1] - vo], r[b[0] - vo], r[b[1] - vo])
                                .distance_squared;
          if (d2 < reach * reach)
            ee.push_back({std::min(ea, eb), std::max(ea, eb), static_cast<float>(0.5 * std::sqrt(d2))});
        }
    }
  }
  // CSR by the first index, sorted by the second, duplicates (a feature seen from several pairs) removed.
  auto csr = [](std::vector<Near>& in, int n, std::vector<int>& start,
                std::vector<std::pair<int, float>>& out) {
    std::sort(in.begin(), in.end());
    in.erase(std::unique(in.begin(), in.end(),
                         [](const Near& x, const Near& y) { return x.a == y.a && x.b == y.b; }),
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
bool SelfCollisionStage::collider_round(loom::cloth::StageContext& ctx, std::vector<char>& dirty,
                                        int threads) {
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
  zone_budget_violation_.clear();
  const int threads = ctx.threads;
  const int nv = vertex_offset_[num_cloths_];
  x0_.resize(nv), x1_.resize(nv), w_.resize(nv), m_.resize(nv), near_.resize(nv), fixed_v_.resize(nv),
      w_free_.resize(nv);
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
