#pragma once
// Small helpers shared by the cloth tests.
#include <memory>
#include <random>

#include "loom/cloth/Cloth.h"
#include "loom/cloth/ClothMesh.h"

namespace loom::test {

using cloth::Vec3;
using cloth::Vec3s;

// A cloth with three vertices (one triangle) whose masses and terms a test sets itself.
inline std::unique_ptr<cloth::Cloth> triangle_cloth() {
  auto mesh = cloth::ClothMesh::from_triangles({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}, {{0, 1, 2}}, {}, "test");
  return std::make_unique<cloth::Cloth>("test", mesh, cloth::Material());
}

inline Vec3s perturbed(const Vec3s& x, double amount, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-amount, amount);
  Vec3s out = x;
  for (Vec3& p : out) p += Vec3(u(rng), u(rng), u(rng));
  return out;
}

}  // namespace loom::test
