#include "loom/collision/BodyCollisionStage.h"

#include <algorithm>
#include <cmath>

#include "loom/collision/ColliderDistance.h"
#include "loom/collision/ColliderGeometry.h"
#include "loom/collision/SweptCollider.h"

namespace loom::collision {

using cloth::ClothState;

namespace {

constexpr int kChunk = 128;  // vertices per broad-phase query

Aabb swept_box(const Vec3& a, const Vec3& b, double margin) {
  Aabb box;
  box.grow(a);
  box.grow(b);
  box.lo -= Vec3::Constant(margin);
  box.hi += Vec3::Constant(margin);
  return box;
}

}  // namespace

BodyCollisionStage::BodyCollisionStage(ColliderSetPtr colliders, BodyCollisionSettings settings)
    : colliders_(std::move(colliders)), settings_(settings) {
  if (!colliders_) colliders_ = std::make_shared<ColliderSet>();
  settings_.max_passes = std::max(1, settings_.max_passes);
}

double BodyCollisionStage::thickness(int k, double material_thickness) const {
  const double own = (*colliders_)[k].thickness;
  if (own > 0.0) return own;
  return settings_.thickness > 0.0 ? settings_.thickness : material_thickness;
}

void BodyCollisionStage::run(cloth::StageContext& ctx) {
  ColliderSet& set = *colliders_;
  for (Collider& c : set) {
    if (c.motion) c.prev = c.motion(ctx.t), c.curr = c.motion(ctx.t + ctx.h);
    prepare_collider(c);
  }
  std::vector<double> margins(set.size(), 0.0);
  for (size_t k = 0; k < set.size(); ++k)
    for (const auto& cl : ctx.cloths)
      margins[k] = std::max(margins[k], thickness(static_cast<int>(k), cl->material().thickness));
  broad_phase_.update(set, margins);
  max_deficit_ = -HUGE_VAL;
  h_ = ctx.h;
  near_.resize(ctx.cloths.size());
  for (size_t c = 0; c < ctx.cloths.size(); ++c)
    run_cloth(*ctx.cloths[c], static_cast<int>(c), ctx.h, ctx.threads);
}

void BodyCollisionStage::run_cloth(cloth::Cloth& cloth, int cloth_index, double h, int threads) {
  ColliderSet& set = *colliders_;
  ClothState& s = cloth.state();
  const int n = s.size();
  std::vector<char>& near = near_[cloth_index];
  near.assign(n, 0);
  // Set below for the vertices left near a collider, when the solver reads them (settings_.contact_normals).
  if (settings_.contact_normals)
    s.contact_normal.assign(n, Vec3::Zero());
  else
    s.contact_normal.clear();
  if (static_cast<int>(pairs_.size()) <= cloth_index)
    pairs_.resize(cloth_index + 1), min_thickness_.resize(cloth_index + 1);
  std::vector<Pair>& pairs = pairs_[cloth_index];
  pairs.assign(set.size(), Pair());
  for (size_t k = 0; k < set.size(); ++k) {
    pairs[k].thickness = thickness(static_cast<int>(k), cloth.material().thickness);
    pairs[k].mu_k = settings_.friction.value_or(set[k].friction);
    pairs[k].mu_s = std::max(pairs[k].mu_k, settings_.static_friction.value_or(set[k].static_friction));
  }
  for (const FrictionPair& fp : settings_.friction_pairs) {
    if (fp.cloth != cloth_index || fp.collider < 0 || fp.collider >= static_cast<int>(set.size())) continue;
    pairs[fp.collider].mu_k = fp.friction;
    pairs[fp.collider].mu_s = std::max(fp.friction, fp.static_friction);
  }
  double max_th = 0.0, min_th = HUGE_VAL;
  for (const Pair& p : pairs) max_th = std::max(max_th, p.thickness), min_th = std::min(min_th, p.thickness);
  min_thickness_[cloth_index] = min_th;

  // Edges first, so the vertex phase (continuous test + projection) has the last word: no vertex ends the
  // step inside a collider because an edge correction pushed it there.
  std::vector<Reaction> edge_records;
  if (settings_.edges) run_edges(cloth, h, threads, edge_records);

  const int chunks = (n + kChunk - 1) / kChunk;
  std::vector<std::vector<Reaction>> records(chunks);
  struct ChunkCounts {
    long candidates = 0, contacts = 0, ccd_hits = 0, unresolved = 0;
    int passes = 0;
    double deficit = -HUGE_VAL;
  };
  std::vector<ChunkCounts> counts(chunks);

#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (threads > 1)
  for (int ch = 0; ch < chunks; ++ch) {
    const int begin = ch * kChunk, end = std::min(n, begin + kChunk);
    Aabb chunk_box;
    for (int i = begin; i < end; ++i) chunk_box.grow(s.x_prev[i]), chunk_box.grow(s.x[i]);
    chunk_box.lo -= Vec3::Constant(max_th), chunk_box.hi += Vec3::Constant(max_th);
    const std::vector<int> cands = broad_phase_.query(chunk_box);
    ChunkCounts& cc = counts[ch];
    std::vector<Reaction>& out = records[ch];
    if (cands.empty()) continue;
    std::vector<int> mine;
    std::vector<double> final_d;
    for (int i = begin; i < end; ++i) {
      if (s.inv_mass[i] == 0.0) continue;  // kinematic vertices follow their pins
      const Vec3 x0 = s.x_prev[i];
      Vec3 x = s.x[i], v = s.v[i];
      mine.clear();
      for (int k : cands)
        if (swept_box(x0, x, pairs[k].thickness).overlaps(broad_phase_.box(k))) mine.push_back(k);
      if (mine.empty()) continue;
      cc.candidates += static_cast<long>(mine.size());
      const int used =
          respond_vertex(mine, pairs, x0, x, v, s.mass[i], h, out, cc.contacts, cc.ccd_hits, &final_d);
      cc.passes = std::max(cc.passes, used);
      s.x[i] = x;
      s.v[i] = v;
      int closest = -1;
      double closest_gap = HUGE_VAL;
      bool inside = false;
      for (size_t j = 0; j < mine.size(); ++j) {
        const int k = mine[j];
        const double d = final_d.empty() ? signed_distance(set[k], set[k].curr, x, nullptr) : final_d[j];
        cc.deficit = std::max(cc.deficit, pairs[k].thickness - d);
        inside = inside || d < 0.0;
        if (d < 2.0 * pairs[k].thickness) near[i] = 1;
        if (d - pairs[k].thickness < closest_gap) closest_gap = d - pairs[k].thickness, closest = k;
      }
      cc.unresolved += inside ? 1 : 0;  // a pinch: no way out of the colliders it is between
      // Held against the closest collider in the next solve (ClothState::contact_normal), if it is near and
      // not leaving it (relative normal velocity <= 0: resting, or approaching; a vertex leaving keeps
      // gravity's pull).
      if (settings_.contact_normals && near[i] && closest >= 0) {
        Vec3 nrm;
        signed_distance(set[closest], set[closest].curr, x, &nrm);
        const Vec3 vs = surface_velocity(set[closest].prev, set[closest].curr, h, x);
        if ((v - vs).dot(nrm) <= 1e-9) s.contact_normal[i] = nrm;
      }
    }
  }

  std::vector<Reaction> all = std::move(edge_records);
  int step_passes = 0;
  for (int ch = 0; ch < chunks; ++ch) {
    all.insert(all.end(), records[ch].begin(), records[ch].end());
    candidates_ += counts[ch].candidates;
    contacts_ += counts[ch].contacts;
    ccd_hits_ += counts[ch].ccd_hits;
    unresolved_ += counts[ch].unresolved;
    step_passes = std::max(step_passes, counts[ch].passes);
    max_deficit_ = std::max(max_deficit_, counts[ch].deficit);
  }
  passes_ += step_passes;
  for (const Reaction& r : all) {
    Collider& c = set[r.collider];
    c.reaction_impulse -= r.impulse;
    c.reaction_angular_impulse += (r.point - c.curr.translation()).cross(-r.impulse);
  }
}

// Step 4 for one free vertex (path x0 -> x, velocity v, mass m) against its candidate colliders `mine`:
// returns the passes used; responses are appended to `out`.
int BodyCollisionStage::respond_vertex(const std::vector<int>& mine, const std::vector<Pair>& pairs,
                                       const Vec3& x0, Vec3& x, Vec3& v, double m, double h,
                                       std::vector<Reaction>& out, long& contacts, long& ccd_hits,
                                       std::vector<double>* final_d) const {
  const ColliderSet& set = *colliders_;
  const double ccd_ratio = settings_.ccd_separation;
  const int max_passes = settings_.max_passes;
  if (final_d) final_d->assign(mine.size(), 0.0);
  int pass = 0;
  bool changed = true;
  for (; pass < max_passes; ++pass) {
    changed = false;
    for (size_t j = 0; j < mine.size(); ++j) {
      const int k = mine[j];
      const Collider& c = set[k];
      const Pair& pr = pairs[k];
      // Continuous: the vertex path against the moving collider.
      const SweptHit hit = swept_point(c, x0, x, ccd_ratio * pr.thickness);
      if (hit.hit) {
        // The contact point carried with the body to the end of the step is where the vertex ends if it
        // sticks; Coulomb friction decides how far it slides from there along the surface towards where it
        // was going. (Ending at the carried point always would be infinite friction: where the surface moves
        // more than an edge length per step, the caught vertices are dragged away from their neighbours and
        // the sheet tears.) A triangle mesh keeps the carried point: on a concave part (the inside of a
        // funnel) the tangent plane runs into the surface, and a thin shell could be crossed there.
        const Vec3 stuck = c.curr * hit.local;
        x = c.shape.type == ShapeType::mesh
                ? stuck
                : Vec3(stuck + coulomb_tangent(x - stuck, c.curr.linear() * hit.normal, pr.mu_s, pr.mu_k));
        // The velocity becomes what the vertex did, (x - x_prev) / h (then the inward part relative to the
        // surface is removed below): a vertex that springs keep pulling along a curved surface is caught by
        // the swept test at every step and hardly moves; keeping the velocity it had would let it gather
        // speed without bound.
        const Vec3 v_did = (x - x0) / h;
        out.push_back({k, m * (v_did - v), x});  // its reaction, as every velocity change's
        v = v_did;
        ++ccd_hits;
      }
      Vec3 nrm;
      const double d = signed_distance(c, c.curr, x, &nrm);
      const double limit = pass == 0 && !hit.hit ? pr.thickness : pr.thickness * (1.0 - 1e-6);
      if (final_d) (*final_d)[j] = d;
      if (!hit.hit && d >= limit) continue;
      if (d < pr.thickness) x += (pr.thickness - d) * nrm;  // projection to surface + thickness
      // Velocity: relative to the body's surface (translation and rotation over the step).
      const Vec3 vs = surface_velocity(c.prev, c.curr, h, x);
      const Vec3 vr = v - vs;
      const double vn = vr.dot(nrm);
      const Vec3 vt = vr - vn * nrm;
      const Vec3 vt_new = coulomb_tangent(vr, nrm, pr.mu_s, pr.mu_k);
      const Vec3 v_new = vs + std::max(vn, 0.0) * nrm + vt_new;
      // The tangential change acts over the whole step (x = x_prev + h v), unless the vertex was already
      // placed by the swept test.
      if (!hit.hit) {
        x += h * (vt_new - vt);
        Vec3 n2;
        const double d2 = signed_distance(c, c.curr, x, &n2);
        if (d2 < pr.thickness) x += (pr.thickness - d2) * n2;
      }
      out.push_back({k, m * (v_new - v), x});
      v = v_new;
      ++contacts;
      changed = true;
    }
    if (!changed) break;
  }
  if (pass == max_passes) exit_pinch(mine, pairs, x, v, m, h, out, contacts);
  // A pass that changed nothing evaluated every collider's distance at the final x (after all passes, or
  // the pinch exit, x moved since: the caller evaluates it).
  if (final_d && changed) final_d->clear();
  return pass + (pass < max_passes ? 1 : 0);
}

// A vertex in the crease of two overlapping capsules (the back of a bent knee, where thigh and shin capsules
// overlap; an armpit) is pushed into one by the projection out of the other, and the passes end with it
// inside whichever came first (on the surface of the other). It leaves the union instead: along the sum of
// the normals of the colliders it is within the thickness of (or touches), by the largest deficit over that
// normal's share (signed distances are 1-Lipschitz, so a few steps), then the inward velocity relative to
// each of their surfaces is removed.
void BodyCollisionStage::exit_pinch(const std::vector<int>& mine, const std::vector<Pair>& pairs, Vec3& x,
                                    Vec3& v, double m, double h, std::vector<Reaction>& out,
                                    long& contacts) const {
  const ColliderSet& set = *colliders_;
  std::vector<std::pair<int, Vec3>> touched;  // collider, its normal at x
  for (int it = 0; it < 8; ++it) {
    Vec3 dir = Vec3::Zero();
    touched.clear();
    bool inside = false;
    for (int k : mine) {
      Vec3 n;
      const double d = signed_distance(set[k], set[k].curr, x, &n);
      const double deficit = pairs[k].thickness - d;
      // Touching (within 1% of the thickness past it) counts too: the collider the last pass projected out
      // of.
      if (deficit <= -0.01 * pairs[k].thickness) continue;
      // Capsules only (the joints of a character rig): between walls closing in (a shrinking box) there is no
      // way out of the union, and moving there fed energy into a crushed cloth (the stability suite).
      if (set[k].shape.type != ShapeType::capsule) return;
      touched.emplace_back(k, n);
      dir += n;
      inside = inside || deficit > 1e-6 * pairs[k].thickness;
    }
    if (!inside) break;
    if (dir.norm() < 1e-6) dir = touched.front().second;  // opposite normals: out of the first
    dir.normalize();
    double step = 0.0;
    for (const auto& [k, n] : touched) {
      const double d = signed_distance(set[k], set[k].curr, x, nullptr);
      step = std::max(step, (pairs[k].thickness - d) / std::max(0.2, n.dot(dir)));
    }
    x += std::min(step, 0.1) * dir;  // m; at most 10 cm per step
  }
  // Velocity: no approach to any collider it now touches (within twice the thickness).
  for (int k : mine) {
    Vec3 n;
    const double d = signed_distance(set[k], set[k].curr, x, &n);
    if (d > 2.0 * pairs[k].thickness) continue;
    const Vec3 vs = surface_velocity(set[k].prev, set[k].curr, h, x);
    const double vn = (v - vs).dot(n);
    if (vn >= 0.0) continue;
    out.push_back({k, -m * vn * n, x});
    v -= vn * n;
    ++contacts;
  }
}

bool BodyCollisionStage::revisit_vertex(int cloth_index, const Vec3& x0, const Vec3& x_body, Vec3& x, Vec3& v,
                                        double m, double fraction, std::vector<Reaction>& out) const {
  if (cloth_index >= static_cast<int>(pairs_.size())) return false;
  const std::vector<Pair>& pairs = pairs_[cloth_index];
  // Moved less than a quarter of the smallest thickness from where this stage left it: signed distances are
  // 1-Lipschitz, so the end point is still at least 3/4 of the thickness outside every collider.
  if ((x - x_body).norm() < 0.25 * min_thickness_[cloth_index]) return false;
  const ColliderSet& set = *colliders_;
  double max_th = 0.0;
  for (const Pair& p : pairs) max_th = std::max(max_th, p.thickness);
  std::vector<int> mine;
  bool act = false;
  for (int k : broad_phase_.query(swept_box(x0, x, max_th))) {
    if (!swept_box(x0, x, pairs[k].thickness).overlaps(broad_phase_.box(k))) continue;
    mine.push_back(k);
    const Collider& c = set[k];
    if (!act) {
      act = signed_distance(c, c.curr, x, nullptr) < fraction * pairs[k].thickness ||
            swept_point(c, x0, x, settings_.ccd_separation * pairs[k].thickness).hit;
    }
  }
  if (!act) return false;
  long contacts = 0, hits = 0;
  respond_vertex(mine, pairs, x0, x, v, m, h_, out, contacts, hits);
  return true;
}

void BodyCollisionStage::add_reactions(const std::vector<Reaction>& reactions) {
  ColliderSet& set = *colliders_;
  for (const Reaction& r : reactions) {
    Collider& c = set[r.collider];
    c.reaction_impulse -= r.impulse;
    c.reaction_angular_impulse += (r.point - c.curr.translation()).cross(-r.impulse);
  }
  revisits_ += static_cast<long>(reactions.size());
}

// One edge's correction against one collider in a pass.
struct BodyCollisionStage::EdgeCorrection {
  int collider = -1;
  Vec3 dxa = Vec3::Zero(), dxb = Vec3::Zero(), dva = Vec3::Zero(), dvb = Vec3::Zero();
  Vec3 point = Vec3::Zero(), normal = Vec3::Zero();
  bool leaving = false;  // the edge point separates from the surface (then its ends get no contact normal)
};

void BodyCollisionStage::run_edges(cloth::Cloth& cloth, double h, int threads,
                                   std::vector<Reaction>& records) {
  ColliderSet& set = *colliders_;
  std::vector<int> edge_colliders;
  for (int k = 0; k < static_cast<int>(set.size()); ++k)
    if (set[k].shape.type == ShapeType::capsule || set[k].shape.type == ShapeType::box)
      edge_colliders.push_back(k);
  if (edge_colliders.empty()) return;
  const int ne = static_cast<int>(cloth.mesh().edges().size());
  std::vector<EdgeCorrection> corr(ne);
  for (int pass = 0; pass < settings_.max_passes; ++pass) {
    if (find_edge_corrections(cloth, h, threads, edge_colliders, corr) == 0) break;
    if (drop_threaded_edges(cloth, corr) == 0) break;
    apply_edge_corrections(cloth, corr, records);
  }
}

long BodyCollisionStage::find_edge_corrections(const cloth::Cloth& cloth, double h, int threads,
                                               const std::vector<int>& edge_colliders,
                                               std::vector<EdgeCorrection>& corr) const {
  const ClothState& s = cloth.state();
  const auto& edges = cloth.mesh().edges();
  const int ne = static_cast<int>(edges.size());
  long found = 0;
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1) reduction(+ : found)
  for (int e = 0; e < ne; ++e) {
    EdgeCorrection& cr = corr[e];
    cr = EdgeCorrection();
    const int a = edges[e].i, b = edges[e].j;
    const double wa = s.inv_mass[a], wb = s.inv_mass[b];
    if (wa + wb == 0.0) continue;
    for (int k : edge_colliders) {
      if (edge_correction(s, a, b, k, cloth.material().thickness, h, cr)) {
        ++found;
        break;  // one collider per edge per pass
      }
    }
  }
  return found;
}

