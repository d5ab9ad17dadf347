#pragma once
// Triangle surfaces of collider shapes, for drawing them (`loom run --render`, loom-view) and for export.
// Vertices lie exactly on the analytic surface (up to rounding): a UV sphere, a capsule of two hemispheres
// joined by a tube, a cylinder with flat caps, a box with one quad per face, the convex hull's triangles
// (ColliderGeometry, Qhull), a mesh collider's own triangles, and a square of the plane. Triangles are wound
// counter-clockwise seen from outside (outward normals); each vertex carries the surface normal there, so
// faces meeting at an edge (box, cylinder rim, hull) have their own vertices.
#include <vector>

#include "loom/collision/Collider.h"

namespace loom::collision {

struct ColliderMesh {
  std::vector<Vec3> vertices;  // m
  std::vector<Vec3> normals;   // unit, one per vertex
  std::vector<Tri> triangles;
};

struct TessellationSettings {
  int segments = 32;             // around an axis (sphere, capsule, cylinder); rings follow from it
  double plane_half_size = 2.0;  // m, half the side of the square drawn for a plane
};

// In the collider's local frame (Collider.h conventions). A convex shape uses `geometry` (the hull) when
// given, else builds the hull; throws loom::Error for what build_collider_geometry rejects.
ColliderMesh tessellate(const Shape& shape, const ColliderGeometry* geometry = nullptr,
                        const TessellationSettings& settings = {});
// The same mesh moved to `pose` (vertices and normals).
ColliderMesh transformed(const ColliderMesh& local, const Transform& pose);

}  // namespace loom::collision
