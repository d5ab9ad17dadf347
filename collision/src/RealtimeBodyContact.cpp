#include "loom/collision/RealtimeBodyContact.h"

#include <algorithm>
#include <cmath>
#include <limits>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "GridCell.h"
#include "loom/collision/ColliderDistance.h"
#include "loom/collision/ColliderGeometry.h"
#include "loom/collision/FrictionPair.h"
#include "loom/collision/SweptCollider.h"

namespace loom::collision {

using cloth::ClothState;
using Prepared = RealtimeBodyContactStage::Prepared;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxCandidates = 64;     // colliders tested per vertex
constexpr int kPinchRounds = 8;        // rounds of the pinch exit
constexpr double kGridCell = 0.1;      // m, target cell size of the per-step collider grid
constexpr int kMaxGridDim = 32;        // cells per axis at most
constexpr size_t kMaskColliders = 64;  // colliders a mask holds (bits of an unsigned long long)
constexpr double kMaskMargin = 0.02;   // m, the least margin of a mask box
constexpr double kMaskSteps = 6.0;     // steps of motion a mask box's margin covers

// True when [alo, ahi] and [blo, bhi] overlap (false for NaN).
inline bool boxes_meet(const Vec3& alo, const Vec3& ahi, const Vec3& blo, const Vec3& bhi) {
  return alo.x() <= bhi.x() && blo.x() <= ahi.x() && alo.y() <= bhi.y() && blo.y() <= ahi.y() &&
         alo.z() <= bhi.z() && blo.z() <= ahi.z();
}
// True when [ilo, ihi] lies inside [olo, ohi] (false for NaN).
inline bool box_holds(const Vec3& olo, const Vec3& ohi, const Vec3& ilo, const Vec3& ihi) {
  return olo.x() <= ilo.x() && olo.y() <= ilo.y() && olo.z() <= ilo.z() && ihi.x() <= ohi.x() &&
         ihi.y() <= ohi.y() && ihi.z() <= ohi.z();
}

// Radius (m) of a sphere about the shape's origin that holds the whole shape (infinite for a plane).
double bounding_radius(const Shape& s) {
  switch (s.type) {
    case ShapeType::plane:
      return kInf;
    case ShapeType::sphere:
      return s.radius;
    case ShapeType::capsule:
      return s.half_height + s.radius;
    case ShapeType::box:
      return s.half_extents.norm();
    case ShapeType::cylinder:
      return std::hypot(s.radius, s.half_height);
    default: {
      double r = 0.0;
      for (const Vec3& v : s.vertices) r = std::max(r, v.norm());
      return r;
    }
  }
}

// Signed distance (m) from p to collider c at its step-end pose (end) or step-start pose, outward normal in
// n. Plane, sphere and capsule in closed form on the prepared world data; the rest through
// ColliderDistance.h.
double distance(const Collider& c, const Prepared& pc, bool end, const Vec3& p, Vec3* n) {
  switch (c.shape.type) {
    case ShapeType::sphere:
    case ShapeType::capsule: {
      const Vec3& a = end ? pc.a1 : pc.a0;
      const Vec3 ab = (end ? pc.b1 : pc.b0) - a;
      const double len2 = ab.squaredNorm();
      const double s = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
      const Vec3 d = p - (a + s * ab);
      const double l = d.norm();
      if (l > 1e-12) {
        *n = d / l;
      } else {  // on the axis: any direction normal to it
        const Transform& pose = end ? c.curr : c.prev;
        *n = pose.linear().col(0);
      }
      return l - pc.radius;
    }
    case ShapeType::plane: {
      const Transform& pose = end ? c.curr : c.prev;
      *n = pose.linear().col(1);
      return (p - pose.translation()).dot(*n);
    }
    default:
      return signed_distance(c, end ? c.curr : c.prev, p, n);
  }
}

}  // namespace

