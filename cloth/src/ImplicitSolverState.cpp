// Save and restore of ImplicitSolver's history (non-finite guard, checkpoints): everything a step
// reads that an earlier step wrote, so a restored solver continues bit-identically.
#include "loom/cloth/ImplicitSolver.h"

namespace loom::cloth {

void ImplicitSolver::save_state(StateWriter& out) const {
  out.tag(name());
  out.i64(has_history_ ? 1 : 0);
  out.vec3s(x_hist_);
  out.vec3s(v_hist_);
  out.f64(h_hist_);
  out.f64(h_sub_);
  out.i64(streak_);
  out.vec3s(dv_);
  out.f64(h_dv_);
}

void ImplicitSolver::load_state(StateReader& in, const Cloth& cloth) {
  prepare(cloth);  // builds the pattern (and would clear the history): before the history is read
  in.tag(name());
  has_history_ = in.i64() != 0;
  x_hist_ = in.vec3s();
  v_hist_ = in.vec3s();
  h_hist_ = in.f64();
  h_sub_ = in.f64();
  streak_ = static_cast<int>(in.i64());
  dv_ = in.vec3s();
  h_dv_ = in.f64();
  energy_cache_valid_ = false;
}

}  // namespace loom::cloth
