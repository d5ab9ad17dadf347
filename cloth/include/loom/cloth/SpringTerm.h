#pragma once
// Hooke springs with damping along the spring (docs/references.md, "Cloth models"):
//   f_i = k (l - L) x̂ + c (x̂·(v_j - v_i)) x̂,  f_j = -f_i,  x̂ = (x_j - x_i) / l,  E = k/2 (l - L)².
// Forces are computed per spring in parallel, then gathered per vertex in a fixed order, so the result is
// bit-identical for any thread count. Jacobians likewise: per-spring blocks in parallel, then added block by
// block in spring order (BlockGather).
#include "loom/cloth/BlockGather.h"
#include "loom/cloth/PairGather.h"
#include "loom/cloth/Term.h"

namespace loom::cloth {

struct Spring {
  int i = 0, j = 0;
  double rest_length = 0.0;  // m
  double k = 0.0;            // N/m
  double c = 0.0;            // N·s/m, damping along the spring
};

class SpringTerm final : public Term {
 public:
  SpringTerm(int num_vertices, std::vector<Spring> springs, const char* name = "springs");
  const char* name() const override { return name_; }
  double energy(const EvalContext& c) const override;
  void add_forces(const EvalContext& c, Vec3s& f) const override;
  void add_pattern(std::vector<std::pair<int, int>>& pairs) const override;
  void add_jacobians(const EvalContext& c, const JacobianOptions& o, BlockMatrix* dfdx,
                     BlockMatrix* dfdv) const override;
  bool has_velocity_jacobian() const override { return damped_; }
  // K_s = k [n̂n̂ᵀ + r (I - n̂n̂ᵀ)] and c n̂n̂ᵀ are symmetric element by element and go to (i, j) and (j, i)
  // in spring order; only the damping position term (non-symmetric) breaks that.
  bool symmetric_jacobians(const JacobianOptions& o) const override {
    return !(o.damping_position_terms && damped_);
  }
  long work_items() const override { return static_cast<long>(springs_.size()); }
  const std::vector<Spring>& springs() const { return springs_; }

 private:
  const char* name_;
  int n_;
  std::vector<Spring> springs_;
  PairGather gather_;
  bool damped_ = false;                      // some spring has c != 0 (df/dv is not zero)
  mutable Vec3s spring_force_;               // scratch: force on end i of each spring
  mutable std::vector<Mat3> kx_, kv_;        // scratch: df_i/dx_j (N/m) and df_i/dv_j (N·s/m) of each spring
  mutable BlockGather gather_x_, gather_v_;  // slot lists of the df/dx and df/dv matrices
};

}  // namespace loom::cloth
