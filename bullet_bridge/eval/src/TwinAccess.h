#pragma once
// Bridge-internal access to a BulletTwin's world and soft body (rigid bodies for `loom compare`).
#include "loom/bullet/BulletTwin.h"

class btDiscreteDynamicsWorld;
class btSoftBody;
struct btSoftBodyWorldInfo;

namespace loom::bullet {

struct TwinAccess {
  static btDiscreteDynamicsWorld* world(BulletTwin& t);
  static btSoftBody* body(BulletTwin& t);
  static btSoftBodyWorldInfo* info(BulletTwin& t);
};

}  // namespace loom::bullet
