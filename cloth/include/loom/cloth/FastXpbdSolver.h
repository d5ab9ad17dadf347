#pragma once
// FastXpbdSolver ("fast_xpbd"): the real-time tier's solver. XPBD (Macklin, Müller, Chentanez 2016, eq. 18
// with its damping term) on the cloth's springs, C = l - L, compliance α = scale / k, run as many small
// substeps with one iteration each (Macklin et al. 2019, "Small steps in physics simulation": with one
// iteration λ starts at 0 and is not stored). The same physics as XpbdSolver with its data laid out for
// speed:
//   - springs as structure of arrays (int32 vertex indices, and per spring in float: rest length, γ and the
//     inverse denominator 1 / ((1 + γ)(w_i + w_j) + α̃), recomputed only when h or the inverse masses change);
//   - predicted positions in float, in local coordinates q = Rᵀ (p - o) of a per-step frame (o, R): by
//     default o is the cloth's first vertex and R the world axes, or the frame given by set_frame (a
//     character's), padded to four with the inverse mass as the fourth entry, so one 16-byte load gives a
//     vertex's position and weight; eight springs of one colour are projected at once in AVX lanes where the
//     processor has AVX (checked at run time), four in SSE lanes otherwise (4x4 transposes in and out; no
//     fused multiply-add, so every form rounds alike). Only the constraint corrections pass through float:
//     x_new = p_pred + R (q_f - q_f0) with p_pred in double, so gravity's per-substep increment (h² g, 19 µm
//     at 1.4 ms) is kept exactly and the corrections carry a rounding of about 1e-7 of the cloth's size. The
//     double state never leaves world coordinates and the frame is taken afresh each step, so nothing pops
//     when it moves, and the float rounding (hence the motion) does not depend on where in the world the
//     cloth is, nor, with a frame that turns with it, on which way it faces;
//   - springs grouped by colour (no shared vertex within a colour), sorted by lower vertex index and padded
//     to a multiple of eight with springs of zero weight on a spare vertex, so every colour is whole SIMD
//     batches and can be split over threads at batch boundaries; a spring's correction depends only on its
//     two vertices, so results do not depend on the thread count or on which form projects it.
// One step: p = x + h v + h² M⁻¹ f_ext (f_ext: gravity, drag), `iterations` Gauss-Seidel sweeps over the
// colours, v = (p - x) / h, x = p. Kinematic vertices (inverse mass 0) move by exactly x += h v.
#include <vector>

#include "loom/cloth/Solver.h"

namespace loom::cloth {

class FastXpbdSolver final : public Solver {
 public:
  FastXpbdSolver(int iterations, double compliance_scale)
      : iterations_(iterations), compliance_scale_(compliance_scale) {}
  const char* name() const override { return "fast_xpbd"; }
  void check(const Cloth& cloth) const override;
  void step(Cloth& cloth, double t, double h, int threads) override;
  void reset() override { h_ = 0.0; }
  void set_frame(const Eigen::Isometry3d& frame) override;
  // springs (constraints per sweep), sweeps (substep-iterations run).
  std::vector<std::pair<std::string, double>> counters() const override;
  // The springs of the last prepared cloth as (i, j) vertex pairs, colour by colour in sweep order (padding
  // left out). Empty before the first step.
  std::vector<std::vector<std::pair<int, int>>> spring_colors() const;
  // Springs projected at once: 8 (AVX), 4 (SSE) or 1; at most what the processor runs, which is the default.
  // Every form gives the same bits; this is for comparing them.
  void set_lanes(int lanes);

 private:
  struct alignas(16) Point {
    float x, y, z;
    float w;  // 1/kg, inverse mass
  };
  void prepare(const Cloth& cloth);
  // γ, α̃ and the inverse denominators of springs [begin, end) for step h.
  void update_denominators(const ClothState& s, double h, int begin, int end);
  template <bool kTurn>
  void predict(const ClothState& s, double h, const double* gravity_mass, const Vec3& g, int begin, int end);
  template <bool kTurn>
  void finish(ClothState& s, double h, const double* gravity_mass, const Vec3& g, int begin, int end);
  // Projects springs [begin, end) of one colour; begin and end are multiples of 8 (whole batches).
  void project(int begin, int end);
  void project_lambda(int begin, int end);

  int iterations_;
  double compliance_scale_;  // 1, multiplies α = 1/k
  const Cloth* prepared_for_ = nullptr;
  // Springs, colour by colour: colour c is [color_start_[c], color_start_[c + 1]), a multiple of 8 long;
  // padding springs join the spare vertex n with itself and have zero weight.
  std::vector<int> si_, sj_;
  std::vector<float> rest_;       // m
  std::vector<float> alpha_;      // m/N, α = scale / k
  std::vector<float> beta_;       // s, β = c / k
  std::vector<float> gamma_;      // 1, γ = β / h, this h
  std::vector<float> alpha_t_;    // 1/kg, α̃ = α / h², this h
  std::vector<float> inv_denom_;  // kg, 1 / ((1 + γ)(w_i + w_j) + α̃), 0 when both ends are kinematic
  std::vector<double> lambda_;    // N·s², per spring (more than one iteration only)
  std::vector<int> color_start_;
  int real_springs_ = 0;  // springs without the padding
  int lanes_ = 0;         // springs projected at once (0: not chosen yet, the widest form)
  int vertices_ = 0;      // the prepared cloth's vertex count, also the spare vertex's index
  // n + 1 points: the cloth's vertices and the spare vertex of the padding springs.
  std::vector<Point> p_;          // projected positions (m, local: Rᵀ (p - origin_)) and inverse masses
  std::vector<Point> x0_;         // positions at the step's start (m, local), for damping
  Vec3 origin_ = Vec3::Zero();    // m, this step's origin of p_ and x0_
  Mat3 axes_ = Mat3::Identity();  // 1, R: the local axes in world coordinates (columns)
  bool framed_ = false;           // set_frame was called: origin_ and axes_ are its frame's
  std::vector<double> inv_mass_;  // 1/kg, the inverse masses the denominators were computed for
  double h_ = 0.0;                // s, the step the denominators were computed for
  Vec3s f_;                       // N, external forces
  bool damped_ = false;           // some spring has β > 0 (the damping term is evaluated)
  long sweeps_ = 0;
};

}  // namespace loom::cloth
