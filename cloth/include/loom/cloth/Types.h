#pragma once
// Basic numeric types of the cloth core. `double` throughout (docs/architecture.md, "Numbers and threads").
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

namespace loom::cloth {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Vec3s = std::vector<Vec3>;
using Tri = std::array<int, 3>;

}  // namespace loom::cloth
