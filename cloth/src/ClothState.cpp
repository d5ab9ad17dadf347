#include "loom/cloth/ClothState.h"

namespace loom::cloth {

bool ClothState::is_finite() const {
  for (size_t i = 0; i < x.size(); ++i)
    if (!x[i].allFinite() || !v[i].allFinite()) return false;
  return true;
}

}  // namespace loom::cloth