RealtimeBodyContactStage::RealtimeBodyContactStage(ColliderSetPtr colliders, RealtimeContactSettings settings)
    : colliders_(std::move(colliders)), settings_(settings) {
  if (!colliders_) colliders_ = std::make_shared<ColliderSet>();
  settings_.passes = std::max(1, settings_.passes);
  if (settings_.faces && !settings_.positions_only) {
    FeatureContactSettings fs;
    fs.thickness = settings_.thickness;
    if (settings_.friction >= 0.0) fs.friction = settings_.friction;
    if (settings_.static_friction >= 0.0) fs.static_friction = settings_.static_friction;
    fs.iterations = 1;    // the vertex projection follows
    fs.face_slack = 0.5;  // a garment wrapped round a capsule stays with the vertex projection
    fs.vertices = false;
    faces_ = std::make_unique<FeatureContactStage>(colliders_, fs);
  }
}

double RealtimeBodyContactStage::thickness(const Collider& c, double material_thickness) const {
  if (c.thickness > 0.0) return c.thickness;
  return settings_.thickness > 0.0 ? settings_.thickness : material_thickness;
}

std::vector<std::pair<std::string, double>> RealtimeBodyContactStage::counters() const {
  std::vector<std::pair<std::string, double>> out = {{"candidates", static_cast<double>(candidates_)},
                                                     {"contacts", static_cast<double>(contacts_)},
                                                     {"ccd_tests", static_cast<double>(ccd_tests_)},
                                                     {"ccd_hits", static_cast<double>(ccd_hits_)},
                                                     {"unresolved", static_cast<double>(unresolved_)}};
  double face_contacts = 0.0;
  if (faces_)
    for (const auto& [name, value] : faces_->counters())
      if (name == "face_contacts") face_contacts = value;
  out.emplace_back("face_contacts", face_contacts);
  if (limits_strain()) out.emplace_back("strain_corrections", static_cast<double>(strain_corrections_));
  return out;
}

void RealtimeBodyContactStage::run(cloth::StageContext& ctx) {
  for (Collider& c : *colliders_) {
    if (c.motion) c.prev = c.motion(ctx.t), c.curr = c.motion(ctx.t + ctx.h);
    if (c.shape.type == ShapeType::convex || c.shape.type == ShapeType::mesh) prepare_collider(c);
  }
  if (faces_) faces_->run(ctx);  // step 0: collider features against cloth triangles
  prepare_poses(*colliders_);
  const size_t nc = ctx.cloths.size();
  for (size_t c = 0; c < nc; ++c) {
    // Unchanged since the earlier stage's projection: a vertex it left outside every collider.
    const cloth::Vec3s* unchanged = earlier_ && earlier_->after_.size() == nc &&
                                            earlier_->after_[c].size() == ctx.cloths[c]->state().x.size()
                                        ? &earlier_->after_[c]
                                        : nullptr;
    if (unsettled_.size() < nc) unsettled_.resize(nc);
    unsettled_[c].clear();
    run_cloth(c, *ctx.cloths[c], ctx.h, unchanged, unsettled_[c]);
  }
  after_.resize(nc);
  for (size_t c = 0; c < nc; ++c) {
    after_[c] = ctx.cloths[c]->state().x;
    // A vertex the passes did not settle: never skipped by a later stage (NaN equals nothing).
    if (c < unsettled_.size())
      for (int i : unsettled_[c]) after_[c][i] = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  }
}

// A coarse grid over the cloth's box: each cell lists the active colliders whose box meets it, so a vertex
// tests the boxes of a few colliders (a character's neighbouring bones), not of all of them.
struct RealtimeBodyContactStage::ColliderGrid {
  Vec3 lo;
  int dims[3];
  Vec3 inv_cell;
  int cell_of(const Vec3& p, int a) const {
    return clamped_cell((p[a] - lo[a]) * inv_cell[a], 0, dims[a] - 1);
  }
  int cell_index(const Vec3& p) const {
    return (cell_of(p, 2) * dims[1] + cell_of(p, 1)) * dims[0] + cell_of(p, 0);
  }
};

