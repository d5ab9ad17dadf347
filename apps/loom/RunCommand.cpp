#include "RunCommand.h"

#include "DetailView.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "Checkpoint.h"
#include "loom/cloth/Error.h"
#include "loom/export/Exporters.h"
#ifdef LOOM_HAVE_RENDER
#include "loom/render/RenderRun.h"
#endif
#ifdef LOOM_HAVE_BULLET
#include "loom/bullet/BulletScene.h"
#endif
#include "loom/collision/MultiClothCensus.h"
#include "loom/collision/SelfCollisionStage.h"
#include "loom/scene/Build.h"
#include "loom/scene/Scene.h"

namespace fs = std::filesystem;

namespace loom::app {

namespace {

// The default scene (issue 6): a mocap character in a skirt and a cape; builds without loom::characters
// fall back to the hanging cloth.
#ifdef LOOM_HAVE_CHARACTERS
constexpr const char* kDefaultScene = "character_layers.json";
#else
constexpr const char* kDefaultScene = "hanging_cloth.json";
#endif

// Ctrl-C (SIGINT): the run stops at the next frame boundary, writes a checkpoint and valid outputs (issue 8).
volatile std::sig_atomic_t g_interrupted = 0;
extern "C" void on_sigint(int) { g_interrupted = 1; }

void write_obj(const fs::path& path, const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  std::ofstream out(path);
  if (!out) throw Error(path.string(), "", "cannot write frame");
  out << std::setprecision(9);
  int base = 1;
  for (const auto& c : cloths) {
    out << "o " << c->name() << "\n";
    for (const cloth::Vec3& p : c->state().x) out << "v " << p.x() << ' ' << p.y() << ' ' << p.z() << "\n";
    for (const cloth::Tri& t : c->mesh().triangles())
      out << "f " << t[0] + base << ' ' << t[1] + base << ' ' << t[2] + base << "\n";
    base += c->state().size();
  }
  if (!out) throw Error(path.string(), "", "write failed");
}

// Writes `text` to `path` through a temporary file and a rename, so a reader never sees half a file.
void write_atomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp);
    out << text;
    if (!out) throw Error(path.string(), "", "write failed");
  }
  fs::rename(tmp, path);
}

class ProgressBar {
 public:
  explicit ProgressBar(int total) : total_(total), enabled_(isatty(STDERR_FILENO)) {}
  void update(int done, double ms_per_frame) {
    if (!enabled_) return;
    const int width = 30, filled = total_ ? done * width / total_ : width;
    std::fprintf(stderr, "\r[%s%s] %3d%% frame %d/%d  %.2f ms/frame", std::string(filled, '#').c_str(),
                 std::string(width - filled, ' ').c_str(), total_ ? 100 * done / total_ : 100, done, total_, ms_per_frame);
    std::fflush(stderr);
  }
  void finish() {
    if (enabled_) std::fprintf(stderr, "\n");
  }

 private:
  int total_;
  bool enabled_;
};

void print_profile(const cloth::Simulation& sim, int frames) {
  std::printf("%-22s %12s %12s  %s\n", "stage", "total ms", "ms/frame", "counters");
  for (const cloth::StageProfile& p : sim.profile()) {
    std::string counters;
    for (const auto& [k, v] : p.counters) {
      std::ostringstream s;
      s << k << '=' << v;
      counters += (counters.empty() ? "" : " ") + s.str();
    }
    const bool sub = p.name.find('/') != std::string::npos;
    std::printf("%-22s %12.3f %12.4f  %s\n", ((sub ? "  " : "") + p.name).c_str(), p.total_ms,
                frames ? p.total_ms / frames : 0.0, counters.c_str());
  }
}

}  // namespace

std::string default_scene_path() {
  if (const char* env = std::getenv("LOOM_SCENES")) return (fs::path(env) / kDefaultScene).string();
  if (fs::exists(fs::path("scenes") / kDefaultScene)) return (fs::path("scenes") / kDefaultScene).string();
  return (fs::path(LOOM_SOURCE_DIR) / "scenes" / kDefaultScene).string();
}

