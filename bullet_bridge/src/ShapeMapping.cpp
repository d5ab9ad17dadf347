// Bullet shapes -> Loom colliders (BulletCloth.h, map_shape). Bullet's default shapes are Y-up; the X and Z
// variants get a rotation taking local y to their axis.
#include <btBulletDynamicsCommon.h>

#include <cmath>

#include "BulletConvert.h"
#include "loom/bullet/BulletCloth.h"

namespace loom::bullet {

using collision::Collider;
using collision::Shape;
using collision::ShapeType;
using collision::Transform;

namespace {

// Rotation taking +y to the axis `up` (0 = x, 1 = y, 2 = z).
Transform axis_frame(int up) {
  Transform t = Transform::Identity();
  if (up == 0) t.linear() = Eigen::AngleAxisd(-M_PI / 2, Vec3::UnitZ()).toRotationMatrix();
  if (up == 2) t.linear() = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()).toRotationMatrix();
  return t;
}

void add(std::vector<Collider>& out, const std::string& name, const Shape& s, const Transform& pose) {
  Collider c;
  c.name = name;
  c.shape = s;
  c.prev = c.curr = pose;
  out.push_back(std::move(c));
}

struct TriangleCollector final : btInternalTriangleIndexCallback {
  Shape* shape = nullptr;
  void internalProcessTriangleIndex(btVector3* tri, int, int) override {
    const int base = static_cast<int>(shape->vertices.size());
    for (int k = 0; k < 3; ++k) shape->vertices.push_back(to_eigen(tri[k]));
    shape->triangles.push_back({base, base + 1, base + 2});
  }
};

}  // namespace

void map_shape(const btCollisionShape* shape, const Transform& pose, const std::string& name,
               std::vector<Collider>& out, std::vector<std::string>& unsupported) {
  const std::string label = name + ":" + shape->getName();
  Shape s;
  switch (shape->getShapeType()) {
    case SPHERE_SHAPE_PROXYTYPE: {
      s.type = ShapeType::sphere;
      s.radius = static_cast<const btSphereShape*>(shape)->getRadius();
      add(out, label, s, pose);
      return;
    }
    case CAPSULE_SHAPE_PROXYTYPE: {
      const auto* c = static_cast<const btCapsuleShape*>(shape);
      s.type = ShapeType::capsule;
      s.radius = c->getRadius();
      s.half_height = c->getHalfHeight();
      add(out, label, s, pose * axis_frame(c->getUpAxis()));
      return;
    }
    case BOX_SHAPE_PROXYTYPE: {
      s.type = ShapeType::box;
      s.half_extents = to_eigen(static_cast<const btBoxShape*>(shape)->getHalfExtentsWithMargin());
      add(out, label, s, pose);
      return;
    }
    case CYLINDER_SHAPE_PROXYTYPE: {
      const auto* c = static_cast<const btCylinderShape*>(shape);
      const int up = c->getUpAxis();
      const btVector3 he = c->getHalfExtentsWithMargin();
      s.type = ShapeType::cylinder;
      s.radius = he[(up + 1) % 3];
      s.half_height = he[up];
      add(out, label, s, pose * axis_frame(up));
      return;
    }
    case CONE_SHAPE_PROXYTYPE: {
      // The cone as a convex hull: apex at +h/2 on its axis, base circle (64 points) at -h/2.
      const auto* c = static_cast<const btConeShape*>(shape);
      const double r = c->getRadius(), h = c->getHeight();
      s.type = ShapeType::convex;
      s.vertices.emplace_back(0.0, 0.5 * h, 0.0);
      for (int k = 0; k < 64; ++k) {
        const double a = 2.0 * M_PI * k / 64;
        s.vertices.emplace_back(r * std::cos(a), -0.5 * h, r * std::sin(a));
      }
      add(out, label, s, pose * axis_frame(c->getConeUpIndex()));
      return;
    }
    case STATIC_PLANE_PROXYTYPE: {
      const auto* p = static_cast<const btStaticPlaneShape*>(shape);
      const Vec3 n = to_eigen(p->getPlaneNormal()).normalized();
      Transform local = Transform::Identity();
      local.linear() = Eigen::Quaterniond::FromTwoVectors(Vec3::UnitY(), n).toRotationMatrix();
      local.translation() = n * p->getPlaneConstant();
      s.type = ShapeType::plane;
      add(out, label, s, pose * local);
      return;
    }
    case CONVEX_HULL_SHAPE_PROXYTYPE: {
      const auto* c = static_cast<const btConvexHullShape*>(shape);
      const Vec3 scale = to_eigen(c->getLocalScaling());
      s.type = ShapeType::convex;
      for (int k = 0; k < c->getNumPoints(); ++k)
        s.vertices.push_back(to_eigen(c->getUnscaledPoints()[k]).cwiseProduct(scale));
      add(out, label, s, pose);
      return;
    }
    case COMPOUND_SHAPE_PROXYTYPE: {
      const auto* c = static_cast<const btCompoundShape*>(shape);
      for (int k = 0; k < c->getNumChildShapes(); ++k)
        map_shape(c->getChildShape(k), pose * to_eigen(c->getChildTransform(k)),
                  name + "/" + std::to_string(k), out, unsupported);
      return;
    }
    case TRIANGLE_MESH_SHAPE_PROXYTYPE: {
      auto* m = const_cast<btBvhTriangleMeshShape*>(static_cast<const btBvhTriangleMeshShape*>(shape));
      s.type = ShapeType::mesh;
      TriangleCollector cb;
      cb.shape = &s;
      const btScalar big = btScalar(1e30);
      m->getMeshInterface()->InternalProcessAllTriangles(&cb, btVector3(-big, -big, -big),
                                                         btVector3(big, big, big));
      add(out, label, s, pose);
      return;
    }
    default:
      unsupported.push_back(shape->getName());
      return;
  }
}

}  // namespace loom::bullet