void RealtimeBodyContactStage::run_cloth(size_t index, cloth::Cloth& cloth, double h,
                                         const cloth::Vec3s* unchanged, std::vector<int>& unsettled) {
  ColliderSet& set = *colliders_;
  ClothState& s = cloth.state();
  const int n = s.size();
  if (n == 0 || set.empty()) return;
  if (static_cast<int>(s.x_prev.size()) != n) s.x_prev = s.x;
  // Positions only: a collider whose box misses x cannot come within the thickness of x at the step's end
  // (the box holds the collider at curr inflated by the thickness), so x0's colliders are not needed.
  const bool end_only = settings_.positions_only;
  // The vertices to visit (with an earlier stage: those moved since it), and their box over the step (end
  // positions only when end_only; every free vertex's when the strain limit's rounds follow, they may move
  // any of them).
  const bool rounds = limits_strain();
  visit_.clear();
  Vec3 lo = Vec3::Constant(kInf), hi = Vec3::Constant(-kInf);
  for (int i = 0; i < n; ++i) {
    if (!(s.inv_mass[i] > 0.0)) continue;
    const bool visit = !(unchanged && (*unchanged)[i] == s.x[i]);
    if (visit) visit_.push_back(i);
    if (!visit && !rounds) continue;
    lo = lo.cwiseMin(s.x[i]), hi = hi.cwiseMax(s.x[i]);
    if (!end_only) lo = lo.cwiseMin(s.x_prev[i]), hi = hi.cwiseMax(s.x_prev[i]);
  }
  if (visit_.empty() && !rounds) return;
  if (!(lo.array() <= hi.array()).all()) return;  // no free vertex
  prepare_colliders(set, cloth.material().thickness, lo, hi);
  if (active_.empty() && !rounds) return;
  // The masks when the colliders fit in one (the strain limit's rounds look colliders up on the grid).
  const bool masked = !rounds && set.size() <= kMaskColliders;
  ColliderGrid grid;
  if (masked)
    refresh_masks(index, n);
  else
    grid = build_grid(lo, hi);

  if (rounds) held_.assign(n, 0);
  int cand[kMaxCandidates];
  for (int i : visit_) {
    const double m = s.mass[i];
    Vec3 x = s.x[i];
    const Vec3 x0 = s.x_prev[i];
    const int nc = masked ? masked_candidates(index, i, x, end_only ? x : x0, cand)
                          : gather_candidates(grid, x, end_only ? x : x0, cand);
    if (nc == 0) continue;
    candidates_ += nc;
    Vec3 v = s.v[i];
    if (settings_.continuous && !settings_.positions_only) sweep(set, cand, nc, x0, x);
    const bool moved = project(set, cand, nc, m, x0, h, x, v);
    if (moved) pinch_exit(set, cand, nc, x), unsettled.push_back(i);
    if (rounds && x != s.x[i]) held_[i] = 1;  // pushed out (project's result: moved in its last pass)
    s.x[i] = x;
    s.v[i] = v;
  }
  if (rounds) limit_rounds(index, cloth, h, grid, unsettled);
}

void RealtimeBodyContactStage::limit_rounds(size_t index, cloth::Cloth& cloth, double h,
                                            const ColliderGrid& grid, std::vector<int>& unsettled) {
  ColliderSet& set = *colliders_;
  ClothState& s = cloth.state();
  const int n = s.size();
  if (limited_.size() <= index) limited_.resize(index + 1);
  if (limited_[index].empty()) limited_[index] = cloth::limited_springs(cloth.mesh());
  const double max_stretch = settings_.strain_limit->max_stretch;
  int cand[kMaxCandidates];
  for (int round = 0; round < settings_.rounds; ++round) {
    limit_moved_.assign(n, 0);
    const long corrections = cloth::limit_stretch(cloth.mesh(), limited_[index], max_stretch,
                                                  settings_.sweeps, held_, s, limit_moved_);
    strain_corrections_ += corrections;
    if (corrections == 0) break;
    bool projected = false;
    for (int i = 0; i < n; ++i) {
      if (!limit_moved_[i]) continue;
      s.v[i] = (s.x[i] - s.x_prev[i]) / h;
      Vec3 x = s.x[i];
      const int nc = gather_candidates(grid, x, x, cand);
      if (nc == 0) continue;
      candidates_ += nc;
      Vec3 v = s.v[i];
      if (project(set, cand, nc, s.mass[i], s.x[i], h, x, v))
        pinch_exit(set, cand, nc, x), unsettled.push_back(i);
      if (x == s.x[i]) continue;
      held_[i] = 1;
      projected = true;
      s.x[i] = x;
    }
    if (!projected) break;
  }
}

