#include "loom/cloth/Cloth.h"

#include <chrono>
#include <cstring>

#include "loom/cloth/Error.h"

namespace loom::cloth {

Cloth::Cloth(std::string name, std::shared_ptr<const ClothMesh> mesh, Material material)
    : name_(std::move(name)), mesh_(std::move(mesh)), material_(std::move(material)) {
  const int n = mesh_->num_vertices();
  state_.x = mesh_->rest_positions();
  state_.x_prev = state_.x;
  state_.v.assign(n, Vec3::Zero());
  state_.mass.resize(n);
  state_.inv_mass.resize(n);
  for (int i = 0; i < n; ++i) {
    state_.mass[i] = material_.areal_density * mesh_->vertex_areas()[i];
    state_.inv_mass[i] = 1.0 / state_.mass[i];
  }
}

void Cloth::add_term(std::unique_ptr<Term> term) {
  terms_.push_back(std::move(term));
  timings_.emplace_back();
}

const Term* Cloth::find_term(const std::string& name) const {
  for (const auto& t : terms_)
    if (name == t->name()) return t.get();
  return nullptr;
}

void Cloth::add_pin(Pin pin) {
  if (pin.vertex < 0 || pin.vertex >= state_.size())
    throw Error("", "pins",
                "vertex " + std::to_string(pin.vertex) + " is out of range [0, " +
                    std::to_string(state_.size()) + ")");
  state_.inv_mass[pin.vertex] = 0.0;
  pins_.push_back(std::move(pin));
}

void Cloth::compute_forces(const Vec3s& x, const Vec3s& v, double t, int threads, Vec3s& f) {
  // Cleared in parallel on large meshes: a serial clear capped the explicit solvers' 2-thread speed-up.
  const int n = static_cast<int>(x.size());
  f.resize(n);
#pragma omp parallel for num_threads(threads) if (threads > 1 && n >= kParallelMinVertices) schedule(static)
  for (int i = 0; i < n; ++i) f[i].setZero();
  const EvalContext ctx{x, v, t, threads};
  for (size_t k = 0; k < terms_.size(); ++k) {
    const auto start = std::chrono::steady_clock::now();
    terms_[k]->add_forces(ctx, f);
    TermTiming& tt = timings_[k];
    tt.ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    ++tt.calls;
    tt.items += terms_[k]->work_items();
  }
}

double Cloth::elastic_energy(int threads) const {
  const EvalContext ctx{state_.x, state_.v, 0.0, threads};
  double e = 0.0;
  for (const auto& t : terms_)
    if (t->conservative() && std::strcmp(t->name(), "gravity") != 0) e += t->energy(ctx);
  return e;
}

}  // namespace loom::cloth
