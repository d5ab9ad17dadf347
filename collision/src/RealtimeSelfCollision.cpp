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
inline __attribute__((always_inline)) bool barycentric(const Vec3& a, const Vec3& b, const Vec3& c,
                                                       const Vec3& p, double bw[3]) {
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

// floor(x) without a library call (x86-64 without SSE4.1 has no rounding instruction): through a 64-bit
// integer where |x| < 2^52, x itself beyond (already whole) and for NaN.
inline double fast_floor(double x) {
  if (!(std::abs(x) < 4503599627370496.0)) return x;
  const double t = static_cast<double>(static_cast<long long>(x));
  return t > x ? t - 1.0 : t;
}

// Cells of side 1 / inv_cell that the box [lo, hi] overlaps, in double (no overflow; NaN for a NaN box,
// which the callers count as large).
double box_cells(const Vec3& lo, const Vec3& hi, double inv_cell) {
  double cells = 1.0;
  for (int k = 0; k < 3; ++k) cells *= fast_floor(hi[k] * inv_cell) - fast_floor(lo[k] * inv_cell) + 1.0;
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

void RealtimeSelfCollisionStage::Grid::fit(const Vec3s& points, double side) {
  for (int k = 0; k < 3; ++k) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Vec3& p : points)
      if (std::isfinite(p[k])) lo = std::min(lo, p[k]), hi = std::max(hi, p[k]);
    if (!(lo <= hi)) lo = hi = 0.0;  // no finite coordinate
    // Cells of `side`, or wider so that at most kMaxGridDim cover the points' extent.
    const double h = std::max(side, (hi - lo) / (kMaxGridDim - 1));
    origin[k] = lo;
    inv[k] = std::isfinite(h) ? 1.0 / h : 0.0;
    dim[k] = std::isfinite(h) ? static_cast<int>(std::min<double>(kMaxGridDim, (hi - lo) * inv[k] + 1.0)) : 1;
    dim[k] = std::max(1, dim[k]);
  }
}

int RealtimeSelfCollisionStage::Grid::axis(double v, int k) const {
  // Truncation is floor for c >= 0; NaN to 0.
  const double c = (v - origin[k]) * inv[k];
  return c >= 0.0 ? static_cast<int>(std::min(c, static_cast<double>(dim[k] - 1))) : 0;
}

void RealtimeSelfCollisionStage::set_margins(double h) {
  // m_g = max(P/2, |u_g - u_mean| T): the displacement from the common motion a vertex may gather before
  // the list is rebuilt, from its velocity relative to the mean at the broad phase over T, kHorizonRuns
  // runs. Any margins keep the list exact (moved_too_far() checks them); these only make it last.
  const int n = static_cast<int>(built_.size());
  Vec3 mean = Vec3::Zero();
  for (int g = 0; g < n; ++g) mean += *vs_[g];
  mean /= std::max(1, n);
  const double base = 0.5 * settings_.padding, horizon = kHorizonRuns * settings_.every * h;
  margin_.resize(n);
  for (int g = 0; g < n; ++g)
    margin_[g] =
        std::min(kMaxMarginPaddings * settings_.padding, std::max(base, (*vs_[g] - mean).norm() * horizon));
}

bool RealtimeSelfCollisionStage::moved_too_far() const {
  const int n = static_cast<int>(built_.size());
  if (n == 0) return true;
  // A vertex v and a corner k of a triangle q have moved by at most m_v + m_k relative to each other when
  // every displacement d_g lies within its margin m_g of a common centre c (the mean displacement); the
  // broad phase listed every pair whose vertex lay in the triangle's box inflated by t + m_v + max_k m_k,
  // so the list holds every pair whose vertex lies in the box inflated by t now.
  Vec3 c = Vec3::Zero();
  for (int g = 0; g < n; ++g) c += *xs_[g] - built_[g];
  c /= n;
  for (int g = 0; g < n; ++g)
    if (!((*xs_[g] - built_[g] - c).squaredNorm() <= margin_[g] * margin_[g])) return true;  // NaN too
  return false;
}