void RealtimeBodyContactStage::prepare_poses(const ColliderSet& set) {
  prepared_.resize(set.size());
  for (size_t k = 0; k < set.size(); ++k) {
    const Collider& c = set[k];
    Prepared& pc = prepared_[k];
    const double extent = bounding_radius(c.shape);
    const Vec3 c0 = c.prev.translation(), c1 = c.curr.translation();
    const double theta = rotation_angle(c.prev, c.curr);
    pc.motion = (c1 - c0).norm() + (theta > 0.0 ? theta * extent : 0.0);
    if (c.shape.type == ShapeType::sphere || c.shape.type == ShapeType::capsule) {
      const Vec3 axis = Vec3(0.0, c.shape.type == ShapeType::capsule ? c.shape.half_height : 0.0, 0.0);
      pc.a0 = c.prev * (-axis), pc.b0 = c.prev * axis, pc.a1 = c.curr * (-axis), pc.b1 = c.curr * axis;
      pc.radius = c.shape.radius;
      pc.reach = pc.radius;
      pc.core_lo = pc.a0.cwiseMin(pc.b0).cwiseMin(pc.a1).cwiseMin(pc.b1);
      pc.core_hi = pc.a0.cwiseMax(pc.b0).cwiseMax(pc.a1).cwiseMax(pc.b1);
    } else {
      pc.reach = extent;
      pc.core_lo = c0.cwiseMin(c1), pc.core_hi = c0.cwiseMax(c1);
    }
  }
}

void RealtimeBodyContactStage::prepare_colliders(const ColliderSet& set, double material_thickness,
                                                 const Vec3& lo, const Vec3& hi) {
  active_.clear();
  for (size_t k = 0; k < set.size(); ++k) {
    const Collider& c = set[k];
    Prepared& pc = prepared_[k];
    pc.thickness = thickness(c, material_thickness);
    pc.mu_k = settings_.friction >= 0.0 ? settings_.friction : c.friction;
    pc.mu_s =
        std::max(pc.mu_k, settings_.static_friction >= 0.0 ? settings_.static_friction : c.static_friction);
    if (std::isinf(pc.reach)) {
      pc.lo = Vec3::Constant(-kInf), pc.hi = Vec3::Constant(kInf);
    } else {
      const double r = pc.reach + pc.thickness;
      pc.lo = pc.core_lo - Vec3::Constant(r);
      pc.hi = pc.core_hi + Vec3::Constant(r);
    }
    // A discrete test goes wrong only when the relative motion can carry a vertex past the collider's middle
    // (the axis of a sphere or capsule, a box's smallest half extent); for other shapes, past the thickness.
    switch (c.shape.type) {
      case ShapeType::sphere:
      case ShapeType::capsule:
        pc.swept_threshold = std::max(pc.thickness, pc.radius);
        break;
      case ShapeType::box:
        pc.swept_threshold = std::max(pc.thickness, c.shape.half_extents.minCoeff());
        break;
      default:
        pc.swept_threshold = pc.thickness;
    }
    pc.active = (pc.lo.array() <= hi.array()).all() && (pc.hi.array() >= lo.array()).all();
    if (pc.active) active_.push_back(static_cast<int>(k));
  }
}

RealtimeBodyContactStage::ColliderGrid RealtimeBodyContactStage::build_grid(const Vec3& lo, const Vec3& hi) {
  ColliderGrid g;
  g.lo = lo;
  int* dims = g.dims;
  const Vec3 extent = (hi - lo).cwiseMax(Vec3::Constant(1e-9));
  for (int a = 0; a < 3; ++a) dims[a] = clamped_cell(extent[a] / kGridCell, 1, kMaxGridDim);
  g.inv_cell = Vec3(dims[0] / extent.x(), dims[1] / extent.y(), dims[2] / extent.z());
  const int num_cells = dims[0] * dims[1] * dims[2];
  grid_start_.assign(num_cells + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) {
      for (int c = 0; c < num_cells; ++c) grid_start_[c + 1] += grid_start_[c];
      grid_items_.resize(grid_start_[num_cells]);
      grid_fill_.assign(grid_start_.begin(), grid_start_.end() - 1);
      for (int a = 0; a < 3; ++a)
        grid_lo_[a].resize(grid_start_[num_cells] + 2), grid_hi_[a].resize(grid_start_[num_cells] + 2);
    }
    for (int k : active_) {
      const Prepared& pc = prepared_[k];
      const Vec3 blo = pc.lo.cwiseMax(lo), bhi = pc.hi.cwiseMin(hi);
      for (int z = g.cell_of(blo, 2); z <= g.cell_of(bhi, 2); ++z)
        for (int y = g.cell_of(blo, 1); y <= g.cell_of(bhi, 1); ++y)
          for (int x = g.cell_of(blo, 0); x <= g.cell_of(bhi, 0); ++x) {
            const int c = (z * dims[1] + y) * dims[0] + x;
            if (pass == 0) {
              ++grid_start_[c + 1];
            } else {
              const int slot = grid_fill_[c]++;
              grid_items_[slot] = k;
              for (int a = 0; a < 3; ++a) grid_lo_[a][slot] = pc.lo[a], grid_hi_[a][slot] = pc.hi[a];
            }
          }
    }
  }
  return g;
}

