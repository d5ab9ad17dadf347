#pragma once
// Geometric drape (Weil 1986, "The synthesis of cloth objects", SIGGRAPH '86), `solver.method: "weil"`: no
// dynamics, the hanging shape is synthesised from catenaries.
//   1. Between every pair of constraint points (pinned vertices, at their targets) a catenary of the cloth's
//      length between them (the rest distance) is hung in the vertical plane through them; the vertices lying
//      on the straight rest segment between the pair take the catenary's point at their arc length.
//   2. Subdivision along new catenaries (grids): every grid row and column is scanned; between two
//      consecutive placed vertices with unplaced ones between them, a new catenary is hung and gives those
//      their positions. All candidates of one pass come from the previous pass's placed vertices and a vertex
//      on several catenaries takes the highest one (the cloth rests on the tightest curve) — so the result
//      does not depend on the order of rows and columns and a symmetric setup gives a symmetric drape.
//      Repeated until nothing changes.
//   3. What is left (outside every catenary: below the constraint points) hangs straight down from the
//   nearest
//      placed vertex of its column or row, at its rest distance.
// Catenary through a and b of length S, horizontal span d, rise h (Weil 1986; docs/validation.md): y = α
// cosh((x - x0)/α) + c with sqrt(S² - h²) = 2α sinh(d/2α) (solved for α by Newton's method on the log), taut
// (a straight segment) when S <= |b - a|. "Down" is the direction of the cloth's gravity term (-y without
// one). It is honest about what it cannot do: check() refuses cloths that need motion or forces it does not
// model (drag or wind, moving pins, an initial velocity, no pins, a non-grid mesh), naming the scene field;
// the scene loader refuses colliders, rigid bodies, characters and collision for it. The first step places
// the cloth; later steps keep it (velocities zero).
#include "loom/cloth/Solver.h"

namespace loom::cloth {

// Point at arc length s (0 <= s <= S) along the catenary of length S from a to b hanging along `down` (unit).
Vec3 catenary_point(const Vec3& a, const Vec3& b, double S, double s, const Vec3& down);

class WeilSolver final : public Solver {
 public:
  const char* name() const override { return "weil"; }
  void check(const Cloth& cloth) const override;
  void step(Cloth& cloth, double t, double h, int threads) override;
  // The drape is made again after a state is restored (the guard's rollback, a checkpoint): the restored
  // state is the undraped one.
  void load_state(StateReader& in, const Cloth& cloth) override {
    (void)in, (void)cloth;
    placed_ = nullptr;
  }
  double last_ms() const { return last_ms_; }  // ms, time of the last synthesis

 private:
  const Cloth* placed_ = nullptr;  // the cloth already draped
  double last_ms_ = 0.0;
};

// The drape of `cloth` with its constraint points at `pins` (vertex, position); free vertices get their
// place.
void weil_drape(const Cloth& cloth, const std::vector<std::pair<int, Vec3>>& pins, const Vec3& down,
                Vec3s& x);

}  // namespace loom::cloth
