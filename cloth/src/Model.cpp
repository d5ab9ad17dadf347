#include "loom/cloth/Model.h"

#include <functional>

#include "loom/cloth/Error.h"
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
         c.add_term(std::make_unique<SpringTerm>(c.mesh().num_vertices(), make_springs(c.mesh(), c.material())));
       }},
  };
  return entries;
}

}  // namespace

void add_model_terms(Cloth& cloth, const std::string& model, const std::string& file, const std::string& where) {
  for (const Entry& e : registry())
    if (model == e.name) return e.add(cloth);
  std::string known;
  for (const auto& n : model_names()) known += (known.empty() ? "" : ", ") + n;
  throw Error(file, where, "unknown model '" + model + "' (known: " + known + ")");
}

std::vector<std::string> model_names() {
  std::vector<std::string> names;
  for (const Entry& e : registry()) names.push_back(e.name);
  return names;
}

}  // namespace loom::cloth
