#pragma once
// RealtimeSelfCollisionStage ("realtime_self_collision"): the real-time tier's self- and cloth-cloth
// collision, proximity only, on a budget. Every `every`-th step it
//   1. broad phase, only when the cloths have moved far enough since the last one. Each vertex g gets a
//      margin m_g = max(P/2, |u_g - u| T) (P the padding, u_g its velocity, u the mean velocity, T the time
//      of kHorizonRuns runs; at most kMaxMarginPaddings P), the motion relative to the others it may gather
//      before the list is rebuilt. Every triangle of every cloth, its box inflated by the thickness t plus
//      the largest margin of its corners, goes into the cells of a uniform grid of about two mean edge
//      lengths that a vertex reads (Teschner et al. 2003, "Optimized spatial hashing for collision detection
//      of deformable objects", with a dense table in place of the hash: counting sort, no allocation per
//      step once the scratch has grown); every vertex v whose point widened by m_v meets the box of a
//      triangle of its cells that does not hold it (box tests four at a time) becomes a candidate pair,
//      except pairs of one cloth closer than 2t at rest (a vertex and a neighbouring triangle on flat cloth:
//      never contacts). The list is sorted by (vertex, triangle) without duplicates. While every vertex's
//      displacement since that broad phase lies within its margin of the mean displacement, a vertex and
//      the corners of a triangle have moved by at most m_v + m_k relative to each other, so the list holds
//      every pair whose vertex lies in the triangle's box inflated by t now; the broad phase runs again when
//      a vertex leaves its margin;
//   2. narrow phase, for the candidates whose vertex lies in the triangle's box inflated by t at the run's
//      start: where the vertex projects inside the triangle and lies closer than the thickness t to its
//      plane, the pair is pushed apart to t along the triangle normal (t between cloths, a fraction of it
//      within one, where a smaller gap lets folds form), on the side the vertex was on at the end of the
//      previous run (so a vertex that went through between runs is brought back, not pushed further). A
//      position-based projection of C = s (x_v - Σ b_k x_k)·n - t >= 0 (Müller et al. 2007, "Position based
//      dynamics", Sec. 3.3), with s = ±1 the remembered side and b the barycentric weights, split by inverse
//      mass; the approaching normal velocity is removed by the same weights;
//   3. remembers the positions as the sides of the next run.
// The narrow phase visits the pairs in (vertex, triangle) order and its box test is exact, so the result
// does not depend on when the broad phase ran (the positions of the last broad phase are part of the state).
// Vertex-triangle proximity without continuous tests: pairs that cross by more than t between two runs, or
// that cross edge against edge, are not caught; the census (MultiClothCensus.h) measures what is left.
// Runs on one thread: results do not depend on the thread count.
#include <array>
#include <memory>
#include <vector>

#include "loom/cloth/Stage.h"

namespace loom::collision {

struct RealtimeSelfSettings {
  bool self = true;            // within each cloth as well as between cloths
  double thickness = 0.02;     // m, the proximity kept between a vertex and a triangle of another cloth
  double self_fraction = 0.5;  // 1, the proximity within one cloth, as a fraction of `thickness`
  int every = 1;               // run at every k-th step
  double padding = 0.02;       // m, P: the broad phase's margin beyond the thickness
};

class RealtimeSelfCollisionStage final : public cloth::Stage {
 public:
  explicit RealtimeSelfCollisionStage(RealtimeSelfSettings settings);
  const char* name() const override { return "realtime_self_collision"; }
  // Cells a triangle's box may span in the hash: a triangle of a sane cloth spans a few per axis (cells are
  // at least two mean edges wide), a stretched or exploding one could span billions. A larger box is not
  // entered cell by cell but tested against every vertex (exact, bounded by vertices x such triangles).
  static constexpr double kMaxBoxCells = 4096;
  void run(cloth::StageContext& ctx) override;
  // runs, broad_phases, candidates (pairs listed, summed over broad phases), pairs (narrow-phase tests
  // past the box), contacts (projections), large_boxes (triangles whose box spans more than kMaxBoxCells
  // cells, tested against every vertex instead) and hash_entries (cell entries made: cells that hold a
  // vertex), summed over broad phases.
  std::vector<std::pair<std::string, double>> counters() const override;
  void save_state(cloth::StateWriter& out) const override;
  void load_state(cloth::StateReader& in) override;