int run_command(const RunOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  RunOptions o = options;
  std::optional<Checkpoint> resume;  // --resume DIR: the run's options and state come from DIR/checkpoint
  if (!o.resume.empty()) {
    resume = read_checkpoint(o.resume);
    o.scene = resume->scene;
    o.sets = resume->sets;
    o.out = o.resume;
    o.render = resume->render;
    if (o.frames < 0) o.frames = resume->frames_total;
    if (o.threads < 0) o.threads = resume->threads;
    if (o.checkpoint_every <= 0) o.checkpoint_every = resume->checkpoint_every;
    if (read_text_file(o.scene) != resume->scene_text)
      throw Error(o.scene, "--resume", "the scene file changed since the checkpoint was written");
  }
  const std::string scene_path = o.scene.empty() ? default_scene_path() : o.scene;
  scene::Scene sc = scene::load_scene(scene_path, o.sets);
  if (o.threads > 0) sc.setup.threads = o.threads;
  // Issue 8: the guard's intersection check is on by default for a scene with cloth-cloth or self-collision
  // (measured: 7-8 % of the step time on character_layers, 1.3 % on layer_stack; README "Reliability"), unless the
  // scene sets `guard.intersections` itself.
  // The real-time tiers' proximity collision samples its checks instead (`--census`).
  if (!sc.setup.guard.intersections_set && sc.collision && !sc.proximity &&
      (sc.collision->self || sc.setup.cloths.size() > 1))
    sc.setup.guard.intersections = true;
  const int frames = o.frames >= 0 ? o.frames : sc.frames;
  collision::ColliderSetPtr census_colliders;  // --census: the simulation's colliders, for max_penetration
  // A scene with rigid `bodies` (issue 9) runs in a Bullet world, its cloths as one BulletCloth; the
  // colliders drawn and censused are then the bodies at their poses.
  std::unique_ptr<cloth::Simulation> sim_ptr;
#ifdef LOOM_HAVE_BULLET
  std::unique_ptr<bullet::BulletScene> bodies_world;
#endif
  if (!sc.bodies.empty()) {
#ifdef LOOM_HAVE_BULLET
    if (!sc.colliders.empty())
      throw Error(scene_path, "colliders", "cannot be combined with 'bodies' yet: give static shapes as bodies (mass 0)");
    if (sc.character) throw Error(scene_path, "character", "cannot be combined with 'bodies' yet");
    if (resume || o.checkpoint_every > 0)
      throw Error(scene_path, "bodies", "--checkpoint-every / --resume do not save the Bullet world: not available for scenes with rigid bodies");
    bodies_world = std::make_unique<bullet::BulletScene>(sc.setup, sc.bodies);
    if (sc.collision && (sc.collision->self || sc.setup.cloths.size() > 1))
      bodies_world->simulation().add_stage(std::make_unique<collision::SelfCollisionStage>(*sc.collision));
    census_colliders = bodies_world->body_colliders();
#else
    throw Error(scene_path, "bodies", "rigid bodies need the Bullet bridge, and this loom was built without it (Debian: libbullet-dev)");
#endif
  } else {
    sim_ptr = scene::build_simulation(sc, &census_colliders);  // validates before any output
  }
#ifdef LOOM_HAVE_BULLET
  cloth::Simulation& sim = bodies_world ? bodies_world->simulation() : *sim_ptr;
  auto step_frame = [&]() { return bodies_world ? bodies_world->step_frame() : sim.step_frame(); };
#else
  cloth::Simulation& sim = *sim_ptr;
  auto step_frame = [&]() { return sim.step_frame(); };
#endif
  // --census (issue 5): exact count of intersecting triangle pairs (self, non-adjacent, and between cloths)
  // and the deepest vertex inside a collider, after every frame; summary.json gets the largest of each.
  long census_intersections = 0;
  double census_penetration = 0.0;
  auto run_census = [&] {
    if (!o.census) return;
    std::vector<collision::CensusInput> in;
    for (const auto& c : sim.cloths()) in.push_back({&c->mesh(), &c->state().x});
    census_intersections = std::max(census_intersections, collision::count_all_intersections(in, sc.setup.threads));
    if (census_colliders) census_penetration = std::max(census_penetration, collision::max_penetration(in, *census_colliders));
  };

  // Output folder: our files from an earlier run are removed first, so nothing stale passes for new.
  const fs::path out = o.out.empty() ? fs::path("out") / sc.name : fs::path(o.out);
  std::error_code ec;
  fs::create_directories(out / "frames", ec);
  if (ec || !fs::is_directory(out / "frames")) throw Error(out.string(), "--out", "cannot create output folder: " + ec.message());
  {
    const fs::path probe = out / ".loom_write_test";
    std::ofstream test(probe);
    if (!test) throw Error(out.string(), "--out", "output folder is not writable");
    test.close();
    fs::remove(probe);
  }
  fs::remove(out / "summary.json");
  // On --resume, the stats rows and OBJ frames up to the checkpoint's frame are kept, later ones dropped.
  const int first = resume ? resume->frame : 0;
  std::string kept_rows = resume ? kept_stats_rows(out, first) : "";
  fs::remove(out / "stats.csv");
  for (const auto& entry : fs::directory_iterator(out / "frames"))
    if (entry.path().extension() == ".obj" && entry.path().filename().string().rfind("frame_", 0) == 0 &&
        (!resume || std::atoi(entry.path().filename().string().c_str() + 6) > first))
      fs::remove(entry.path());
  if (!resume) fs::remove_all(out / "checkpoint");

  const std::vector<std::string> stage_names = sim.stage_names();
  const fs::path stats_partial = out / "stats.csv.partial";
  std::ofstream csv(stats_partial);
  if (!csv) throw Error(stats_partial.string(), "", "cannot write");
  csv << std::setprecision(10);
  csv << "frame,time,kinetic_energy,potential_energy,elastic_energy,max_strain,mean_strain,ms_total";
  for (const auto& n : stage_names) csv << ",ms_" << n;
  csv << "\n";
  csv << kept_rows;
  auto write_row = [&](const cloth::FrameStats& s) {
    csv << s.frame << ',' << s.time << ',' << s.kinetic << ',' << s.potential << ',' << s.elastic << ','
        << s.max_strain << ',' << s.mean_strain << ',' << s.total_ms;
    for (double ms : s.stage_ms) csv << ',' << ms;
    csv << "\n";
  };
  // Scenes with bodies: DIR/bodies.csv, one row per body per frame (centre of mass, velocity).
  std::ofstream bodies_csv;
  auto write_bodies = [&](int f) {
#ifdef LOOM_HAVE_BULLET
    if (!bodies_world) return;
    if (!bodies_csv.is_open()) {
      bodies_csv.open(out / "bodies.csv");
      if (!bodies_csv) throw Error((out / "bodies.csv").string(), "", "cannot write");
      bodies_csv << std::setprecision(10) << "frame,time,body,x,y,z,vx,vy,vz\n";
    }
    for (size_t k = 0; k < bodies_world->num_bodies(); ++k) {
      const cloth::Vec3 p = bodies_world->body_position(k), v = bodies_world->body_velocity(k);
      bodies_csv << f << ',' << f * sc.setup.frame_dt << ',' << sc.bodies[k].name << ',' << p.x() << ',' << p.y() << ','
                 << p.z() << ',' << v.x() << ',' << v.y() << ',' << v.z() << "\n";
    }
#else
    (void)f;
#endif
  };
  fs::remove(out / "bodies.csv");
  auto frame_path = [&](int f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", f);
    return out / "frames" / name;
  };

  // Hybrid detail (issue 10): cloths with `detail` are written and rendered as their curved-face surface.
  DetailView shown(sc, sim);
  // output.formats: "obj" below (with output.frames), "pc2" and "gltf" through loom::export.
  const bool obj = sc.output.frames && std::find(sc.output.formats.begin(), sc.output.formats.end(), "obj") != sc.output.formats.end();
  exporter::Exporters exports(out.string(), sc.output.formats, shown.cloths(), sc.output.every);
#ifdef LOOM_HAVE_RENDER
  std::unique_ptr<render::Recording> recording;  // --render: positions kept, rendered after the run
  if (o.render) recording = std::make_unique<render::Recording>(shown.cloths(), census_colliders);
#else
  if (o.render) throw Error("", "--render", "this loom was built without the offscreen renderer (Debian: libosmesa6-dev libstb-dev)");
#endif

  // Geometry kept in memory by pc2/gltf/--render is logged for --resume (Checkpoint.h; Ctrl-C can come any time).
  bool in_memory = o.render;
  for (const std::string& f : sc.output.formats) in_memory = in_memory || f == "pc2" || f == "gltf";
  std::unique_ptr<FrameLog> log;
  if (in_memory) log = std::make_unique<FrameLog>(out, resume ? resume->logged_frames : 0, shown.cloths());
  auto keep_frame = [&](bool exported, bool rendered) {
    if (exported) exports.frame(sim.time(), shown.cloths());
#ifdef LOOM_HAVE_RENDER
    if (recording && rendered) recording->add(shown.cloths());
#endif
    if (log && (exported || rendered)) log->append(sim.time(), (exported ? 1 : 0) | (rendered ? 2 : 0), shown.cloths());
  };
  double max_strain = 0.0, mean_strain_sum = 0.0, sim_ms = 0.0;
  bool finite = true;
  if (resume) {
    cloth::StateReader in(resume->state, (out / "checkpoint" / "checkpoint.bin").string());
    sim.load_state(in);
    max_strain = resume->max_strain;
    mean_strain_sum = resume->mean_strain_sum;
    sim_ms = resume->sim_ms;
    if (log)  // the frames pc2/gltf/--render hold in memory, back from the log
      log->replay(shown.cloths(), [&](double time, int flags) {
        if (flags & 1) exports.frame(time, shown.cloths());
#ifdef LOOM_HAVE_RENDER
        if (recording && (flags & 2)) recording->add(shown.cloths());
#endif
      });
    shown.update();  // the replayed frames left their positions in the shown cloths
  } else {
    cloth::FrameStats s0 = sim.measure();
    finite = s0.finite;
    if (finite) {  // NaN is never written (issue 8)
      write_row(s0);
      write_bodies(0);
      run_census();
      if (obj) write_obj(frame_path(0), shown.cloths());
      keep_frame(true, true);
    }
    max_strain = finite ? s0.max_strain : 0.0;
  }
  int done = first;
  std::string error;
  ProgressBar bar(frames);
  auto save_checkpoint = [&]() {
    csv.flush();
    if (log) log->flush();
    Checkpoint c;
    c.scene = scene_path;
    c.scene_text = read_text_file(scene_path);
    c.sets = o.sets;
    c.frames_total = frames;
    c.threads = sc.setup.threads;
    c.checkpoint_every = o.checkpoint_every;
    c.render = o.render;
    c.frame = done;
    c.max_strain = max_strain;
    c.mean_strain_sum = mean_strain_sum;
    c.sim_ms = sim_ms;
    c.logged_frames = log ? log->entries() : 0;
    cloth::StateWriter w;
    sim.save_state(w);
    c.state = w.data();
    write_checkpoint(out, c);
  };
  g_interrupted = 0;
  auto old_handler = std::signal(SIGINT, on_sigint);
  bool interrupted = false;
  for (int f = first + 1; f <= frames && finite; ++f) {
    if (g_interrupted) {
      interrupted = true;
      break;
    }
    cloth::FrameStats s = step_frame();
    sim_ms += s.total_ms;
    if (!s.finite) {
      finite = false;
      const std::string cause = sim.failure().empty() ? "the state became non-finite in frame " + std::to_string(f) +
                                                            " (t = " + std::to_string(s.time) + " s)"
                                                      : sim.failure();
      error = cause + "; stopped, frames up to " + std::to_string(f - 1) + " are valid";
      break;
    }
    write_row(s);
    write_bodies(f);
    run_census();
    shown.update();
    if (obj && f % sc.output.every == 0) write_obj(frame_path(f), shown.cloths());
    max_strain = std::max(max_strain, s.max_strain);
    mean_strain_sum += s.mean_strain;
    done = f;
    bool rendered = false;
#ifdef LOOM_HAVE_RENDER
    rendered = f % sc.output.render.every == 0;
#endif
    keep_frame(f % sc.output.every == 0, rendered);
    if (o.checkpoint_every > 0 && f % o.checkpoint_every == 0 && f < frames) save_checkpoint();
    bar.update(done - first, sim_ms / std::max(1, done - first));
  }
  if (g_interrupted) interrupted = done < frames;
  std::signal(SIGINT, old_handler);
  bool resumable = true;
#ifdef LOOM_HAVE_BULLET
  resumable = !bodies_world;
#endif
  if (interrupted && resumable) save_checkpoint();
  bar.finish();
  exports.finish();
  nlohmann::ordered_json render_summary;
#ifdef LOOM_HAVE_RENDER
  if (recording && !interrupted) {  // an interrupted run renders when it is resumed and ends
    render::RenderSettings rs;
    rs.width = sc.output.render.width;
    rs.height = sc.output.render.height;
    if (sc.output.render.camera) rs.camera = render::Camera{sc.output.render.eye, sc.output.render.target, sc.output.render.fov};
    const render::RenderReport rep =
        render::render_recording(out.string(), *recording, rs, 1.0 / (sc.setup.frame_dt * sc.output.render.every));
    render_summary = {{"frames", rep.frames}, {"ms_per_frame", rep.ms_per_frame}, {"width", rs.width}, {"height", rs.height}};
    std::cout << "loom: rendered " << rep.frames << " frames (" << std::fixed << std::setprecision(1) << rep.ms_per_frame
              << " ms/frame) -> " << (out / "render").string() << "/, " << rep.mp4 << ", " << rep.gif << "\n";
  }
#endif
  csv.close();
  if (!csv) throw Error(stats_partial.string(), "", "write failed");
  fs::rename(stats_partial, out / "stats.csv");

  nlohmann::ordered_json j;
  j["scene"] = scene_path;
  j["frames"] = done;
  j["sim_seconds"] = done * sc.setup.frame_dt;
  j["wall_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  j["ms_per_frame"] = done ? sim_ms / done : 0.0;
  nlohmann::ordered_json stages, per_frame, counters;
  for (const cloth::StageProfile& p : sim.profile()) {
    stages[p.name] = p.total_ms;
    per_frame[p.name] = done ? p.total_ms / done : 0.0;
    nlohmann::ordered_json c = nlohmann::ordered_json::object();
    for (const auto& [k, v] : p.counters) c[k] = v;
    counters[p.name] = c;
  }
  j["stages"] = stages;
  j["stages_ms_per_frame"] = per_frame;
  j["counters"] = counters;
  j["max_strain"] = max_strain;
  j["mean_strain"] = done ? mean_strain_sum / done : 0.0;
  j["finite"] = finite;
  if (o.census) {
    j["intersections"] = census_intersections;
    j["max_penetration"] = census_penetration;
  }
  // Issue 8: completed = every frame asked for was simulated; interrupted = stopped by Ctrl-C (resumable).
  j["completed"] = finite && !interrupted && done == frames;
  if (interrupted) j["interrupted"] = true;
  if (resume) j["resumed_from_frame"] = first;
  j["rollbacks"] = sim.rollbacks();
  j["solver"] = sc.setup.solver.method;
  j["substeps"] = sc.setup.substeps;
  j["dt"] = sim.step_size();
  j["threads"] = sc.setup.threads;
  int vertices = 0, triangles = 0;
  for (const auto& c : sim.cloths()) {
    vertices += c->state().size();
    triangles += c->mesh().num_triangles();
  }
  j["vertices"] = vertices;
  j["triangles"] = triangles;
  if (!render_summary.is_null()) j["render"] = render_summary;
#ifdef LOOM_HAVE_BULLET
  if (bodies_world) {  // issue 9: the rigid bodies' end state; the trajectories are in bodies.csv
    nlohmann::ordered_json bj = nlohmann::ordered_json::array();
    for (size_t k = 0; k < bodies_world->num_bodies(); ++k) {
      const cloth::Vec3 p = bodies_world->body_position(k), v = bodies_world->body_velocity(k);
      bj.push_back({{"name", sc.bodies[k].name}, {"position", {p.x(), p.y(), p.z()}}, {"velocity", {v.x(), v.y(), v.z()}}});
    }
    j["bodies"] = bj;
    j["bodies_file"] = "bodies.csv";
    j["bullet_substeps"] = bodies_world->bullet_substeps();
    j["cloth_steps"] = bodies_world->cloth_steps();
    if (!bodies_world->warnings().empty()) j["unsupported_shapes"] = bodies_world->warnings();
  }
#endif
  if (!finite) j["error"] = error;
  write_atomically(out / "summary.json", j.dump(2) + "\n");

  if (o.profile) print_profile(sim, done);
  if (!finite) {
    std::cerr << "loom: error: " << scene_path << ": " << error << "\n";
    return 3;
  }
  if (interrupted) {
    if (!resumable) {
      std::cerr << "loom: interrupted after frame " << done << " of " << frames
                << "; outputs so far are valid (a scene with rigid bodies cannot be resumed)\n";
      return 130;
    }
    std::cerr << "loom: interrupted after frame " << done << " of " << frames << "; outputs so far are valid; continue with: loom run --resume "
              << out.string() << "\n";
    return 130;
  }
  std::cout << "loom: " << done << " frames of " << sc.name << " in " << std::fixed << std::setprecision(2)
            << (done ? sim_ms / done : 0.0) << " ms/frame -> " << out.string() << "\n";
  return 0;
}

}  // namespace loom::app