int RealtimeSelfCollisionStage::scan_cell(int cell, const float* lo, const float* hi, int nh) {
  // Entries whose box [elo, ehi] meets [lo, hi] (the vertex widened by its margin): elo <= hi and
  // ehi >= lo on every axis, four entries at a time.
  const int begin = bucket_start_[cell], end = bucket_start_[cell + 1];
#ifdef __SSE2__
  const __m128 hx = _mm_set1_ps(hi[0]), hy = _mm_set1_ps(hi[1]), hz = _mm_set1_ps(hi[2]);
  const __m128 lx = _mm_set1_ps(lo[0]), ly = _mm_set1_ps(lo[1]), lz = _mm_set1_ps(lo[2]);
  for (int it = begin; it < end; it += 4) {
    __m128 m = _mm_and_ps(_mm_cmple_ps(_mm_loadu_ps(&ent_lo_[0][it]), hx),
                          _mm_cmpge_ps(_mm_loadu_ps(&ent_hi_[0][it]), lx));
    m = _mm_and_ps(m, _mm_and_ps(_mm_cmple_ps(_mm_loadu_ps(&ent_lo_[1][it]), hy),
                                 _mm_cmpge_ps(_mm_loadu_ps(&ent_hi_[1][it]), ly)));
    m = _mm_and_ps(m, _mm_and_ps(_mm_cmple_ps(_mm_loadu_ps(&ent_lo_[2][it]), hz),
                                 _mm_cmpge_ps(_mm_loadu_ps(&ent_hi_[2][it]), lz)));
    unsigned bits = static_cast<unsigned>(_mm_movemask_ps(m));
    if (end - it < 4) bits &= (1u << (end - it)) - 1u;
    while (bits) {
      hit_[nh++] = bucket_items_[it + __builtin_ctz(bits)];
      bits &= bits - 1u;
    }
  }
#else
  for (int it = begin; it < end; ++it) {
    hit_[nh] = bucket_items_[it];
    nh += ent_lo_[0][it] <= hi[0] && ent_hi_[0][it] >= lo[0] && ent_lo_[1][it] <= hi[1] &&
          ent_hi_[1][it] >= lo[1] && ent_lo_[2][it] <= hi[2] && ent_hi_[2][it] >= lo[2];
  }
#endif
  return nh;
}

