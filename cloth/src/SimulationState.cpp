// Simulation state save/restore, the step change and the guard's energy scale.
#include <algorithm>
#include <cmath>

#include "GuardInternal.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Simulation.h"

namespace loom::cloth {

GuardSample guard_sample(const FrameStats& s) {
  GuardSample g;
  g.finite = s.finite;
  g.kinetic = s.kinetic;
  g.potential = s.potential;
  g.elastic = s.elastic;
  g.max_strain = s.max_strain;
  return g;
}

double guard_weight_scale(const SimulationSetup& setup, const std::vector<std::unique_ptr<Cloth>>& cloths) {
  double e = 0.0;
  for (const auto& c : cloths) {
    const Vec3s& X = c->mesh().rest_positions();
    Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
    for (const Vec3& p : X) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    double m = 0.0;
    for (double mi : c->state().mass) m += mi;
    e += m * setup.gravity.norm() * (X.empty() ? 0.0 : (hi - lo).norm());
  }
  return e;
}

double guard_energy_scale(const SimulationSetup& setup, const std::vector<std::unique_ptr<Cloth>>& cloths) {
  // Guard.h: E_ref = Σ m (|g| L + ½ v_ref²), v_ref = 10 m/s + the fastest wind (with gusts), initial
  // velocity or pin path.
  double v_ref = 10.0;
  double fastest = 0.0;
  if (setup.drag)
    fastest = std::max(fastest, setup.drag->wind.norm() * (1.0 + std::abs(setup.drag->gust_amplitude)));
  if (setup.wind) fastest = std::max(fastest, setup.wind->max_speed());
  for (const ClothSetup& c : setup.cloths) fastest = std::max(fastest, c.initial_velocity.norm());
  for (const auto& c : cloths)
    for (const Pin& p : c->pins())
      for (size_t k = 1; k < p.times.size(); ++k)
        fastest = std::max(fastest, (p.offsets[k] - p.offsets[k - 1]).norm() / (p.times[k] - p.times[k - 1]));
  v_ref += fastest;
  double mass = 0.0;
  for (const auto& c : cloths)
    for (double mi : c->state().mass) mass += mi;
  return guard_weight_scale(setup, cloths) + 0.5 * v_ref * v_ref * mass;
}

void Simulation::set_substeps(int substeps) {
  if (substeps < 1) throw Error("", "substeps", "must be >= 1");
  setup_.substeps = substeps;
}

void Simulation::save_state(StateWriter& out) const {
  out.tag("loom-simulation-state-3");
  out.f64(t_);
  out.i64(frame_);
  out.i64(setup_.substeps);
  out.f64(budget_ref_);
  out.f64(budget_potential0_);
  out.f64(pin_work_);
  out.i64(static_cast<std::int64_t>(cloths_.size()));
  for (const auto& c : cloths_) {
    const ClothState& s = c->state();
    out.tag("cloth:" + c->name());
    out.vec3s(s.x);
    out.vec3s(s.v);
    out.vec3s(s.x_prev);
    out.vec3s(s.contact_normal);
  }
  for (const auto& stage : stages_) {
    out.tag(std::string("stage:") + stage->name());
    stage->save_state(out);
  }
  out.tag("end");
}

void Simulation::load_state(StateReader& in) {
  in.tag("loom-simulation-state-3");
  const double t = in.f64();
  const std::int64_t frame = in.i64(), substeps = in.i64();
  const double budget_ref = in.f64(), budget_potential0 = in.f64(), pin_work = in.f64();
  const std::int64_t n = in.i64();
  if (n != static_cast<std::int64_t>(cloths_.size()) || substeps < 1 || frame < 0 || !std::isfinite(t))
    throw Error(in.source(), "",
                "state archive does not match this simulation (" + std::to_string(n) +
                    " cloths, this scene has " + std::to_string(cloths_.size()) + ")");
  for (auto& c : cloths_) {
    in.tag("cloth:" + c->name());
    ClothState& s = c->state();
    Vec3s x = in.vec3s(), v = in.vec3s(), xp = in.vec3s(), cn = in.vec3s();
    if (static_cast<int>(x.size()) != s.size() || v.size() != x.size() || xp.size() != x.size())
      throw Error(in.source(), "cloth " + c->name(),
                  "state archive has " + std::to_string(x.size()) + " vertices, this scene's cloth has " +
                      std::to_string(s.size()));
    if (!cn.empty() && cn.size() != x.size())
      throw Error(in.source(), "cloth " + c->name(),
                  "state archive has " + std::to_string(cn.size()) + " contact normals for " +
                      std::to_string(x.size()) + " vertices");
    s.x = std::move(x);
    s.v = std::move(v);
    s.x_prev = std::move(xp);
    s.contact_normal = std::move(cn);
  }
  for (auto& stage : stages_) {
    in.tag(std::string("stage:") + stage->name());
    stage->load_state(in);
  }
  in.tag("end");
  t_ = t;
  frame_ = static_cast<int>(frame);
  setup_.substeps = static_cast<int>(substeps);
  budget_ref_ = budget_ref;
  budget_potential0_ = budget_potential0;
  pin_work_ = pin_work;
  start_sample_.reset();  // measured again from the restored state at the next frame
}

}  // namespace loom::cloth
