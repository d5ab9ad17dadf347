#pragma once
// Air drag against a (possibly gusting) wind, two parts, both linear in the relative velocity:
//  - isotropic:  f_i = -c_iso A_i (v_i - w(t))                       (A_i: vertex area)
//  - normal:     f_t = -c_n A_t ((v̄_t - w(t))·n̂_t) n̂_t, a third to each vertex of triangle t
//                (v̄_t: mean vertex velocity, n̂_t: unit normal; A_t n̂_t n̂_t = N Nᵀ / (2|N|), N = e1 × e2)
// The normal part is what makes a flag flutter. Non-conservative: energy 0. Its df/dx is exact
// (non-symmetric). Wind: w(t) = w0 (1 + gust_amplitude sin(2π gust_frequency t)).
#include "loom/cloth/Term.h"

namespace loom::cloth {

struct DragSettings {
  double isotropic = 0.0;       // kg/(m²·s)
  double normal = 0.0;          // kg/(m²·s)
  Vec3 wind = Vec3::Zero();     // m/s
  double gust_amplitude = 0.0;  // 1, relative
  double gust_frequency = 0.0;  // Hz
  Vec3 wind_at(double t) const;
};

class AirDragTerm final : public Term {
 public:
  AirDragTerm(const DragSettings& s, std::vector<Tri> triangles, std::vector<double> vertex_area);
  const char* name() const override { return "drag"; }
  bool conservative() const override { return false; }
  double energy(const EvalContext&) const override { return 0.0; }
  void add_forces(const EvalContext& c, Vec3s& f) const override;
  void add_pattern(std::vector<std::pair<int, int>>& pairs) const override;
  void add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                     BlockMatrix* dfdv) const override;
  long work_items() const override { return static_cast<long>(vertex_area_.size() + triangles_.size()); }

 private:
  DragSettings s_;
  std::vector<Tri> triangles_;
  std::vector<double> vertex_area_;                 // m²
  std::vector<std::vector<int>> vertex_triangles_;  // for the deterministic gather
  mutable Vec3s tri_force_;  // scratch: force on each vertex of triangle t (same for all 3)
};

}  // namespace loom::cloth
