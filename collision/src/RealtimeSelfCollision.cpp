#include "loom/collision/RealtimeSelfCollision.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#ifdef __SSE2__
#include <xmmintrin.h>
#endif

namespace loom::collision {

using cloth::Vec3;
using cloth::Vec3s;

namespace {

// Barycentric weights (u, v, w) of p's projection onto the plane of (a, b, c), Ericson 2005, "Real-Time
// Collision Detection", Sec. 3.4; false for a degenerate triangle.
bool barycentric(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& p, double bw[3]) {
  const Vec3 e0 = b - a, e1 = c - a, e2 = p - a;
  const double d00 = e0.dot(e0), d01 = e0.dot(e1), d11 = e1.dot(e1), d20 = e2.dot(e0), d21 = e2.dot(e1);
  const double den = d00 * d11 - d01 * d01;
  if (!(den > 1e-30)) return false;
  bw[1] = (d11 * d20 - d01 * d21) / den;
  bw[2] = (d00 * d21 - d01 * d20) / den;
  bw[0] = 1.0 - bw[1] - bw[2];
  return true;
}

constexpr double kInsideTolerance =
    0.02;  // 1, barycentric slack: a vertex over a shared edge sees both faces

// Cells of side 1 / inv_cell that the box [lo, hi] overlaps, in double (no overflow; NaN for a NaN box,
// which the callers count as large).
double box_cells(const Vec3& lo, const Vec3& hi, double inv_cell) {
  double cells = 1.0;
  for (int k = 0; k < 3; ++k) cells *= std::floor(hi[k] * inv_cell) - std::floor(lo[k] * inv_cell) + 1.0;
  return cells;
}

// True when p lies in the box [lo, hi] (x, y, z lanes; the fourth lane is ignored).
inline bool in_box(const float* p, const float* lo, const float* hi) {
#ifdef __SSE2__
  const __m128 v = _mm_load_ps(p);
  const int m =
      _mm_movemask_ps(_mm_and_ps(_mm_cmpge_ps(v, _mm_load_ps(lo)), _mm_cmple_ps(v, _mm_load_ps(hi))));
  return (m & 7) == 7;
#else
  return p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1] && p[2] >= lo[2] && p[2] <= hi[2];
#endif
}

bool inside_triangle(const double bw[3]) {
  return bw[0] >= -kInsideTolerance && bw[1] >= -kInsideTolerance && bw[2] >= -kInsideTolerance;
}

}  // namespace

RealtimeSelfCollisionStage::RealtimeSelfCollisionStage(RealtimeSelfSettings settings) : settings_(settings) {
  settings_.every = std::max(1, settings_.every);
}

std::vector<std::pair<std::string, double>> RealtimeSelfCollisionStage::counters() const {
  return {{"runs", static_cast<double>(runs_)},
          {"broad_phases", static_cast<double>(broad_phases_)},
          {"candidates", static_cast<double>(candidates_)},
          {"pairs", static_cast<double>(pairs_)},
          {"contacts", static_cast<double>(contacts_)},
          {"large_boxes", static_cast<double>(large_boxes_)},
          {"hash_entries", static_cast<double>(hash_entries_)}};
}

void RealtimeSelfCollisionStage::save_state(cloth::StateWriter& out) const {
  out.tag("realtime_self_collision");
  out.i64(step_);
  out.vec3s(last_);
  out.vec3s(built_);
}

void RealtimeSelfCollisionStage::load_state(cloth::StateReader& in) {
  in.tag("realtime_self_collision");
  step_ = in.i64();
  last_ = in.vec3s();
  built_ = in.vec3s();
  cand_valid_ = false;  // rebuilt from built_ at the next run: the same list
}

long RealtimeSelfCollisionStage::cell_key(int x, int y, int z) const {
  // Teschner et al. 2003: (x p1 xor y p2 xor z p3) mod table size.
  const unsigned long h = (static_cast<unsigned long>(x) * 73856093ul) ^
                          (static_cast<unsigned long>(y) * 19349663ul) ^
                          (static_cast<unsigned long>(z) * 83492791ul);
  return static_cast<long>(h & static_cast<unsigned long>(bucket_start_.size() - 2));
}