void RealtimeSelfCollisionStage::broad_phase() {
  ++broad_phases_;
  const double inv_cell = 1.0 / cell_, base = 0.5 * settings_.padding;
  // A uniform grid over the vertices (Teschner et al. 2003, "Optimized spatial hashing for collision
  // detection of deformable objects", with a dense table in place of the hash: no two cells share an
  // entry, so a cell lists each triangle once and in order). Each triangle's box, inflated by
  // t + max_k m_k + P/2, is counted and sorted into the cells that hold a vertex; a vertex reads the cells
  // of its point widened by m_v - P/2 (its own cell when m_v = P/2).
  grid_.fit(built_, cell_);
  const int nt = static_cast<int>(tri_.size()), n = static_cast<int>(built_.size());
  const int cells = grid_.cells();
  occupied_.assign(cells, 0);
  vert_cell_.resize(n);
  for (int g = 0; g < n; ++g) {
    const Vec3& p = built_[g];
    vert_cell_[g] = grid_.index(grid_.axis(p.x(), 0), grid_.axis(p.y(), 1), grid_.axis(p.z(), 2));
    occupied_[vert_cell_[g]] = 1;
  }
  // Vertices with a margin beyond P/2 read more cells, which need not hold a vertex: mark them too.
  for (int g = 0; g < n; ++g) {
    if (!(margin_[g] > base)) continue;
    const Vec3& p = built_[g];
    const double w = margin_[g] - base;
    int r[6];
    for (int k = 0; k < 3; ++k) r[k] = grid_.axis(p[k] - w, k), r[k + 3] = grid_.axis(p[k] + w, k);
    for (int z = r[2]; z <= r[5]; ++z)
      for (int y = r[1]; y <= r[4]; ++y)
        for (int x = r[0]; x <= r[3]; ++x) occupied_[grid_.index(x, y, z)] = 1;
  }
  bucket_start_.assign(cells + 1, 0);
  tri_lo_.resize(nt), tri_hi_.resize(nt);
  large_.clear();
  long entries = 0;
  for (int q = 0; q < nt; ++q) {
    const auto& tri = tri_[q];
    const Vec3 &a = built_[tri[0]], &b = built_[tri[1]], &c = built_[tri[2]];
    const double reach = settings_.thickness + std::max({margin_[tri[0]], margin_[tri[1]], margin_[tri[2]]});
    tri_lo_[q] = a.cwiseMin(b).cwiseMin(c) - Vec3::Constant(reach);
    tri_hi_[q] = a.cwiseMax(b).cwiseMax(c) + Vec3::Constant(reach);
    auto& r = tri_range_[q];
    if (!(box_cells(tri_lo_[q], tri_hi_[q], inv_cell) <= kMaxBoxCells)) {
      large_.push_back(q);  // scanned by every vertex below instead of entered in each of its cells
      r = {0, 0, 0, -1, -1, -1};
      continue;
    }
    for (int k = 0; k < 3; ++k)
      r[k] = grid_.axis(tri_lo_[q][k] - base, k), r[k + 3] = grid_.axis(tri_hi_[q][k] + base, k);
    const char* const occupied = occupied_.data();
    int* const counts = bucket_start_.data();
    for (int z = r[2]; z <= r[5]; ++z)
      for (int y = r[1]; y <= r[4]; ++y) {
        const int row = grid_.index(0, y, z);
        for (int x = r[0]; x <= r[3]; ++x) {
          if (!occupied[row + x]) continue;
          if (entries == static_cast<long>(entry_cell_.size()))
            entry_cell_.resize(2 * entries + 1024), entry_tri_.resize(2 * entries + 1024);
          ++counts[row + x + 1];
          entry_cell_[entries] = row + x, entry_tri_[entries] = q, ++entries;
        }
      }
  }
  large_boxes_ += static_cast<long>(large_.size());
  hash_entries_ += entries;
  for (int k = 0; k < cells; ++k) bucket_start_[k + 1] += bucket_start_[k];
  bucket_items_.resize(entries);
  for (int k = 0; k < 3; ++k) ent_lo_[k].resize(entries + 4), ent_hi_[k].resize(entries + 4);
  fill_.assign(bucket_start_.begin(), bucket_start_.end() - 1);
  // Each entry carries its triangle's box (inflated by t + max_k m_k) in float, widened by 1 mm for the
  // rounding, so that the scan reads one cell's entries in a row.
  constexpr double kRound = 1e-3;  // m
  box_f_.resize(nt);
  for (int q = 0; q < nt; ++q) {
    const Vec3 lo = tri_lo_[q] - Vec3::Constant(kRound), hi = tri_hi_[q] + Vec3::Constant(kRound);
    box_f_[q] =
        FloatBox{{static_cast<float>(lo.x()), static_cast<float>(lo.y()), static_cast<float>(lo.z()), 0.0f},
                 {static_cast<float>(hi.x()), static_cast<float>(hi.y()), static_cast<float>(hi.z()), 0.0f}};
  }
  float *lx = ent_lo_[0].data(), *ly = ent_lo_[1].data(), *lz = ent_lo_[2].data();
  float *hx = ent_hi_[0].data(), *hy = ent_hi_[1].data(), *hz = ent_hi_[2].data();
  for (long e = 0; e < entries; ++e) {
    const int slot = fill_[entry_cell_[e]]++, q = entry_tri_[e];
    const FloatBox& b = box_f_[q];
    bucket_items_[slot] = q;
    lx[slot] = b.lo[0], ly[slot] = b.lo[1], lz[slot] = b.lo[2];
    hx[slot] = b.hi[0], hy[slot] = b.hi[1], hz[slot] = b.hi[2];
  }
  // Every vertex v against the triangles of the cells it reads: the box tests of [p - m_v, p + m_v] first
  // (the entries that pass are written to hit_), then the filters on the few that passed.
  cand_.clear();
  hit_.resize(bucket_items_.size() + large_.size());
  for (int g = 0; g < n; ++g) {
    const Vec3& p = built_[g];
    const double m = margin_[g];
    const float lo[4] = {static_cast<float>(p.x() - m), static_cast<float>(p.y() - m),
                         static_cast<float>(p.z() - m), 0.0f};
    const float hi[4] = {static_cast<float>(p.x() + m), static_cast<float>(p.y() + m),
                         static_cast<float>(p.z() + m), 0.0f};
    int nh = 0;
    bool merge = !large_.empty();
    if (!(m > base)) {
      nh = scan_cell(vert_cell_[g], lo, hi, 0);
    } else {
      const double w = m - base;
      int r[6];
      for (int k = 0; k < 3; ++k) r[k] = grid_.axis(p[k] - w, k), r[k + 3] = grid_.axis(p[k] + w, k);
      for (int z = r[2]; z <= r[5]; ++z)
        for (int y = r[1]; y <= r[4]; ++y)
          for (int x = r[0]; x <= r[3]; ++x) {
            nh = scan_cell(grid_.index(x, y, z), lo, hi, nh);  // distinct cells: distinct entries
          }
      merge = merge || r[0] != r[3] || r[1] != r[4] || r[2] != r[5];
    }
    for (int q : large_) {
      hit_[nh] = q;
      nh += box_f_[q].lo[0] <= hi[0] && box_f_[q].hi[0] >= lo[0] && box_f_[q].lo[1] <= hi[1] &&
            box_f_[q].hi[1] >= lo[1] && box_f_[q].lo[2] <= hi[2] && box_f_[q].hi[2] >= lo[2];
    }
    // Each triangle once and in order: a cell lists them so; several cells and the large ones are merged.
    if (merge) {
      std::sort(hit_.begin(), hit_.begin() + nh);
      nh = static_cast<int>(std::unique(hit_.begin(), hit_.begin() + nh) - hit_.begin());
    }
    // The hits and g's rest neighbours (rest_tri_) are both in ascending order: one merge walk.
    const int* rest = rest_tri_.data() + rest_start_[g];
    const int* const rest_end = rest_tri_.data() + rest_start_[g + 1];
    const int* const hits = hit_.data();
    const std::array<int, 3>* const tris = tri_.data();
    const int* const tri_cloth = tri_cloth_.data();
    const int cloth_g = vert_cloth_[g];
    const bool self = settings_.self;
    for (int k = 0; k < nh; ++k) {
      const int q = hits[k];
      const auto& tri = tris[q];
      if (tri[0] == g || tri[1] == g || tri[2] == g) continue;
      const bool same = tri_cloth[q] == cloth_g;
      if (same && !self) continue;
      if (same) {
        while (rest != rest_end && *rest < q) ++rest;
        if (rest != rest_end && *rest == q) continue;  // neighbours on the rest shape are not contacts
      }
      cand_.emplace_back(g, q);
    }
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
  // Step 1, when the list may miss a pair (always when no list matches the vertices). The margins belong to
  // the list: set with it, or for the positions built_ loaded with the state.
  if (built_.size() == static_cast<size_t>(n) && !cand_valid_) set_margins(ctx.h);
  if (built_.size() != static_cast<size_t>(n) || moved_too_far()) {
    built_.resize(n);
    for (int g = 0; g < n; ++g) built_[g] = *xs[g];
    set_margins(ctx.h);
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
  const FloatPoint* const start = start_.data();
  const FloatBox* const boxes = run_boxes_.data();
  for (const auto& [g, q] : cand_) {
    if (!in_box(start[g].p, boxes[q].lo, boxes[q].hi)) continue;
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
