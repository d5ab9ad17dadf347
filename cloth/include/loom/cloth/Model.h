#pragma once
// Models: which elastic terms a cloth gets (`cloths[i].model` in a scene). "springs" is the mass-spring
// model of the foundation; later models (Baraff-Witkin, Choi-Ko, ...) register in Model.cpp.
#include <string>
#include <vector>

#include "loom/cloth/Cloth.h"

namespace loom::cloth {

// Adds the model's elastic terms to the cloth. Throws loom::Error(file, where, ...) for an unknown model.
void add_model_terms(Cloth& cloth, const std::string& model, const std::string& file,
                     const std::string& where);
std::vector<std::string> model_names();

}  // namespace loom::cloth
