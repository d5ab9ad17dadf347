#pragma once
// Garments fitted to a skeleton's measurements at its pose at t = 0:
//   cape   a rectangle hanging behind the back from the shoulder line (shoulder width, shoulders to knees),
//          its whole top row attached to the chest joint (the neck's parent), placed clear of every capsule
//          over the motion;
//   skirt  a flared tube from the waist (root height, or above the thighs' capsules) to the knees, its waist
//   ring
//          attached to the root, hugging the pelvis and clear of the torso over the whole motion;
//   shirt  a loose tube (poncho) around the torso and arms, from the shoulders to the hips, its top ring
//          attached to the nearest of the chest, neck and clavicle bones;
//   obj    a mesh from an OBJ file whose `g` groups name attachments: every vertex of a group's faces is
//          attached to the group's bone (or to its nearest bone).
// Generated vertices start `clearance` outside every capsule of the rig (pushed out along the garment's
// horizontal normal). Attachment offsets are taken in the attached joint's frame at t = 0.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "loom/characters/CapsuleRig.h"
#include "loom/characters/Motion.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Error.h"

namespace loom::characters {

struct GarmentSpec {
  std::string type = "cape";  // cape | skirt | shirt | obj
  double resolution = 0.05;   // m, target edge length of generated garments
  double clearance = 0.02;    // m, start gap between generated cloth and the capsules
  double length = 0.0;        // m, 0: from the skeleton (see above)
  double width = 0.0;         // m, cape width; 0: shoulder width + 0.2 m
  double flare = 1.4;         // 1, skirt hem radius over waist radius (before pushing out of the legs)
  // obj garments
  std::string path;                           // OBJ file
  double scale = 1.0;                         // x -> scale * x + translate (as mesh.type "obj")
  Vec3 translate = Vec3::Zero();              // m
  std::map<std::string, std::string> attach;  // OBJ group -> bone (file or canonical name) or "nearest"
};

struct Garment {
  std::shared_ptr<const cloth::ClothMesh> mesh;
  std::vector<int> attached_vertices;  // mesh vertices attached to the skeleton
  std::vector<int> attached_joints;    // the joint of each attached vertex
};

// A bone the garment hangs from has no capsule because its `radii` entry is 0: where = the radii entry
// (`where`'s prefix before ".garments" + ".radii.<key>").
struct RemovedCapsule : Error {
  using Error::Error;
};

// Throws loom::Error (file = `source`, where = `where`) when the skeleton lacks a bone the garment needs,
// an OBJ group is missing, or the mesh is invalid; RemovedCapsule when the bone's capsule was removed.
// `outside`: points the garment must also clear (the vertices of garments made before it: layers).
Garment make_garment(const GarmentSpec& spec, const Motion& motion, const CapsuleRig& rig,
                     const std::string& source = "", const std::string& where = "",
                     const cloth::Vec3s& outside = {});

// Vertices of each `g` group's faces in an OBJ file (0-based, in file order of `v`).
std::map<std::string, std::vector<int>> read_obj_groups(const std::string& path);

}  // namespace loom::characters