void RealtimeSelfCollisionStage::prepare(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  offset_.assign(1, 0);
  tri_.clear(), tri_cloth_.clear(), vert_cloth_.clear(), rest_.clear();
  double edge_sum = 0.0;
  long edge_count = 0;
  for (size_t c = 0; c < cloths.size(); ++c) {
    const cloth::ClothMesh& mesh = cloths[c]->mesh();
    const int base = offset_.back();
    for (const cloth::Tri& t : mesh.triangles()) {
      tri_.push_back({t[0] + base, t[1] + base, t[2] + base});
      tri_cloth_.push_back(static_cast<int>(c));
      for (int k = 0; k < 3; ++k) {
        edge_sum += (mesh.rest_positions()[t[k]] - mesh.rest_positions()[t[(k + 1) % 3]]).norm();
        ++edge_count;
      }
    }
    for (int i = 0; i < mesh.num_vertices(); ++i) {
      vert_cloth_.push_back(static_cast<int>(c));
      rest_.push_back(mesh.rest_positions()[i]);
    }
    offset_.push_back(base + mesh.num_vertices());
  }
  // At least the reach t + P of a padded box on each side, so a box spans a bounded number of cells
  // whatever the padding (the candidate list does not depend on the cell size).
  cell_ = std::max({2.0 * (edge_count > 0 ? edge_sum / edge_count : 0.05), 4.0 * settings_.thickness,
                    2.0 * (settings_.thickness + settings_.padding)});
  // A power-of-two table with about eight slots per triangle (plus one end entry).
  size_t size = 1;
  while (size < 8 * tri_.size() + 8) size *= 2;
  bucket_start_.assign(size + 1, 0);
  tri_range_.resize(tri_.size());
  rest_neighbours();
  // Sides and broad-phase positions loaded with the state are kept; otherwise the current positions.
  const size_t n = static_cast<size_t>(offset_.back());
  if (last_.size() != n) {
    last_.clear();
    for (const auto& cl : cloths) last_.insert(last_.end(), cl->state().x.begin(), cl->state().x.end());
  }
  if (built_.size() != n) built_.clear();
  cand_valid_ = false;
  prepared_ = true;
}