int RealtimeBodyContactStage::gather_candidates(const ColliderGrid& grid, const Vec3& x, const Vec3& x0,
                                                int* cand) const {
  // Every collider whose box meets the box of the path x0 -> x (a collider the path crosses with both ends
  // outside its box too: a step longer than the collider, or across a corner of its box). From the cells
  // the path's box covers (the end's cell first, then the start's), or, for a path over more than 8 cells,
  // from all active colliders.
  int nc = 0;
  const Vec3 lo = x.cwiseMin(x0), hi = x.cwiseMax(x0);
  // The collider k whose box meets the path's box [lo, hi] (tested by the caller) unless listed; `fresh`: no
  // collider added yet and the entries from one cell (each collider once), so none is listed.
  auto add = [&](int k, bool fresh) {
    if (nc < kMaxCandidates && (fresh || std::find(cand, cand + nc, k) == cand + nc)) cand[nc++] = k;
  };
  // The entries of cell c, in order, whose box meets [lo, hi]: lo <= box hi and box lo <= hi on every axis
  // (false for NaN, as the comparisons of Eigen arrays), two entries at a time.
  auto add_cell = [&](int c) {
    const bool fresh = nc == 0;
    const int begin = grid_start_[c], end = grid_start_[c + 1];
#ifdef __SSE2__
    const __m128d lx = _mm_set1_pd(lo.x()), ly = _mm_set1_pd(lo.y()), lz = _mm_set1_pd(lo.z());
    const __m128d hx = _mm_set1_pd(hi.x()), hy = _mm_set1_pd(hi.y()), hz = _mm_set1_pd(hi.z());
    for (int it = begin; it < end; it += 2) {
      __m128d m = _mm_and_pd(_mm_cmple_pd(lx, _mm_loadu_pd(&grid_hi_[0][it])),
                             _mm_cmple_pd(_mm_loadu_pd(&grid_lo_[0][it]), hx));
      m = _mm_and_pd(m, _mm_and_pd(_mm_cmple_pd(ly, _mm_loadu_pd(&grid_hi_[1][it])),
                                   _mm_cmple_pd(_mm_loadu_pd(&grid_lo_[1][it]), hy)));
      m = _mm_and_pd(m, _mm_and_pd(_mm_cmple_pd(lz, _mm_loadu_pd(&grid_hi_[2][it])),
                                   _mm_cmple_pd(_mm_loadu_pd(&grid_lo_[2][it]), hz)));
      unsigned bits = static_cast<unsigned>(_mm_movemask_pd(m));
      if (end - it < 2) bits &= 1u;
      if (bits & 1u) add(grid_items_[it], fresh);
      if (bits & 2u) add(grid_items_[it + 1], fresh);
    }
#else
    for (int it = begin; it < end; ++it)
      if (lo.x() <= grid_hi_[0][it] && grid_lo_[0][it] <= hi.x() && lo.y() <= grid_hi_[1][it] &&
          grid_lo_[1][it] <= hi.y() && lo.z() <= grid_hi_[2][it] && grid_lo_[2][it] <= hi.z())
        add(grid_items_[it], fresh);
#endif
  };
  int first[3], last[3];
  long cells = 1;
  for (int a = 0; a < 3; ++a) {
    first[a] = grid.cell_of(lo, a), last[a] = grid.cell_of(hi, a);
    cells *= last[a] - first[a] + 1;
  }
  if (cells > 8) {
    for (int k : active_) {  // each collider once, in ascending order
      const Prepared& pc = prepared_[k];
      if ((lo.array() <= pc.hi.array()).all() && (pc.lo.array() <= hi.array()).all()) add(k, true);
    }
    return nc;
  }
  const int c1 = grid.cell_index(x), c0 = grid.cell_index(x0);
  add_cell(c1);
  if (c0 != c1) add_cell(c0);
  if (cells > 2)
    for (int z = first[2]; z <= last[2]; ++z)
      for (int y = first[1]; y <= last[1]; ++y)
        for (int xx = first[0]; xx <= last[0]; ++xx) {
          const int c = (z * grid.dims[1] + y) * grid.dims[0] + xx;
          if (c != c0 && c != c1) add_cell(c);
        }
  if (c0 != c1 || cells > 2) std::sort(cand, cand + nc);  // one cell lists them in ascending order
  return nc;
}

