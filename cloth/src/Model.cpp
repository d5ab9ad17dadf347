#include "loom/cloth/Model.h"

#include <functional>

#include "loom/cloth/BaraffWitkinTerm.h"
#include "loom/cloth/ChoiKoTerm.h"
#include "loom/cloth/CorotatedFemTerm.h"
#include "loom/cloth/DihedralBendingTerm.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/SpringSet.h"
#include "loom/cloth/SpringTerm.h"

namespace loom::cloth {

namespace {

struct Entry {
  const char* name;
  std::function<void(Cloth&)> add;
};

const std::vector<Entry>& registry() {
  static const std::vector<Entry> entries = {
      {"springs",
       [](Cloth& c) {
         c.add_term(
             std::make_unique<SpringTerm>(c.mesh().num_vertices(), make_springs(c.mesh(), c.material())));
       }},
      // Choi & Ko 2002: tension-only sequential springs + interlaced buckling springs (ChoiKoTerm.h).
      {"choi_ko", [](Cloth& c) { c.add_term(make_choi_ko_term(c.mesh(), c.material())); }},
      // Baraff & Witkin 1998 triangle stretch + shear, dihedral-angle bending (BaraffWitkinTerm.h,
      // DihedralBendingTerm.h).
      {"baraff_witkin",
       [](Cloth& c) {
         c.add_term(make_bw_stretch_term(c.mesh(), c.material()));
         c.add_term(make_bw_shear_term(c.mesh(), c.material()));
         c.add_term(make_dihedral_bending_term(c.mesh(), c.material()));
       }},
      // Co-rotated linear FEM membrane (orthotropic, warp/weft), dihedral-angle bending (CorotatedFemTerm.h).
      {"corotated_fem",
       [](Cloth& c) {
         c.add_term(make_corotated_fem_term(c.mesh(), c.material()));
         c.add_term(make_dihedral_bending_term(c.mesh(), c.material()));
       }},
  };
  return entries;
}

}  // namespace

void add_model_terms(Cloth& cloth, const std::string& model, const std::string& file,
                     const std::string& where) {
  for (const Entry& e : registry())
    if (model == e.name) return e.add(cloth);
  std::string known;
  for (const auto& n : model_names()) known += (known.empty() ? "" : ", ") + n;
  throw Error(file, where, "unknown model '" + show_value(model) + "' (known: " + known + ")");
}

std::vector<std::string> model_names() {
  std::vector<std::string> names;
  for (const Entry& e : registry()) names.push_back(e.name);
  return names;
}

}  // namespace loom::cloth