bool BodyCollisionStage::edge_correction(const ClothState& s, int a, int b, int k, double material_thickness,
                                         double h, EdgeCorrection& cr) const {
  const Collider& c = (*colliders_)[k];
  const double wa = s.inv_mass[a], wb = s.inv_mass[b];
  const double th = thickness(k, material_thickness);
  Aabb box = swept_box(s.x_prev[a], s.x[a], th);
  box.grow(s.x_prev[b]), box.grow(s.x[b]);
  box.lo -= Vec3::Constant(th), box.hi += Vec3::Constant(th);
  if (!box.overlaps(broad_phase_.box(k))) return false;
  double sp = 0.0, deficit = 0.0;
  Vec3 nrm;
  if (c.shape.type == ShapeType::capsule) {
    const SweptSegmentHit hit =
        swept_segment_capsule(c, s.x_prev[a], s.x_prev[b], s.x[a], s.x[b], settings_.ccd_separation * th);
    if (hit.hit) {
      // Keep the side the edge touched from: along the contact normal carried to curr.
      sp = hit.s;
      nrm = c.curr.linear() * hit.normal_local;
      const Vec3 pe = (1.0 - sp) * s.x[a] + sp * s.x[b];
      deficit = c.shape.radius + th - (pe - c.curr * hit.axis_local).dot(nrm);
    } else {
      deficit = th - segment_capsule_distance(c, c.curr, s.x[a], s.x[b], &sp, &nrm);
    }
  } else {
    const SegmentPast past{s.x_prev[a], s.x_prev[b], c.prev};
    deficit = th - segment_box_edges_distance(c, c.curr, s.x[a], s.x[b], &sp, &nrm, &past);
  }
  // Endpoint contacts belong to the vertex phase.
  if (deficit <= 1e-9 * th || sp <= 1e-6 || sp >= 1.0 - 1e-6) return false;
  // Next to a kinematic endpoint the lever amplifies the free endpoint's correction by 1/s (a contact
  // near a pin, e.g. a garment's attached ring, would fling its neighbour): the free half's contacts
  // only; the vertex phase handles the free endpoint itself.
  if ((wa == 0.0 && sp < 0.5) || (wb == 0.0 && sp > 0.5)) return false;
  // Move the edge point (1-s) a + s b by `deficit` along n, split by inverse mass (Bridson et al. 2002,
  // Sec. 7.1): lambda = deficit / (wa (1-s)^2 + wb s^2).
  const double wsum = wa * (1.0 - sp) * (1.0 - sp) + wb * sp * sp;
  const double lambda = deficit / wsum;
  cr.dxa = wa * (1.0 - sp) * lambda * nrm;
  cr.dxb = wb * sp * lambda * nrm;
  const Vec3 pe = (1.0 - sp) * s.x[a] + sp * s.x[b];
  const Vec3 vs = surface_velocity(c.prev, c.curr, h, pe);
  const double vn = ((1.0 - sp) * s.v[a] + sp * s.v[b] - vs).dot(nrm);
  cr.leaving = vn > 1e-9;
  if (vn < 0.0) {
    const double mu = -vn / wsum;
    cr.dva = wa * (1.0 - sp) * mu * nrm;
    cr.dvb = wb * sp * mu * nrm;
  }
  cr.collider = k;
  cr.point = pe;
  cr.normal = nrm;
  return true;
}