void RealtimeBodyContactStage::refresh_masks(size_t index, int n) {
  if (masks_.size() <= index) masks_.resize(index + 1);
  ColliderMasks& cm = masks_[index];
  const int nk = static_cast<int>(prepared_.size());
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (static_cast<int>(cm.vlo.size()) != n || static_cast<int>(cm.lo[0].size()) != nk) {
    for (int a = 0; a < 3; ++a) cm.lo[a].assign(nk, kNaN), cm.hi[a].assign(nk, kNaN);
    cm.vlo.assign(n, Vec3::Constant(kNaN)), cm.vhi.assign(n, Vec3::Constant(kNaN));
    cm.mask.assign(n, 0);
  }
  for (int k = 0; k < nk; ++k) {
    const Prepared& pc = prepared_[k];
    const Vec3 blo(cm.lo[0][k], cm.lo[1][k], cm.lo[2][k]), bhi(cm.hi[0][k], cm.hi[1][k], cm.hi[2][k]);
    if (box_holds(blo, bhi, pc.lo, pc.hi)) continue;
    const double margin = std::max(kMaskMargin, kMaskSteps * pc.motion);
    const Vec3 nlo = pc.lo - Vec3::Constant(margin), nhi = pc.hi + Vec3::Constant(margin);
    for (int a = 0; a < 3; ++a) cm.lo[a][k] = nlo[a], cm.hi[a][k] = nhi[a];
    const unsigned long long bit = 1ull << k;
    for (int i = 0; i < n; ++i) {
      if (boxes_meet(cm.vlo[i], cm.vhi[i], nlo, nhi))
        cm.mask[i] |= bit;
      else
        cm.mask[i] &= ~bit;
    }
  }
}

int RealtimeBodyContactStage::masked_candidates(size_t index, int i, const Vec3& x, const Vec3& x0,
                                                int* cand) {
  ColliderMasks& cm = masks_[index];
  const Vec3 lo = x.cwiseMin(x0), hi = x.cwiseMax(x0);
  if (!box_holds(cm.vlo[i], cm.vhi[i], lo, hi)) {
    const double margin = std::max(kMaskMargin, kMaskSteps * (x - x0).norm());
    cm.vlo[i] = lo - Vec3::Constant(margin), cm.vhi[i] = hi + Vec3::Constant(margin);
    unsigned long long mask = 0;
    const int nk = static_cast<int>(prepared_.size());
    for (int k = 0; k < nk; ++k)
      if (boxes_meet(cm.vlo[i], cm.vhi[i], Vec3(cm.lo[0][k], cm.lo[1][k], cm.lo[2][k]),
                     Vec3(cm.hi[0][k], cm.hi[1][k], cm.hi[2][k])))
        mask |= 1ull << k;
    cm.mask[i] = mask;
  }
  int nc = 0;
  for (unsigned long long bits = cm.mask[i]; bits; bits &= bits - 1) {
    const int k = __builtin_ctzll(bits);
    const Prepared& pc = prepared_[k];
    if (pc.active && boxes_meet(lo, hi, pc.lo, pc.hi)) cand[nc++] = k;
  }
  return nc;
}

