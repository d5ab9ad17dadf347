#pragma once
// BodyFit: a static human body mesh (no bones) fitted and skinned to a mocap skeleton (a Motion), so the
// clip drives the body with linear blend skinning (Skin.h) and garments can be skinned to the same bones.
//
// The mesh must stand upright (y up, feet on its lowest point), face +z with its left side at +x (as a BVH
// rest pose: MakeHuman's base mesh, CMU skeletons) in an A-pose: arms apart from the torso and pointing
// down-and-out (so that horizontal sections below the armpit cut each arm apart from the torso), legs apart
// below the crotch. The fit:
//   1. scales the mesh uniformly so that its height H equals the skeleton's rest height;
//   2. finds the joints in the mesh from horizontal cross-sections (closed loops of the cut, mesh_section):
//      knee at the centroid of the leg's section at 0.285 H above the floor; ankle on the shin's axis (the
//      line through its section centroids at 0.10 H and 0.20 H) at 0.039 H; hip on the thigh's axis (the
//      line through two thigh-section centroids) at 0.530 H; the shoulder on the upper
//      arm's axis where it lies 0.259 H / 2 minus the arm's radius from the midline; elbow and wrist on the
//      arm's centre line (section centroids from the armpit to the fingertip) at arc lengths in the ratio
//      upper arm : forearm : hand = 0.186 : 0.146 : 0.108 (segment lengths as fractions of height, Drillis
//      and Contini 1966, as tabulated in Winter 2009, "Biomechanics and Motor Control of Human Movement",
//      4th ed., Fig. 4.1); the toe joint on the foot; spine, neck and head joints along the skeleton's own
//      spine, stretched vertically so its shoulders and top joint meet the mesh's;
//   3. poses the skeleton into the mesh: each limb bone (and clavicle, pelvis side, hand) turned by the
//      smallest rotation that points it at the joint found in the mesh, the skeleton's own bone lengths
//      kept; this is the bind pose;
//   4. moves the mesh onto the bind pose: every bone maps its found joint onto the bind pose's joint and
//      stretches along itself by (bind length / found length); the maps are blended with automatic weights
//      (Skin::automatic) at the found joints. The fitted mesh has the skeleton's proportions;
//   5. skins the fitted mesh with automatic weights at the bind pose (bone b = joint b).
// The clip then plays on the fitted body unchanged: pose = Motion::pose(t), one transform per joint.
#include <map>
#include <string>
#include <vector>

#include "loom/characters/CapsuleRig.h"
#include "loom/characters/Motion.h"
#include "loom/characters/SkinnedMesh.h"

namespace loom::characters {

// One closed loop of a plane's cut through a triangle mesh (the cut segments joined through shared edges).
struct SectionLoop {
  Vec3 centroid = Vec3::Zero();  // m, length-weighted mean of the loop's segments (the perimeter's centroid)
  double perimeter = 0.0;        // m, total length of the loop's segments
  Vec3 lo = Vec3::Zero();        // m, bounding box of the loop
  Vec3 hi = Vec3::Zero();
};

// Loops of the cut of mesh (x, tris) by the plane through `point` with normal `normal` (any length > 0).
// Vertices exactly on the plane count as on its positive side; vertices at the same position are one
// (meshes split vertices along UV seams).
std::vector<SectionLoop> mesh_section(const cloth::Vec3s& x, const std::vector<cloth::Tri>& tris,
                                      const Vec3& point, const Vec3& normal);

struct BodyFit {
  SkinnedMesh body;             // the fitted mesh at the bind pose, skinned: bone b = joint b of the motion
  std::vector<Transform> bind;  // global transform of every joint at the bind pose (m, world)
  cloth::Vec3s found;           // per joint: its position found in the scaled input mesh (step 2)
  std::vector<int> measured;    // joints located from the mesh's cross-sections (hips, knees, ankles,
                                // shoulders, elbows, wrists)
  double scale = 1.0;           // uniform scale applied to the input mesh (step 1)
};

// Fits `mesh` (positions and triangles; any skin is ignored) to `motion`'s skeleton. Throws loom::Error:
//   (mesh.source, "positions" / "triangles", ...) for an empty mesh or a non-finite position;
//   (motion.source(), "joints", "no joint 'LeftLeg' ...") when the skeleton lacks a joint the fit needs
//   (canonical names, CapsuleRig.h: LeftUpLeg, LeftLeg, LeftFoot, LeftArm, LeftForeArm, LeftHand and the
//   Right* twins);
//   (mesh.source, "left_leg" / "right_arm" / ..., ...) when the mesh is not in the pose described above (no
//   separate leg or arm section where one is expected, feet pointing along -z).
BodyFit fit_body(const SkinnedMesh& mesh, const Motion& motion);

// A cape over the fitted body's back at the bind pose, for GarmentInstance: a grid `width` wide (m), rows
// `spacing` apart (m) from the shoulder joints' height down to the knees', each row `gap` (m) behind the
// back-most point of the body within the cape's width at or above it (so it hangs straight past the
// buttocks), its normals pointing away from the body. Skinned with automatic weights to fit.body's bones;
// max distance 0 on the top row (skinned at the shoulders) growing linearly to `hem_max_distance` (m) at the
// hem. Throws loom::Error(source, "<argument>", ...) for a non-positive or non-finite width, spacing or gap
// and a negative or NaN hem_max_distance.
struct BackCape {
  cloth::Vec3s positions;  // m, at the bind pose (the skin's bind space)
  std::vector<cloth::Tri> triangles;
  Skin skin;
  std::vector<double> max_distance;  // m per vertex
  int columns = 0, rows = 0;         // vertex i is row i / columns, column i % columns (row 0 at the top)
};
BackCape make_back_cape(const BodyFit& fit, const Motion& motion, double width = 0.5, double spacing = 0.05,
                        double gap = 0.03, double hem_max_distance = 0.3, const std::string& source = "cape");

// Capsule radii fitted to the body (m, keyed by bone file name, for CapsuleRig::build's overrides): for each
// capsule bone, the `quantile` (0 to 1) of the distances from its segment at the bind pose to the fitted
// body's vertices nearest to it and beside it (projecting inside the segment, not onto its ends). Limb bones
// (arms, legs) take the quantile of all their vertices; the torso, neck and head, whose mocap bones run off
// the section's centre (the spine close to the back), take the smallest of the quantiles on each side of the
// bone (front, back and the two across it, each holding at least 5 vertices and 2 % of the bone's), so their
// capsules follow the back instead of bulging out of it (the chest and belly lie outside them). A bone with
// no vertex beside it keeps its table radius.
std::map<std::string, double> body_capsule_radii(const BodyFit& fit, const Motion& motion,
                                                 double quantile = 0.5);

// The body's colliders for a garment on it (GarmentInstance::set_colliders): the capsules of a CapsuleRig
// with body_capsule_radii(fit, motion), moving with the clip (CapsuleRig::clip_colliders).
collision::ColliderSetPtr body_colliders(const BodyFit& fit, const Motion& motion);

}  // namespace loom::characters
