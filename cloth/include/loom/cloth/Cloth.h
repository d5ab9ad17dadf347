#pragma once
// Cloth: one cloth instance in a simulation — shared mesh, material, state, terms and pins.
#include <memory>
#include <string>
#include <vector>

#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/ClothState.h"
#include "loom/cloth/Material.h"
#include "loom/cloth/Pins.h"
#include "loom/cloth/Term.h"

namespace loom::cloth {

// Wall time and work of one term, summed since the start of the run.
struct TermTiming {
  double ms = 0.0;
  long calls = 0;
  long items = 0;
};

class Cloth {
 public:
  Cloth(std::string name, std::shared_ptr<const ClothMesh> mesh, Material material);

  const std::string& name() const { return name_; }
  const ClothMesh& mesh() const { return *mesh_; }
  const std::shared_ptr<const ClothMesh>& mesh_ptr() const { return mesh_; }
  const Material& material() const { return material_; }
  ClothState& state() { return state_; }
  const ClothState& state() const { return state_; }

  void add_term(std::unique_ptr<Term> term);
  const std::vector<std::unique_ptr<Term>>& terms() const { return terms_; }
  const Term* find_term(const std::string& name) const;

  // Pins a vertex (inverse mass 0). Throws loom::Error for an out-of-range vertex.
  void add_pin(Pin pin);
  const std::vector<Pin>& pins() const { return pins_; }

  // f = sum of all terms' forces at (x, v, t); each term's time is recorded in term_timings().
  void compute_forces(const Vec3s& x, const Vec3s& v, double t, int threads, Vec3s& f);
  // Sum of the conservative terms' energies other than gravity (J).
  double elastic_energy(int threads) const;
  const std::vector<TermTiming>& term_timings() const { return timings_; }

 private:
  std::string name_;
  std::shared_ptr<const ClothMesh> mesh_;
  Material material_;
  ClothState state_;
  std::vector<std::unique_ptr<Term>> terms_;
  std::vector<TermTiming> timings_;
  std::vector<Pin> pins_;
};

}  // namespace loom::cloth