// Step 3: the swept test, only where the motion relative to the collider exceeds its thickness and the
// vertex started outside within reach.
void RealtimeBodyContactStage::sweep(const ColliderSet& set, const int* cand, int nc, const Vec3& x0,
                                     Vec3& x) {
  const double step = (x - x0).norm();
  Vec3 nrm;
  for (int q = 0; q < nc; ++q) {
    const Collider& c = set[cand[q]];
    const Prepared& pc = prepared_[cand[q]];
    const double reach = step + pc.motion;
    if (reach <= pc.swept_threshold) continue;
    const double d0 = distance(c, pc, false, x0, &nrm);
    if (d0 <= 0.0 || d0 > reach + pc.thickness) continue;
    ++ccd_tests_;
    const SweptHit hit = swept_point(c, x0, x, 0.5 * pc.thickness);
    if (!hit.hit) continue;
    ++ccd_hits_;
    x = c.curr * hit.local;  // carried with the body from the contact to the step's end
    break;
  }
}

// Step 4: discrete projection and the velocity response; true when the vertex was moved.
bool RealtimeBodyContactStage::project(ColliderSet& set, const int* cand, int nc, double m, const Vec3& x0,
                                       double h, Vec3& x, Vec3& v) {
  Vec3 nrm;
  bool moved = true;
  for (int pass = 0; pass < settings_.passes && moved; ++pass) {
    moved = false;
    for (int q = 0; q < nc; ++q) {
      Collider& c = set[cand[q]];
      const Prepared& pc = prepared_[cand[q]];
      const double d = distance(c, pc, true, x, &nrm);
      if (d >= pc.thickness) continue;
      const double push = pc.thickness - d;
      x += push * nrm;
      moved = true;
      ++contacts_;
      if (settings_.positions_only) continue;
      // Position-level Coulomb friction on the step's motion relative to the surface, the push standing for
      // the normal impulse (Macklin et al. 2014, "Unified particle physics for real-time applications",
      // Sec. 6.1): the tangential slip is undone when within μ_s of the push, else shortened by μ_k of it.
      const Vec3 rel = (x - x0) - (c.curr * (c.prev.inverse() * x0) - x0);
      const Vec3 slip = rel - rel.dot(nrm) * nrm;
      const double len = slip.norm();
      if (len > 0.0) x -= len <= pc.mu_s * push ? slip : Vec3(slip * std::min(1.0, pc.mu_k * push / len));
      const Vec3 vs = surface_velocity(c.prev, c.curr, h, x);
      const Vec3 vr = v - vs;
      if (vr.dot(nrm) >= 0.0) continue;  // separating: position only
      const Vec3 v_new = vs + coulomb_tangent(vr, nrm, pc.mu_s, pc.mu_k);
      // Step 5: the reaction on the collider.
      const Vec3 impulse = m * (v_new - v);
      c.reaction_impulse -= impulse;
      c.reaction_angular_impulse -= (x - c.curr.translation()).cross(impulse);
      v = v_new;
    }
  }
  return moved;
}

// A pinch (the passes push the vertex from one collider into another, e.g. an arm pressed against the
// torso): move it along the sum of the normals of the colliders it is inside, by the deepest depth,
// until it is outside all of them (a few rounds); what remains is counted. Runs after step 4 moved x.
void RealtimeBodyContactStage::pinch_exit(const ColliderSet& set, const int* cand, int nc, Vec3& x) {
  Vec3 nrm;
  for (int round = 0; round < kPinchRounds; ++round) {
    Vec3 sum = Vec3::Zero();
    double deepest = 0.0;
    for (int q = 0; q < nc; ++q) {
      const double d = distance(set[cand[q]], prepared_[cand[q]], true, x, &nrm);
      if (d < 0.0) sum += nrm, deepest = std::max(deepest, -d + prepared_[cand[q]].thickness);
    }
    if (deepest == 0.0) break;
    const double len = sum.norm();
    if (!(len > 1e-12)) break;
    x += deepest * (sum / len);
  }
  for (int q = 0; q < nc; ++q)
    if (distance(set[cand[q]], prepared_[cand[q]], true, x, &nrm) < 0.0) {
      ++unresolved_;
      break;
    }
}

}  // namespace loom::collision