 private:
  // Cells per axis of a grid at most (wider cells when the points spread further).
  static constexpr int kMaxGridDim = 64;
  // A uniform grid of dim[k] cells of side 1 / inv[k] from origin[k] per axis; coordinates beyond it are
  // clamped to the border cells (those only hold more, the tests stay exact), NaN to cell 0.
  struct Grid {
    double origin[3] = {0.0, 0.0, 0.0};  // m
    double inv[3] = {1.0, 1.0, 1.0};     // 1/m
    int dim[3] = {1, 1, 1};
    // Cells of at least `side` (m) over the finite coordinates of `points`.
    void fit(const cloth::Vec3s& points, double side);
    int axis(double v, int k) const;  // cell index on axis k, monotone in v
    int index(int x, int y, int z) const { return x + dim[0] * (y + dim[1] * z); }
    int cells() const { return dim[0] * dim[1] * dim[2]; }
  };
  void prepare(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths);
  // Runs ahead the margins are set for, and the largest margin in paddings.
  static constexpr double kHorizonRuns = 4.0;
  static constexpr double kMaxMarginPaddings = 3.0;
  // Fills margin_ from the velocities (h: s, the step size).
  void set_margins(double h);
  // False when every vertex's displacement since the broad phase at built_ lies within its margin of the
  // mean displacement (step 1's bound).
  bool moved_too_far() const;
  // Appends to hit_ from position nh the triangles of `cell` whose box meets [lo, hi]; the new count.
  int scan_cell(int cell, const float* lo, const float* hi, int nh);
  // Fills rest_start_ / rest_tri_.
  void rest_neighbours();
  // Step 1 at the positions built_.
  void broad_phase();

  RealtimeSelfSettings settings_;
  bool prepared_ = false;
  long step_ = 0;
  double cell_ = 0.1;                    // m, cell size
  std::vector<int> offset_;              // first global vertex of each cloth (size cloths + 1)
  std::vector<int> tri_cloth_;           // per global triangle: its cloth
  std::vector<std::array<int, 3>> tri_;  // per global triangle: global vertex indices
  std::vector<int> vert_cloth_;          // per global vertex: its cloth
  cloth::Vec3s rest_;                    // m, per global vertex: rest position
  // Per global vertex g: the triangles of its cloth it lies within 2t of and inside at rest (never
  // contacts), rest_tri_[rest_start_[g] .. rest_start_[g + 1]).
  std::vector<int> rest_start_, rest_tri_;
  cloth::Vec3s last_;  // m, per global vertex: positions at the end of the previous run
  Grid grid_;          // the broad phase's cells
  std::vector<int> bucket_start_, bucket_items_;  // per cell: its triangles (counting sort)
  struct alignas(16) FloatBox {
    float lo[4], hi[4];  // m (x, y, z, unused)
  };
  struct alignas(16) FloatPoint {
    float p[4];  // m (x, y, z, unused)
  };
  std::vector<FloatBox> box_f_;      // scratch: per triangle, its padded box in float
  std::vector<FloatBox> run_boxes_;  // per triangle: box inflated by the thickness at the run's start
  std::array<std::vector<float>, 3> ent_lo_, ent_hi_;  // m, per cell entry: its triangle's box per axis
  std::vector<int> entry_cell_, entry_tri_;  // scratch: per cell entry, its cell and triangle (capacity)
  std::vector<double> margin_;  // m, per global vertex: m_g, its margin for the list of the broad phase
  std::vector<std::array<int, 6>> tri_range_;  // per triangle: cell range lo xyz, hi xyz
  std::vector<int> vert_cell_;                 // scratch: per vertex, its cell at the broad phase
  std::vector<char> occupied_;                 // scratch: per cell, a vertex reads it
  std::vector<int> hit_;                       // scratch: one vertex's triangles whose box holds it
  std::vector<int> large_;         // triangles whose box spans too many cells: tested against every vertex
  cloth::Vec3s tri_lo_, tri_hi_;   // m, per triangle: box inflated by the thickness, this run
  std::vector<FloatPoint> start_;  // m, per global vertex: position at the run's start
  cloth::Vec3s built_;  // m, per global vertex: positions at the last broad phase (empty: none yet)
  std::vector<std::pair<int, int>> cand_;  // candidate (vertex, triangle) pairs of the last broad phase
  bool cand_valid_ = false;                // cand_ was built from built_
  cloth::Vec3s tri_n_;                     // 1, per triangle: unit normal at the run's start (0: degenerate)
  std::vector<cloth::Vec3*> xs_, vs_;      // scratch: each global vertex's position and velocity
  std::vector<double> w_;                  // scratch: each global vertex's inverse mass (1/kg)
  std::vector<int> fill_;                  // scratch: counting-sort cursors
  long runs_ = 0, broad_phases_ = 0, candidates_ = 0, pairs_ = 0, contacts_ = 0, large_boxes_ = 0,
       hash_entries_ = 0;
};

}  // namespace loom::collision
