#include "CompareCharacter.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "Terminal.h"
#include "loom/bullet/CharacterCompare.h"
#include "loom/characters/Character.h"
#include "loom/cloth/OutputFile.h"
#include "loom/eval/CsvNumber.h"
#include "loom/scene/ScenePipeline.h"
#include "loom/scene/SceneRegime.h"

namespace loom::app {

// The character's capsules (one kinematic body per bone, in rig order) and, for attachment joints that start
// no capsule (a root with zero-length bones), an anchor-only body following the joint.
std::vector<bullet::KinematicBody> character_bodies(const std::shared_ptr<const characters::Character>& ch) {
  using characters::Transform;
  std::vector<bullet::KinematicBody> bodies;
  const auto& bones = ch->rig.bones();
  for (size_t k = 0; k < bones.size(); ++k) {
    bullet::KinematicBody b;
    b.name = "character/" + bones[k].name;
    b.shape.type = collision::ShapeType::capsule;
    b.shape.radius = bones[k].radius;
    b.shape.half_height = bones[k].half_length;
    b.friction = ch->friction;
    b.motion = [ch, k](double t) {
      std::vector<Transform> pose, caps;
      ch->motion.pose(t, pose);
      ch->rig.capsule_poses(pose, caps);
      return caps[k];
    };
    bodies.push_back(std::move(b));
  }
  std::map<int, size_t> body_of_joint;
  for (size_t k = 0; k < bones.size(); ++k)
    body_of_joint.emplace(bones[k].joint, k);  // first bone of a joint
  for (const characters::Attachment& a : ch->attachments) {
    auto it = body_of_joint.find(a.joint);
    if (it == body_of_joint.end()) {
      bullet::KinematicBody b;
      b.name = "joint/" + ch->motion.joints()[a.joint].name;
      b.collides = false;
      const int j = a.joint;
      b.motion = [ch, j](double t) {
        std::vector<Transform> pose;
        ch->motion.pose(t, pose);
        return pose[j];
      };
      bodies.push_back(std::move(b));
      it = body_of_joint.emplace(a.joint, bodies.size() - 1).first;
    }
    bodies[it->second].attachments.push_back({a.cloth, a.vertex});
  }
  return bodies;
}

namespace {

nlohmann::json to_json(const bullet::CharacterMetrics& r) {
  nlohmann::json j;
  j["available"] = true;
  j["ms_per_frame"] = r.m.ms_per_frame;
  j["max_strain"] = r.m.max_strain;
  j["mean_strain"] = r.m.mean_strain;
  j["max_penetration"] = r.m.max_penetration;
  j["diverged"] = r.m.diverged;
  if (!r.m.diverged_why.empty()) j["diverged_why"] = r.m.diverged_why;
  j["penetrating_vertices"] = r.penetrating_vertices;
  j["max_attachment_error"] = r.max_attachment_error;
  return j;
}

}  // namespace

int compare_character(const scene::Scene& sc, int frames, eval::OutputFolder& folder) {
  const std::string out = folder.dir().string();
  bullet::CharacterCompareInput in;
  in.setup = sc.setup;
  in.bodies = character_bodies(sc.character);
  in.frames = frames > 0 ? frames : sc.frames;
  in.thickness = sc.character->thickness > 0.0
                     ? sc.character->thickness
                     : (sc.setup.cloths.empty() ? 0.001 : sc.setup.cloths[0].material.thickness);
  auto pipeline = scene::build_pipeline(sc);
  cloth::Simulation* sim = &pipeline->simulation();
  const bullet::CharacterMetrics loom = [&] {
    bullet::CharacterMetrics r = bullet::run_loom_character(*sim, in);
    if (!r.m.diverged_why.empty()) r.m.diverged_why += scene::divergence_suspects(sc);
    return r;
  }();
  const bullet::CharacterMetrics classic = bullet::run_bullet_character(in);
  const std::string deformable_note =
      "the deformable world is not run on characters (docs/bullet.md: NaN nodes against rigid bodies)";

  nlohmann::json j;
  j["scene"] = sc.name;
  j["frames"] = in.frames;
  j["frame_dt"] = sc.setup.frame_dt;
  j["bullet_substeps"] = in.bullet_substeps;
  j["bodies"] = 0;
  j["character_capsules"] = sc.character->rig.bones().size();
  j["garments"] = sc.setup.cloths.size();
  j["loom"] = to_json(loom);
  j["bullet_classic"] = to_json(classic);
  j["bullet_deformable"] = {{"available", false},    {"note", deformable_note}, {"ms_per_frame", nullptr},
                            {"max_strain", nullptr}, {"mean_strain", nullptr},  {"max_penetration", nullptr},
                            {"diverged", nullptr}};
  OutputFile(folder.claim("compare.json")) << j.dump(2) << "\n";
  OutputFile csv(folder.claim("compare.csv"));
  csv << "system,available,ms_per_frame,max_strain,mean_strain,max_penetration,diverged\n";
  for (const bullet::CharacterMetrics* r : {&loom, &classic}) {
    csv << r->m.system << ",1," << eval::csv_number(r->m.ms_per_frame) << ','
        << eval::csv_number(r->m.max_strain, 9) << ',' << eval::csv_number(r->m.mean_strain, 9) << ','
        << eval::csv_number(r->m.max_penetration, 9) << ',' << (r->m.diverged ? 1 : 0) << "\n";
  }
  csv << "bullet_deformable,0,,,,,\n";
  std::printf("%-18s %12s %12s %12s %16s %9s %12s %12s\n", "system", "ms/frame", "max_strain", "mean_strain",
              "max_penetration", "diverged", "inside_verts", "attach_err");
  for (const bullet::CharacterMetrics* r : {&loom, &classic})
    std::printf("%-18s %12.3f %12.5f %12.6f %16.6f %9s %12ld %12.6f\n", r->m.system.c_str(),
                r->m.ms_per_frame, r->m.max_strain, r->m.mean_strain, r->m.max_penetration,
                r->m.diverged ? "yes" : "no", r->penetrating_vertices, r->max_attachment_error);
  for (const bullet::CharacterMetrics* r : {&loom, &classic})
    if (!r->m.diverged_why.empty())
      std::printf("%-18s diverged: %s\n", r->m.system.c_str(), printable(r->m.diverged_why).c_str());
  std::printf("%-18s not run: %s\n", "bullet_deformable", deformable_note.c_str());
  const std::string shown = printable(out);  // the user's path, control characters as \xNN
  std::printf("wrote %s/compare.csv and %s/compare.json\n", shown.c_str(), shown.c_str());
  return 0;
}

}  // namespace loom::app