long BodyCollisionStage::drop_threaded_edges(const cloth::Cloth& cloth, std::vector<EdgeCorrection>& corr) {
  const ColliderSet& set = *colliders_;
  const int nv = cloth.state().size();
  const auto& edges = cloth.mesh().edges();
  const int ne = static_cast<int>(edges.size());
  // A capsule threaded through the cloth: two edges of one vertex corrected against the same capsule from
  // opposite sides (normals more than 90 degrees apart) have the capsule between them, through a triangle
  // of the fan, which no edge correction can undo (faces are not tested). Pushing both edges to their own
  // sides would pull the vertex's neighbours apart every step, and the solver would throw the stretched
  // vertex back. Those edges get no correction: the cloth slides off the limb; the vertex phase still keeps
  // every vertex out of every collider. Capsules only: cloth wrapped around the edge of a thin box (a
  // tablecloth on a table) has opposite normals too and is corrected. (Testing instead whether the
  // capsule's axis crosses the vertex's triangle misses threaded capsules that the opposite edge normals
  // catch.)
  std::vector<int> first_collider(nv, -1);
  std::vector<Vec3> first_normal(nv);
  std::vector<char> threaded(nv, 0);
  for (int e = 0; e < ne; ++e) {
    const EdgeCorrection& cr = corr[e];
    if (cr.collider < 0 || set[cr.collider].shape.type != ShapeType::capsule) continue;
    for (int v : {edges[e].i, edges[e].j}) {
      if (first_collider[v] < 0) {
        first_collider[v] = cr.collider, first_normal[v] = cr.normal;
      } else if (first_collider[v] == cr.collider && first_normal[v].dot(cr.normal) < 0.0) {
        threaded[v] = 1;
      }
    }
  }
  long applied = 0;
  for (int e = 0; e < ne; ++e) {
    EdgeCorrection& cr = corr[e];
    if (cr.collider < 0) continue;
    if (threaded[edges[e].i] || threaded[edges[e].j]) {
      cr.collider = -1;
      ++threaded_edges_;
    } else {
      ++applied;
    }
  }
  return applied;
}