void RealtimeSelfCollisionStage::rest_neighbours() {
  // Vertices by cell of their rest position; each triangle looks at the cells of its rest box inflated by
  // 2t plus the barycentric slack.
  const double t_self = settings_.self_fraction * settings_.thickness, inv_cell = 1.0 / cell_;
  auto cell_of = [&](double v) { return static_cast<long>(std::floor(v * inv_cell)); };
  auto key = [&](long x, long y, long z) { return (x * 73856093L) ^ (y * 19349663L) ^ (z * 83492791L); };
  std::unordered_map<long, std::vector<int>> cells;
  const int n = static_cast<int>(rest_.size()), nt = static_cast<int>(tri_.size());
  for (int g = 0; g < n; ++g)
    cells[key(cell_of(rest_[g].x()), cell_of(rest_[g].y()), cell_of(rest_[g].z()))].push_back(g);
  std::vector<std::pair<int, int>> pairs;
  for (int q = 0; q < nt; ++q) {
    const auto& tri = tri_[q];
    const Vec3 &ra = rest_[tri[0]], &rb = rest_[tri[1]], &rc = rest_[tri[2]];
    const Vec3 rn = (rb - ra).cross(rc - ra).normalized();
    const double edge = std::max({(rb - ra).norm(), (rc - rb).norm(), (ra - rc).norm()});
    const Vec3 reach = Vec3::Constant(2.0 * t_self + kInsideTolerance * edge);
    const Vec3 lo = ra.cwiseMin(rb).cwiseMin(rc) - reach, hi = ra.cwiseMax(rb).cwiseMax(rc) + reach;
    auto test = [&](int g) {
      if (vert_cloth_[g] != tri_cloth_[q] || tri[0] == g || tri[1] == g || tri[2] == g) return;
      double rbw[3];
      if (std::abs((rest_[g] - ra).dot(rn)) < 2.0 * t_self && barycentric(ra, rb, rc, rest_[g], rbw) &&
          inside_triangle(rbw))
        pairs.emplace_back(g, q);
    };
    if (!(box_cells(lo, hi, inv_cell) <= kMaxBoxCells)) {  // every vertex once, not cell by cell
      for (int g = offset_[tri_cloth_[q]]; g < offset_[tri_cloth_[q] + 1]; ++g) test(g);
      continue;
    }
    for (long x = cell_of(lo.x()); x <= cell_of(hi.x()); ++x)
      for (long y = cell_of(lo.y()); y <= cell_of(hi.y()); ++y)
        for (long z = cell_of(lo.z()); z <= cell_of(hi.z()); ++z) {
          const auto it = cells.find(key(x, y, z));
          if (it == cells.end()) continue;
          for (int g : it->second) test(g);
        }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  rest_start_.assign(n + 1, 0);
  rest_tri_.clear();
  for (const auto& [g, q] : pairs) ++rest_start_[g + 1], rest_tri_.push_back(q);
  for (int g = 0; g < n; ++g) rest_start_[g + 1] += rest_start_[g];
}

bool RealtimeSelfCollisionStage::moved_too_far() const {
  const int n = static_cast<int>(built_.size());
  if (n == 0) return true;
  // A pair's vertex and triangle corners have moved by at most P relative to each other (the list holds
  // it) when every displacement d lies within R of a common centre r and 2R <= P; or, per cloth c with
  // centre r_c and radius R_c, when 2 R_c <= P within each cloth (self pairs) and R_a + R_b + |r_a - r_b|
  // <= P between cloths. Centres: the middle of the displacements' box.
  const int nc = static_cast<int>(offset_.size()) - 1;
  Vec3 all_lo = Vec3::Constant(std::numeric_limits<double>::infinity()), all_hi = -all_lo;
  centre_.resize(nc), radius_.resize(nc);
  for (int c = 0; c < nc; ++c) {
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (int g = offset_[c]; g < offset_[c + 1]; ++g) {
      const Vec3 d = *xs_[g] - built_[g];
      lo = lo.cwiseMin(d), hi = hi.cwiseMax(d);
    }
    centre_[c] = 0.5 * (lo + hi);
    all_lo = all_lo.cwiseMin(lo), all_hi = all_hi.cwiseMax(hi);
  }
  const Vec3 centre = 0.5 * (all_lo + all_hi);
  double all_r2 = 0.0;
  for (int c = 0; c < nc; ++c) {
    double r2 = 0.0;
    for (int g = offset_[c]; g < offset_[c + 1]; ++g) {
      const Vec3 d = *xs_[g] - built_[g];
      r2 = std::max(r2, (d - centre_[c]).squaredNorm());
      all_r2 = std::max(all_r2, (d - centre).squaredNorm());
    }
    radius_[c] = std::sqrt(r2);
  }
  const double p = settings_.padding;
  if (2.0 * std::sqrt(all_r2) <= p) return false;
  for (int a = 0; a < nc; ++a) {
    if (settings_.self && 2.0 * radius_[a] > p) return true;
    for (int b = a + 1; b < nc; ++b)
      if (radius_[a] + radius_[b] + (centre_[a] - centre_[b]).norm() > p) return true;
  }
  return false;
}

void RealtimeSelfCollisionStage::broad_phase() {
  ++broad_phases_;
  const double reach = settings_.thickness + settings_.padding, inv_cell = 1.0 / cell_;
  const long table = static_cast<long>(bucket_start_.size()) - 1;
  // Clamped before the conversion (a cloth flung far from the origin must not overflow int); clamped cells
  // only gather more triangles into the end cells, the box test below stays exact.
  constexpr double kMaxCell = 1 << 30;
  auto cell_of = [&](double v) {  // NaN (a state the guard will stop) to the lowest cell, never cast
    const double c = std::floor(v * inv_cell);
    return static_cast<int>(c >= -kMaxCell ? std::min(c, kMaxCell) : -kMaxCell);
  };
  // Counting sort of the triangles' padded boxes into the table, only into the slots a vertex reads (the
  // vertices' slots first).
  std::fill(bucket_start_.begin(), bucket_start_.end(), 0);
  const int nt = static_cast<int>(tri_.size()), n = static_cast<int>(built_.size());
  occupied_.assign(table, 0);
  vert_key_.resize(n);
  for (int g = 0; g < n; ++g) {
    const Vec3& p = built_[g];
    vert_key_[g] = cell_key(cell_of(p.x()), cell_of(p.y()), cell_of(p.z()));
    occupied_[vert_key_[g]] = 1;
  }
  tri_lo_.resize(nt), tri_hi_.resize(nt);
  entry_key_.clear(), entry_tri_.clear(), large_.clear();
  for (int q = 0; q < nt; ++q) {
    const Vec3 &a = built_[tri_[q][0]], &b = built_[tri_[q][1]], &c = built_[tri_[q][2]];
    tri_lo_[q] = a.cwiseMin(b).cwiseMin(c) - Vec3::Constant(reach);
    tri_hi_[q] = a.cwiseMax(b).cwiseMax(c) + Vec3::Constant(reach);
    if (!(box_cells(tri_lo_[q], tri_hi_[q], inv_cell) <= kMaxBoxCells)) {
      large_.push_back(q);  // scanned by every vertex below instead of entered in each of its cells
      continue;
    }
    auto& r = tri_range_[q];
    for (int k = 0; k < 3; ++k) r[k] = cell_of(tri_lo_[q][k]), r[k + 3] = cell_of(tri_hi_[q][k]);
    for (int x = r[0]; x <= r[3]; ++x)
      for (int y = r[1]; y <= r[4]; ++y)
        for (int z = r[2]; z <= r[5]; ++z) {
          const long key = cell_key(x, y, z);
          if (!occupied_[key]) continue;
          ++bucket_start_[key + 1];
          entry_key_.push_back(static_cast<int>(key));
          entry_tri_.push_back(q);
        }
  }
  large_boxes_ += static_cast<long>(large_.size());
  hash_entries_ += static_cast<long>(entry_key_.size());
  for (long k = 0; k < table; ++k) bucket_start_[k + 1] += bucket_start_[k];
  bucket_items_.resize(bucket_start_[table]);
  bucket_boxes_.resize(bucket_start_[table]);
  fill_.assign(bucket_start_.begin(), bucket_start_.end() - 1);
  // Each entry carries its triangle's box in float (widened by 1 mm for the rounding), so that the scan
  // below reads one bucket's entries in a row.
  constexpr double kRound = 1e-3;  // m
  box_f_.resize(nt);
  for (int q = 0; q < nt; ++q) {
    const Vec3 lo = tri_lo_[q] - Vec3::Constant(kRound), hi = tri_hi_[q] + Vec3::Constant(kRound);
    box_f_[q] =
        FloatBox{{static_cast<float>(lo.x()), static_cast<float>(lo.y()), static_cast<float>(lo.z()), 0.0f},
                 {static_cast<float>(hi.x()), static_cast<float>(hi.y()), static_cast<float>(hi.z()), 0.0f}};
  }
  for (size_t e = 0; e < entry_key_.size(); ++e) {
    const int slot = fill_[entry_key_[e]]++;
    bucket_items_[slot] = entry_tri_[e];
    bucket_boxes_[slot] = box_f_[entry_tri_[e]];
  }
  // Every vertex against the triangles of its cell: the box tests first, without branches (the entries
  // that pass are written to hit_ by stream compaction), then the filters on the few that passed.
  cand_.clear();
  hit_.resize(bucket_items_.size() + large_.size());
  for (int g = 0; g < n; ++g) {
    const Vec3& p = built_[g];
    alignas(16) const float pf[4] = {static_cast<float>(p.x()), static_cast<float>(p.y()),
                                     static_cast<float>(p.z()), 0.0f};
    const size_t first = cand_.size();
    const long key = vert_key_[g];
    int nh = 0;
    for (int it = bucket_start_[key]; it < bucket_start_[key + 1]; ++it) {
      hit_[nh] = bucket_items_[it];
      nh += in_box(pf, bucket_boxes_[it].lo, bucket_boxes_[it].hi);
    }
    for (int q : large_) {
      hit_[nh] = q;
      nh += in_box(pf, box_f_[q].lo, box_f_[q].hi);
    }
    const auto rest_begin = rest_tri_.begin() + rest_start_[g],
               rest_end = rest_tri_.begin() + rest_start_[g + 1];
    for (int k = 0; k < nh; ++k) {
      const int q = hit_[k];
      const auto& tri = tri_[q];
      if (tri[0] == g || tri[1] == g || tri[2] == g) continue;
      const bool same = tri_cloth_[q] == vert_cloth_[g];
      if (same && !settings_.self) continue;
      if (same && std::find(rest_begin, rest_end, q) != rest_end)
        continue;  // neighbours on the rest shape are not contacts
      cand_.emplace_back(g, q);
    }
    // This vertex's triangles in order, each once (hash collisions list a triangle once per cell).
    std::sort(cand_.begin() + first, cand_.end());
    cand_.erase(std::unique(cand_.begin() + first, cand_.end()), cand_.end());
  }
  candidates_ += static_cast<long>(cand_.size());
  cand_valid_ = true;
}

void RealtimeSelfCollisionStage::run(cloth::StageContext& ctx) {
  if (!prepared_ || offset_.size() != ctx.cloths.size() + 1) prepare(ctx.cloths);
  if (step_++ % settings_.every != 0) return;
  ++runs_;
  const int nc = static_cast<int>(ctx.cloths.size());
  const int n = offset_.back();
  // Global views of the cloths' state.
  std::vector<Vec3*>& xs = xs_;
  std::vector<Vec3*>& vs = vs_;
  std::vector<double>& w = w_;
  xs.resize(n), vs.resize(n), w.resize(n);
  for (int c = 0; c < nc; ++c) {
    cloth::ClothState& s = ctx.cloths[c]->state();
    for (int i = 0; i < s.size(); ++i)
      xs[offset_[c] + i] = &s.x[i], vs[offset_[c] + i] = &s.v[i], w[offset_[c] + i] = s.inv_mass[i];
  }
  // A state loaded before the first run (the guard's frame-start snapshot of a rolled-back first frame, a
  // checkpoint) holds no sides: the current positions, as prepare() takes them.
  if (last_.size() != static_cast<size_t>(n)) {
    last_.resize(n);
    for (int g = 0; g < n; ++g) last_[g] = *xs[g];
  }
  // Step 1, when the list may miss a pair (always when no list matches the vertices).
  if (built_.size() != static_cast<size_t>(n) || moved_too_far()) {
    built_.resize(n);
    for (int g = 0; g < n; ++g) built_[g] = *xs[g];
    cand_valid_ = false;
  }
  if (!cand_valid_) broad_phase();
  const double t_between = settings_.thickness, t_self = settings_.self_fraction * settings_.thickness;
  // The triangles' boxes inflated by the thickness and their unit normals at the run's start, in float for
  // the box test (the same rounding whenever the list was built: the filter does not depend on it).
  const int nt = static_cast<int>(tri_.size());
  run_boxes_.resize(nt), tri_n_.resize(nt), start_.resize(n);
  for (int g = 0; g < n; ++g) {
    const Vec3& x = *xs[g];
    start_[g] =
        FloatPoint{{static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z()), 0.0f}};
  }
  for (int q = 0; q < nt; ++q) {
    const Vec3 &a = *xs[tri_[q][0]], &b = *xs[tri_[q][1]], &c = *xs[tri_[q][2]];
    const Vec3 lo = a.cwiseMin(b).cwiseMin(c) - Vec3::Constant(t_between),
               hi = a.cwiseMax(b).cwiseMax(c) + Vec3::Constant(t_between);
    run_boxes_[q] = {
        {static_cast<float>(lo.x()), static_cast<float>(lo.y()), static_cast<float>(lo.z()), 0.0f},
        {static_cast<float>(hi.x()), static_cast<float>(hi.y()), static_cast<float>(hi.z()), 0.0f}};
    const Vec3 nq = (b - a).cross(c - a);
    const double len = nq.norm();
    tri_n_[q] = len > 1e-20 ? Vec3(nq / len) : Vec3::Zero();
  }
  // Step 2: the candidates in (vertex, triangle) order whose vertex lay in the box at the run's start.
  for (const auto& [g, q] : cand_) {
    if (!in_box(start_[g].p, run_boxes_[q].lo, run_boxes_[q].hi)) continue;
    Vec3& p = *xs[g];
    const auto& tri = tri_[q];
    const bool same = tri_cloth_[q] == vert_cloth_[g];
    const double t = same ? t_self : t_between;
    const double wv = w[g], wa = w[tri[0]], wb = w[tri[1]], wc = w[tri[2]];
    if (wv + wa + wb + wc == 0.0) continue;
    Vec3 &a = *xs[tri[0]], &b = *xs[tri[1]], &c = *xs[tri[2]];
    // The normal at the run's start positions (this run's earlier projections move a triangle by at most
    // the thickness, a small tilt for a triangle many thicknesses wide).
    const Vec3& nrm = tri_n_[q];
    const double sd = (p - a).dot(nrm);
    if (!(std::abs(sd) < 3.0 * t)) continue;  // a degenerate triangle (normal 0) fails barycentric()
    ++pairs_;
    double bw[3];
    if (!barycentric(a, b, c, p, bw) || !inside_triangle(bw)) continue;
    // The side at the previous run (its own normal), the current one when the vertex lay in the plane.
    const Vec3 &la = last_[tri[0]], &lb = last_[tri[1]], &lc = last_[tri[2]];
    const double sd_last = (last_[g] - la).dot((lb - la).cross(lc - la));
    const double side = sd_last > 0.0 ? 1.0 : sd_last < 0.0 ? -1.0 : (sd >= 0.0 ? 1.0 : -1.0);
    const double gap = side * sd;
    if (gap >= t) continue;
    // PBD projection of C = side (p - Σ b_k x_k)·n - t >= 0 (gradient side n on p, -side b_k n on x_k).
    const double denom = wv + bw[0] * bw[0] * wa + bw[1] * bw[1] * wb + bw[2] * bw[2] * wc;
    if (!(denom > 0.0)) continue;
    const Vec3 dir = side * nrm;
    const double lambda = (t - gap) / denom;
    p += (wv * lambda) * dir;
    a -= (wa * bw[0] * lambda) * dir;
    b -= (wb * bw[1] * lambda) * dir;
    c -= (wc * bw[2] * lambda) * dir;
    // The approaching normal velocity, removed with the same weights.
    Vec3 &vp = *vs[g], &va = *vs[tri[0]], &vb = *vs[tri[1]], &vc = *vs[tri[2]];
    const double vn = (vp - bw[0] * va - bw[1] * vb - bw[2] * vc).dot(dir);
    if (vn < 0.0) {
      const double mu = -vn / denom;
      vp += (wv * mu) * dir;
      va -= (wa * bw[0] * mu) * dir;
      vb -= (wb * bw[1] * mu) * dir;
      vc -= (wc * bw[2] * mu) * dir;
    }
    ++contacts_;
  }
  // Step 3: the sides of the next run.
  for (int g = 0; g < n; ++g) last_[g] = *xs[g];
}

}  // namespace loom::collision
