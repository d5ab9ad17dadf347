#include "CompareCommand.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "CliValue.h"
#include "loom/bullet/Compare.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/OutputFile.h"
#include "loom/eval/CsvNumber.h"
#include "loom/eval/OutputFolder.h"
#include "loom/scene/Scene.h"
#include "loom/scene/ScenePipeline.h"
#include "loom/scene/SceneRegime.h"

#ifdef LOOM_HAVE_CHARACTER_COMPARE
#include "CompareCharacter.h"
#endif

namespace loom::app {

namespace {

const char* kCompareUsage =
    "Usage: loom compare SCENE [--out DIR] [--overwrite] [--set path=value]... [--frames N]\n"
    "  Runs SCENE's first cloth (and its `bodies`) in Loom (BulletCloth in a Bullet world), in Bullet's\n"
    "  classic soft body and, without rigid bodies, in Bullet's deformable world. Writes DIR/compare.csv "
    "and\n"
    "  DIR/compare.json (default DIR: out/compare). Metrics: ms_per_frame, max_strain, mean_strain,\n"
    "  max_penetration, diverged. Everything but ms_per_frame is deterministic run to run.\n"
    "  Loom runs the scene's `quality`: in a Bullet world \"realtime\" and \"balanced\" are the bridge's\n"
    "  coupled tier, \"reference\" (no key) its setup tier with the scene's solver (compare.json: "
    "loom_tier).\n"
    "  A scene with a `character` runs its garments in Loom (the scene's own pipeline) and as Bullet "
    "classic\n"
    "  soft bodies anchored to the character's capsules, kinematic rigid bodies driven by the clip.\n"
    "  DIR is owned as `loom run` owns its folder (DIR/.loom-manifest): a non-empty folder Loom did not\n"
    "  write is refused unless --overwrite is given.\n";

nlohmann::json to_json(const bullet::SystemMetrics& m) {
  nlohmann::json j;
  j["available"] = m.available;
  if (!m.note.empty()) j["note"] = m.note;
  if (!m.diverged_why.empty()) j["diverged_why"] = m.diverged_why;
  if (m.available) {
    j["ms_per_frame"] = m.ms_per_frame;
    j["max_strain"] = m.max_strain;
    j["mean_strain"] = m.mean_strain;
    j["max_penetration"] = m.max_penetration;
    j["diverged"] = m.diverged;
  } else {
    for (const char* k : {"ms_per_frame", "max_strain", "mean_strain", "max_penetration", "diverged"})
      j[k] = nullptr;
  }
  return j;
}

}  // namespace

int compare_main(int argc, char** argv) {
  std::string scene_path, out = "out/compare";
  std::vector<std::string> sets;
  int frames = -1;
  bool overwrite = false, out_given = false;
  CliArgs args(argc, argv, 2, "compare");
  while (args.next()) {
    const std::string a = args.arg();
    if (args.operand()) {
      if (!scene_path.empty()) {
        std::fprintf(stderr, "loom: error: compare: one scene only (given '%s', '%s')\n",
                     printable(scene_path).c_str(), printable(a).c_str());
        return 2;
      }
      scene_path = cli_path("SCENE", a);
    } else if (a == "-h" || a == "--help") {
      std::cout << kCompareUsage;
      return 0;
    } else if (a == "--out") {
      out = cli_path(a, args.value());
      out_given = true;
    } else if (a == "--overwrite") {
      overwrite = true;
    } else if (a == "--set") {
      sets.push_back(args.value());
    } else if (a == "--frames") {
      frames = static_cast<int>(cli_integer(a, args.value(), 1, 10000000));
    } else {
      args.unknown();
    }
  }
  if (scene_path.empty()) {
    std::fprintf(stderr, "loom compare: error: no scene given\n%s", kCompareUsage);
    return 2;
  }
  const scene::Scene sc = scene::load_scene(scene_path, sets);
  // A character's garments in a Bullet world have no twin: the character comparison has no rigid bodies.
  if (sc.character && !sc.bodies.empty())
    throw Error(sc.file, "bodies",
                "loom compare runs a character scene without rigid bodies (remove 'bodies')");
  // What the Bullet twins cannot run is refused by field before the folder is claimed: scene colliders
  // (the three systems run in a Bullet world, whose shapes are `bodies`: with colliders ignored every row
  // would be a free fall), and moving pins (they bridge fixed pins only; a pin with a `path` moves).
  if (!sc.colliders.empty())
    throw Error(sc.file, "colliders",
                sc.character
                    ? std::string("loom compare's Bullet twin of a character carries its capsules only; "
                                  "it does not see scene colliders (compare the character without "
                                  "them, or loom run this one)")
                    : std::string("loom compare runs the cloth in a Bullet world, where the shapes are "
                                  "`bodies` (mass 0 for a static or kinematic one); its systems do not "
                                  "see scene colliders (compare a scene with bodies, or loom run this "
                                  "one)"));
  // A character scene's twin runs its garments only: a cloth of `cloths` beside them is refused.
  if (sc.character)
    for (size_t c = 0; c < sc.setup.cloths.size(); ++c)
      if (sc.cloth_field(static_cast<int>(c)).rfind("character.garments", 0) != 0)
        throw Error(sc.file, sc.cloth_field(static_cast<int>(c)),
                    "loom compare's Bullet twin of a character runs its garments only; compare the character "
                    "without other cloths (or loom run this one)");
  if (!sc.character)
    for (size_t c = 0; c < sc.setup.cloths.size(); ++c) {
      const cloth::ClothSetup& cs = sc.setup.cloths[c];
      for (size_t k = 0; k < cs.pins.size(); ++k)
        if (!cs.pins[k].times.empty())
          throw Error(sc.file,
                      (k < cs.pin_fields.size()
                           ? cs.pin_fields[k]
                           : "cloths[" + std::to_string(c) + "].pins[" + std::to_string(k) + "]") +
                          ".path",
                      "moves vertex " + std::to_string(cs.pins[k].vertex) +
                          ": loom compare's Bullet twins hold fixed pins only; compare a scene without pin "
                          "paths");
    }
  // The twins carry the cloth's mesh, springs, masses, damping, fixed pins and gravity (docs/bullet.md,
  // "Twins"): a scene value that changes the problem beyond those would make the rows compare different
  // problems, so it is refused by field. Loom's own solver settings (solver, substeps, constraints,
  // quality) are the loom row's and stay.
  auto refuse = [&](const std::string& field, const std::string& what) {
    throw Error(sc.file, field,
                what +
                    ": loom compare's Bullet twins cannot carry it, so the rows would compare different "
                    "problems; compare a scene without it (or loom run this one)");
  };
  if (sc.setup.drag) refuse("effects.drag", "is set");
  if (sc.setup.wind) refuse("effects.wind", "is set");
  for (size_t c = 0; c < sc.setup.cloths.size(); ++c) {
    const cloth::ClothSetup& cs = sc.setup.cloths[c];
    const std::string at = "cloths[" + std::to_string(c) + "]";
    if (cs.model != "springs")
      refuse(sc.character ? "character.garments[" + std::to_string(c) + "].model" : at + ".model",
             "is '" + cs.model + "' (the twins' links are Loom's springs)");
    if (cs.pressure) refuse(at + ".pressure", "is set");
    if (!sc.character && cs.initial_velocity != cloth::Vec3::Zero()) refuse(at + ".velocity", "is not zero");
  }
  // Self-collision: the twins run without it (the deformable twin sets it off, the classic one has none).
  // A character scene keeps it in the loom row: the garments' collision is part of the character pipeline
  // its comparison measures (docs/cli.md).
  if (!sc.character && sc.collision) refuse("collision", "is set (self-collision)");
  if (!sc.character && sc.setup.cloths.size() > 1)
    refuse("cloths",
           "has " + std::to_string(sc.setup.cloths.size()) + " cloths (the twins run the first one)");
  // The folder is checked (and claimed) before the runs, so a refused folder costs nothing.
  if (!out_given) eval::refuse_linked_default(out, "--out");
  // The scene and every file it read: one that is a file compare writes (or an earlier run listed) is
  // refused, --overwrite or not.
  std::vector<std::string> inputs = {scene_path};
  inputs.insert(inputs.end(), sc.inputs.begin(), sc.inputs.end());
  eval::OutputFolder folder(out, "--out", overwrite, false, {"compare.json", "compare.csv"}, inputs);
#ifdef LOOM_HAVE_CHARACTER_COMPARE
  if (sc.character) return compare_character(sc, frames, folder);  // Character scenes
#endif
  bullet::CompareInput in;
  in.setup = sc.setup;
  in.bodies = sc.bodies;
  in.frames = frames > 0 ? frames : sc.frames;
  in.options = scene::bullet_scene_options(sc);
  std::vector<bullet::SystemMetrics> results;
  results.push_back(bullet::run_loom_in_bullet(in));
  if (!results[0].diverged_why.empty()) results[0].diverged_why += scene::divergence_suspects(sc);
  results.push_back(bullet::run_bullet_twin(in, bullet::TwinKind::kClassic));
  results.push_back(bullet::run_bullet_twin(in, bullet::TwinKind::kDeformable));

  nlohmann::json j;
  j["scene"] = sc.name;
  j["frames"] = in.frames;
  j["frame_dt"] = sc.setup.frame_dt;
  j["bullet_substeps"] = in.bullet_substeps;
  j["bodies"] = sc.bodies.size();
  j["quality"] = sc.quality.name;
  j["loom_tier"] = results[0].tier;  // the bridge's tier Loom ran: "coupled" or "setup"
  for (const auto& m : results) j[m.system] = to_json(m);
  OutputFile(folder.claim("compare.json")) << j.dump(2) << "\n";
  OutputFile csv(folder.claim("compare.csv"));
  csv << "system,available,ms_per_frame,max_strain,mean_strain,max_penetration,diverged\n";
  for (const auto& m : results) {
    if (m.available)
      csv << m.system << ",1," << eval::csv_number(m.ms_per_frame) << ',' << eval::csv_number(m.max_strain, 9)
          << ',' << eval::csv_number(m.mean_strain, 9) << ',' << eval::csv_number(m.max_penetration, 9) << ','
          << (m.diverged ? 1 : 0) << "\n";
    else
      csv << m.system << ",0,,,,,\n";
  }
  std::printf("loom: quality %s, the bridge's %s tier\n", sc.quality.name.c_str(), results[0].tier.c_str());
  std::printf("%-18s %12s %12s %12s %16s %9s\n", "system", "ms/frame", "max_strain", "mean_strain",
              "max_penetration", "diverged");
  for (const auto& m : results) {
    if (!m.available) {
      std::printf("%-18s not run: %s\n", m.system.c_str(), m.note.c_str());
      continue;
    }
    std::printf("%-18s %12.3f %12.5f %12.6f %16.6f %9s\n", m.system.c_str(), m.ms_per_frame, m.max_strain,
                m.mean_strain, m.max_penetration, m.diverged ? "yes" : "no");
    if (!m.diverged_why.empty()) std::printf("%-18s diverged: %s\n", "", printable(m.diverged_why).c_str());
  }
  const std::string shown = printable(out);  // the user's path, control characters as \xNN
  std::printf("wrote %s/compare.csv and %s/compare.json\n", shown.c_str(), shown.c_str());
  return 0;
}

}  // namespace loom::app
