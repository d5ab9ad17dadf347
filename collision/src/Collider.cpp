#include "loom/collision/Collider.h"

namespace loom::collision {

const char* shape_type_name(ShapeType type) {
  switch (type) {
    case ShapeType::plane:
      return "plane";
    case ShapeType::sphere:
      return "sphere";
    case ShapeType::capsule:
      return "capsule";
    case ShapeType::box:
      return "box";
    case ShapeType::cylinder:
      return "cylinder";
    case ShapeType::convex:
      return "convex";
    case ShapeType::mesh:
      return "mesh";
  }
  return "unknown";
}

}  // namespace loom::collision