void BodyCollisionStage::apply_edge_corrections(cloth::Cloth& cloth, std::vector<EdgeCorrection>& corr,
                                                std::vector<Reaction>& records) {
  ClothState& s = cloth.state();
  const auto& edges = cloth.mesh().edges();
  const int ne = static_cast<int>(edges.size());
  // Jacobi: a vertex on several corrected edges gets the mean of their corrections, not the sum (summed,
  // the 4-6 edges of a vertex on one capsule push it 4-6 times too far and too fast). Both ends of an edge
  // take the same fraction, 1 / the larger of their counts, so the edge point moves along the normal as the
  // inverse-mass split intends (scaled per end, the end on one corrected edge would take its whole share
  // while its partner on four took a quarter, and the edge would swing about the partner, moving the first
  // end farther than the edge's deficit).
  std::vector<int> hits(s.size(), 0);
  for (int e = 0; e < ne; ++e)
    if (corr[e].collider >= 0) ++hits[edges[e].i], ++hits[edges[e].j];
  // Gather in edge order (deterministic for any thread count).
  for (int e = 0; e < ne; ++e) {
    EdgeCorrection& cr = corr[e];
    if (cr.collider < 0) continue;
    const int a = edges[e].i, b = edges[e].j;
    const double f = 1.0 / std::max(hits[a], hits[b]);
    cr.dxa *= f, cr.dva *= f, cr.dxb *= f, cr.dvb *= f;
    s.x[a] += cr.dxa, s.x[b] += cr.dxb;
    s.v[a] += cr.dva, s.v[b] += cr.dvb;
    // Both free ends are held along the contact normal in the next solve (ClothState::contact_normal; the
    // vertex phase replaces it for a vertex that ends near a collider itself), unless the edge point leaves
    // the surface.
    if (settings_.contact_normals && !cr.leaving) {
      if (s.inv_mass[a] > 0.0) s.contact_normal[a] = cr.normal;
      if (s.inv_mass[b] > 0.0) s.contact_normal[b] = cr.normal;
    }
    records.push_back({cr.collider, s.mass[a] * cr.dva + s.mass[b] * cr.dvb, cr.point});
    ++edge_contacts_;
  }
}

std::vector<std::pair<std::string, double>> BodyCollisionStage::counters() const {
  return {{"candidate_vertices", static_cast<double>(candidates_)},
          {"contacts", static_cast<double>(contacts_)},
          {"ccd_hits", static_cast<double>(ccd_hits_)},
          {"edge_contacts", static_cast<double>(edge_contacts_)},
          {"threaded_edges", static_cast<double>(threaded_edges_)},
          {"passes", static_cast<double>(passes_)},
          {"revisit_contacts", static_cast<double>(revisits_)},
          {"unresolved", static_cast<double>(unresolved_)}};
}

// For a swept hit, `rel` is where the vertex was going relative to the contact point carried with the body;
// without the normal part the vertex stays on the surface's tangent plane at the contact, which a convex
// collider lies behind (a later pass tests the new path).
Vec3 coulomb_tangent(const Vec3& rel, const Vec3& n, double mu_s, double mu_k) {
  const double sn = rel.dot(n);
  const Vec3 st = rel - sn * n;
  const double len = st.norm(), push = std::max(0.0, -sn);
  if (len <= mu_s * push) return Vec3::Zero();
  return st * std::max(0.0, 1.0 - mu_k * push / len);
}

}  // namespace loom::collision
