#include "RunCommand.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <iterator>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <thread>

#include "Checkpoint.h"
#include "DetailView.h"
#include "Terminal.h"
#include "loom/cloth/Error.h"
#include "loom/eval/CsvNumber.h"
#include "loom/eval/HelperProgram.h"
#include "loom/eval/OutputFolder.h"
#include "loom/export/Exporters.h"
#ifdef LOOM_HAVE_RENDER
#include "loom/render/RenderRun.h"
#endif
#ifdef LOOM_HAVE_BULLET
#include "loom/bullet/BulletScene.h"
#endif
#include "loom/cloth/OutputFile.h"
#include "loom/collision/MultiClothCensus.h"
#include "loom/scene/Scene.h"
#include "loom/scene/SceneLimits.h"
#include "loom/scene/ScenePipeline.h"
#include "loom/scene/SceneRegime.h"

namespace fs = std::filesystem;

namespace loom::app {

namespace {

// The default scene: a mocap character in a skirt and a cape; builds without loom::characters
// fall back to the hanging cloth.
#ifdef LOOM_HAVE_CHARACTERS
constexpr const char* kDefaultScene = "character_layers.json";
#else
constexpr const char* kDefaultScene = "hanging_cloth.json";
#endif

// Ctrl-C (SIGINT): the run stops within the frame in progress (the simulation checks the flag between its
// steps and the guard's retries and goes back to the frame's start), writes a checkpoint and valid outputs.
// SIGTERM (kill, timeout, a CI's or container's cancellation) and SIGHUP (the terminal closed) stop it the
// same way; g_interrupted holds the signal's number, the exit code is 128 + it (130 for Ctrl-C). A SIGTERM or
// SIGHUP the parent ignores (nohup) stays ignored.
volatile std::sig_atomic_t g_interrupted = 0;
extern "C" void on_sigint(int sig) { g_interrupted = sig; }
constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP};
int interrupted_exit_code() { return 128 + (g_interrupted > 0 ? static_cast<int>(g_interrupted) : SIGINT); }

// Writes one OBJ frame; returns `hash` continued over the file's bytes (Checkpoint::frames_hash) and
// appends the file's own hash to `file_hashes` (Checkpoint::frame_hashes).
std::uint64_t write_obj(const fs::path& path, const std::vector<std::unique_ptr<cloth::Cloth>>& cloths,
                        std::uint64_t hash, std::vector<std::uint64_t>& file_hashes) {
  std::ostringstream text;
  text << std::setprecision(9);
  int base = 1;
  for (const auto& c : cloths) {
    text << "o " << c->name() << "\n";
    for (const cloth::Vec3& p : c->state().x) text << "v " << p.x() << ' ' << p.y() << ' ' << p.z() << "\n";
    for (const cloth::Tri& t : c->mesh().triangles())
      text << "f " << t[0] + base << ' ' << t[1] + base << ' ' << t[2] + base << "\n";
    base += c->state().size();
  }
  const std::string bytes = text.str();
  OutputFile out(path);
  if (!out) throw Error(path.string(), "", "cannot write frame");
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) throw Error(path.string(), "", out.write_failure());
  file_hashes.push_back(fnv1a(bytes.data(), bytes.size(), kFnvOffset));
  return fnv1a(bytes.data(), bytes.size(), hash);
}

// Writes `text` to `path` through a temporary file `tmp` and a rename, so a reader never sees half a file.
void write_atomically(const fs::path& path, const fs::path& tmp, const std::string& text) {
  write_file_atomically(path.string(), tmp.string(), text);
}

// The first cloth (by name) with a non-finite position, or an empty string.
std::string non_finite_cloth(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  for (const auto& c : cloths)
    for (const cloth::Vec3& p : c->state().x)
      if (!p.allFinite()) return c->name();
  return "";
}

// The first cloth (by name) with a position beyond the scene's coordinate bound kMaxCoordinate on any axis
// (or not finite), or an empty string. Every output holds positions within it: float32 PC2/glTF overflow near
// 3.4e38 and the bound keeps the written digits meaningful.
std::string out_of_range_cloth(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  for (const auto& c : cloths)
    for (const cloth::Vec3& p : c->state().x)
      if (!(p.cwiseAbs().maxCoeff() <= scene::kMaxCoordinate)) return c->name();
  return "";
}

// Digits of the frame numbers in file names: at least 5, enough for the last frame so names sort in order.
int frame_digits(int frames) {
  int d = 5;
  for (long v = 100000; v <= frames; v *= 10) ++d;
  return d;
}

class ProgressBar {
 public:
  explicit ProgressBar(int total) : total_(total), enabled_(isatty(STDERR_FILENO)) {}
  void update(int done, double ms_per_frame) {
    if (!enabled_) return;
    const int width = 30, filled = total_ ? done * width / total_ : width;
    std::fprintf(stderr, "\r[%s%s] %3d%% frame %d/%d  %.2f ms/frame", std::string(filled, '#').c_str(),
                 std::string(width - filled, ' ').c_str(), total_ ? 100 * done / total_ : 100, done, total_,
                 ms_per_frame);
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
  // An empty LOOM_SCENES (an unset shell variable exported) is unset: never the working directory.
  if (const char* env = std::getenv("LOOM_SCENES"); env && *env)
    return (fs::path(env) / kDefaultScene).string();
  if (fs::exists(fs::path("scenes") / kDefaultScene)) return (fs::path("scenes") / kDefaultScene).string();
  return (fs::path(LOOM_SOURCE_DIR) / "scenes" / kDefaultScene).string();
}

namespace {

// A resumed state is an input like any other (its checksum can be recomputed by whoever edits it): every
// position and velocity finite, positions within the scene bound kMaxCoordinate, speeds at most
// kMaxResumedSpeed (and so the previous step's positions within a frame's motion at that speed), every pinned
// vertex at its pin's target (`pins_own_paths`: the pins follow their own paths; a character's garments move
// theirs with the body), the clock at the checkpoint's frame. Refused naming the checkpoint file and the
// cloth, vertex and quantity.
constexpr double kMaxResumedSpeed = 1e5;  // m/s
constexpr double kPinTolerance = 1e-4;    // m, a pinned vertex's distance from its target
void check_resumed_state(const std::string& file, const cloth::Simulation& sim, int frame, double frame_dt,
                         bool pins_own_paths) {
  const double expected = frame * frame_dt;
  if (!(std::abs(sim.time() - expected) <= 1e-9 * std::max(1.0, expected)))
    throw Error(file, "state: time",
                "is " + std::to_string(sim.time()) + " s, not the checkpoint's frame " +
                    std::to_string(frame) + " (" + std::to_string(expected) +
                    " s): the state does not belong to this checkpoint");
  for (const auto& c : sim.cloths()) {
    const cloth::ClothState& st = c->state();
    const std::string who = "state: cloth '" + c->name() + "' vertex ";
    for (size_t i = 0; i < st.x.size(); ++i) {
      if (!(st.x[i].cwiseAbs().maxCoeff() <= scene::kMaxCoordinate))
        throw Error(file, who + std::to_string(i) + " position",
                    "is not finite or beyond 1e6 m: not a state a run writes");
      if (i < st.v.size() && !(st.v[i].norm() <= kMaxResumedSpeed))
        throw Error(file, who + std::to_string(i) + " velocity",
                    "is not finite or faster than 1e5 m/s: not a state a run writes");
      // The position at the start of the last step: at most a frame's motion at that speed away.
      if (i < st.x_prev.size() && !((st.x_prev[i] - st.x[i]).norm() <= kMaxResumedSpeed * frame_dt))
        throw Error(file, who + std::to_string(i) + " previous position",
                    "is not finite or farther from the position than 1e5 m/s moves in a frame: not a state a "
                    "run writes");
    }
    for (const cloth::Pin& p : c->pins())
      if (pins_own_paths && p.vertex >= 0 && static_cast<size_t>(p.vertex) < st.x.size() &&
          !((st.x[p.vertex] - p.target(sim.time())).norm() <= kPinTolerance))
        throw Error(file, who + std::to_string(p.vertex) + " position",
                    "is pinned but lies " + std::to_string((st.x[p.vertex] - p.target(sim.time())).norm()) +
                        " m from its pin: not a state a run writes");
  }
}

// The state's energies and strains against stats.csv's row of the checkpoint's frame, which the run wrote
// from that same state (10 significant digits): a state changed since (a nudged vertex, an edited velocity,
// with its checksum recomputed) no longer gives them. Refused naming the checkpoint and the quantity.
void check_state_matches_stats(const std::string& file, const cloth::FrameStats& now, int frame,
                               const std::string& rows) {
  std::string last;
  std::istringstream in(rows);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) last = line;
  std::vector<double> cell;
  std::istringstream row(last);
  for (std::string c; std::getline(row, c, ',');) cell.push_back(std::strtod(c.c_str(), nullptr));
  if (cell.size() < 7 || cell[0] != frame)
    throw Error(file, "state",
                "stats.csv has no row of the checkpoint's frame " + std::to_string(frame) +
                    ": the run's outputs and its checkpoint do not belong together");
  const std::pair<const char*, double> state[] = {{"kinetic_energy", now.kinetic},
                                                  {"potential_energy", now.potential},
                                                  {"elastic_energy", now.elastic},
                                                  {"max_strain", now.max_strain},
                                                  {"mean_strain", now.mean_strain}};
  for (int k = 0; k < 5; ++k) {
    const double written = cell[k + 2], value = state[k].second;
    if (!(std::abs(value - written) <= 1e-8 * std::max(std::abs(value), std::abs(written)) + 1e-300)) {
      std::ostringstream why;
      why << std::setprecision(10) << "is " << value << " in the state but " << written
          << " in stats.csv's row of frame " << frame
          << ", written from the same state: the state was changed after it was saved";
      throw Error(file, std::string("state: ") + state[k].first, why.str());
    }
  }
}

// The run's totals the checkpoint carries (max strain, the sum of mean strains, the pipeline's ms) against
// the stats rows they were summed from (frames 0 to the checkpoint's; 10 significant digits each): totals
// edited with the checksum recomputed are refused naming the checkpoint and the field.
void check_totals_match_stats(const std::string& file, const Checkpoint& c, const std::string& rows) {
  double max_strain = 0.0, mean_strain_sum = 0.0, sim_ms = 0.0;
  std::istringstream in(rows);
  for (std::string line; std::getline(in, line);) {
    std::vector<double> cell;
    std::istringstream row(line);
    for (std::string v; std::getline(row, v, ',');) cell.push_back(std::strtod(v.c_str(), nullptr));
    if (cell.size() < 8) continue;
    max_strain = std::max(max_strain, cell[5]);
    if (cell[0] >= 1.0) mean_strain_sum += cell[6], sim_ms += cell[7];
  }
  const std::pair<const char*, std::pair<double, double>> totals[] = {
      {"max_strain", {c.max_strain, max_strain}},
      {"mean_strain_sum", {c.mean_strain_sum, mean_strain_sum}},
      {"sim_ms", {c.sim_ms, sim_ms}}};
  for (const auto& [name, v] : totals)
    if (!(std::abs(v.first - v.second) <= 1e-7 * std::max(std::abs(v.first), std::abs(v.second)) + 1e-9)) {
      std::ostringstream why;
      why << std::setprecision(10) << "is " << v.first << " in the checkpoint but " << v.second
          << " from stats.csv's rows up to frame " << c.frame
          << ": the checkpoint was changed after it was saved";
      throw Error(file, name, why.str());
    }
}

// --resume DIR: the run's options come from DIR's checkpoint, after its run id and every input it read
// (scene, meshes, motion clips) are checked against what the checkpoint recorded.
std::optional<Checkpoint> apply_resume(RunOptions& o) {
  if (o.resume.empty()) return std::nullopt;
  Checkpoint resume = read_checkpoint(o.resume);
  const fs::path ckpt = fs::path(o.resume) / "checkpoint" / "checkpoint.bin";
  if (read_run_id(o.resume) != resume.run_id)
    throw Error(ckpt.string(), "run_id",
                "belongs to another run's output folder (its run id is not the one in " +
                    (fs::path(o.resume) / OutputFolder::kManifest).string() +
                    "): resume the folder it was written in");
  check_inputs(resume);
  o.scene = resume.scene;
  o.sets = resume.sets;
  o.out = o.resume;
  o.render = resume.render;
  if (o.frames < 0) o.frames = resume.frames_total;
  // The frames up to the checkpoint are already written: fewer would leave outputs of a run longer than
  // the one asked for (or drop frames the run wrote). Equal finishes the outputs without a new step.
  if (o.frames < resume.frame)
    throw Error(ckpt.string(), "--frames",
                std::to_string(o.frames) + " is below the checkpoint's frame " +
                    std::to_string(resume.frame) + ": give --frames " + std::to_string(resume.frame) +
                    " or more (or leave it out: " + std::to_string(resume.frames_total) + ")");
  // The frame files keep the width of the names already written: a count that needs more digits would
  // mix two widths in frames/ (names that no longer sort in frame order).
  if (frame_digits(o.frames) > resume.frame_digits)
    throw Error(ckpt.string(), "--frames",
                std::to_string(o.frames) + " needs frame numbers of " +
                    std::to_string(frame_digits(o.frames)) + " digits, but this run's frame files have " +
                    std::to_string(resume.frame_digits) + ": give --frames below " +
                    std::to_string(static_cast<long long>(std::pow(10, resume.frame_digits))) +
                    " or start a new run");
  if (o.threads < 0) o.threads = resume.threads;
  if (o.checkpoint_every <= 0) o.checkpoint_every = resume.checkpoint_every;
  if (read_text_file(o.scene) != resume.scene_text)
    throw Error(o.scene, "--resume", "the scene file changed since the checkpoint was written");
  return resume;
}

// One `loom run`: the scene's pipeline, the output folder it owns and what it writes there, frame by frame.
// The constructor validates everything (scene, resume state, output folder) before any file changes.
class SceneRun {
 public:
  explicit SceneRun(const RunOptions& options);
  // Frame 0 (or, on --resume, the frames kept in memory replayed from the log), then every frame asked for.
  void run();
  // Renders the recording (--render), closes stats.csv, writes summary.json; returns the exit code.
  int finish();

 private:
  void open_outputs();
  // Refuses, before any file changes, a format of output.formats whose file (and the memory that writes or
  // reads it) would exceed kMaxExportBytes for the frames asked for.
  void check_export_sizes() const;
  void start();
  void step_frames();
  void render_video();
  nlohmann::ordered_json summary() const;
  double unresolved_contacts() const;
  bool tier_strain_held() const;
  void print_warnings() const;
  void write_row(const cloth::FrameStats& s);
  void write_bodies(int f);
  bool run_census(int f);
  std::string frame_name(int f) const;
  // Deletes the files DIR/<folder>/frame_<number><ext> the manifest lists whose number is `from` or more
  // (whatever its width): frames an earlier run wrote beyond what this one writes.
  void remove_listed_frames(const std::string& folder, const std::string& ext, long from);
  void keep_frame(bool exported, bool rendered);
  // --resume: refuses (naming the file) when an OBJ frame written up to the checkpoint is missing, or when
  // their bytes no longer hash to the checkpoint's frames_hash; sets frames_hash_ to it.
  void check_kept_frames();
  void save_checkpoint();
  // Stops the run at frame f with `why` when the simulation or the shown surface is not finite.
  bool stopped_non_finite(const cloth::FrameStats& s, int f);

  const std::chrono::steady_clock::time_point wall_start_ = std::chrono::steady_clock::now();
  RunOptions o_;
  std::optional<Checkpoint> resume_;
  std::string scene_path_, scene_abs_, scene_text_;
  std::vector<InputFile>
      inputs_;  // what a checkpoint records of the inputs: every file the scene read, hashed
  scene::Scene sc_;
  int frames_ = 0;
  std::unique_ptr<scene::ScenePipeline> pipeline_;
  cloth::Simulation* sim_ = nullptr;
#ifdef LOOM_HAVE_BULLET
  const bullet::BulletScene* bodies_world_ = nullptr;  // a scene with rigid bodies: its Bullet world
#endif
  fs::path out_;
  std::shared_ptr<eval::FolderLock> resume_lock_;  // --resume: held from before the checkpoint is read
  std::unique_ptr<OutputFolder> folder_;
  int first_ = 0;
  std::unique_ptr<DetailView> shown_;  // cloths with `detail` are written and rendered as their surface
  std::unique_ptr<FrameLog> log_;      // frames pc2/gltf/--render keep in memory, logged for --resume
  int digits_ = 5;
  std::vector<std::string> export_files_;    // the exporters' files, relative to out_
  bool no_frame_written_ = false;            // frame 0 was not finite: the run stopped before it
  std::uint64_t frames_hash_ = kFnvOffset;   // the OBJ frames written so far (Checkpoint::frames_hash)
  std::vector<std::uint64_t> frame_hashes_;  // each of them alone (Checkpoint::frame_hashes)
  bool obj_ = false;
  fs::path stats_partial_;
  OutputFile csv_, bodies_csv_;
  std::unique_ptr<exporter::Exporters> exports_;
#ifdef LOOM_HAVE_RENDER
  std::unique_ptr<render::Recording> recording_;  // --render: positions kept, rendered after the run
#endif
  nlohmann::ordered_json render_summary_;
  long census_intersections_ = 0;
  double census_penetration_ = 0.0;
  double max_strain_ = 0.0, mean_strain_sum_ = 0.0, sim_ms_ = 0.0;
  int max_strain_frame_ = 0;  // the frame of max_strain_ (0: the start state, or before a resume)
  double wall_ms_ = 0.0;      // ms, whole frames stepped by this process (with a Bullet world's own step)
  int stepped_ = 0;           // frames stepped by this process
  bool finite_ = true, interrupted_ = false, resumable_ = true;
  bool render_interrupted_ = false;  // Ctrl-C in the render phase: the video is not written
  std::string render_error_;         // ffmpeg failed: the video is not written, the run ends with exit 1
  void (*old_handlers_[3])(int) = {SIG_DFL, SIG_DFL, SIG_DFL};  // of kStopSignals
  std::string error_;
  int done_ = 0;
};

SceneRun::SceneRun(const RunOptions& options) : o_(options) {
  // The folder is locked before its checkpoint or manifest is read (OutputFolder.h, FolderLock).
  if (!o_.resume.empty()) resume_lock_ = eval::FolderLock::acquire(o_.resume, "--resume");
  resume_ = apply_resume(o_);
  scene_path_ = o_.scene.empty() ? default_scene_path() : o_.scene;
  sc_ = scene::load_scene(scene_path_, o_.sets);
  // The scene by absolute path, so --resume works from any folder; resolved as the system resolves it (a
  // link followed before a "..": lexical normalisation would name another file).
  std::error_code canon_ec;
  const fs::path canon = fs::weakly_canonical(fs::absolute(scene_path_), canon_ec);
  scene_abs_ = (canon_ec ? fs::absolute(scene_path_).lexically_normal() : canon).string();
  scene_text_ = read_text_file(scene_path_);
  inputs_ = {fingerprint(scene_abs_)};  // the path the checkpoint records as its scene
  for (const std::string& f : sc_.inputs) inputs_.push_back(fingerprint(f));
  if (o_.threads > 0) sc_.setup.threads = o_.threads;
  for (const std::string& w : sc_.start_warnings)
    std::cerr
        << "loom: warning: " << printable(scene_path_) << ": " << printable(w)
        << ": contact pushes it out from the first step, with a jump, and cannot free a cloth that lies "
           "deeper inside than it can move (move them apart)\n";
  // Threads beyond the machine's only queue on the cores (and thousands exhaust the OpenMP runtime).
  const int hardware = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  if (sc_.setup.threads > hardware) {
    std::cerr << "loom: warning: " << printable(scene_path_) << ": threads " << sc_.setup.threads
              << " capped at the " << hardware << " hardware threads of this machine\n";
    sc_.setup.threads = hardware;
  }
  frames_ = o_.frames >= 0 ? o_.frames : sc_.frames;
  if (frames_ > scene::kMaxFrames)
    throw Error(
        scene_path_, "--frames",
        "at most " + std::to_string(scene::kMaxFrames) + " frames (got " + std::to_string(frames_) + ")");
  if (sc_.setup.solver.method == "weil" && frames_ > 1)  // one static shape (Scene.cpp, check_weil)
    throw Error(scene_path_, "--frames",
                "the weil drape (solver.method \"weil\") is one static shape: at most 1 frame (got " +
                    std::to_string(frames_) + ")");
  if (!sc_.bodies.empty() && (resume_ || o_.checkpoint_every > 0))
    throw Error(
        scene_path_, "bodies",
        "--checkpoint-every / --resume do not save the Bullet world: not available for scenes with rigid "
        "bodies");
  // What the scene runs, with the scene-level defaults (ScenePipeline.h); validates before any output.
  pipeline_ = scene::build_pipeline(sc_);
  sc_ = pipeline_->scene();
  sim_ = &pipeline_->simulation();
#ifdef LOOM_HAVE_BULLET
  bodies_world_ = pipeline_->bullet();
  resumable_ = !bodies_world_;
#endif
  open_outputs();
}

// A frame rate as the message shows it: 6 significant digits.
std::string video_rate_text(double hz) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", hz);
  return text;
}

// The largest file (and memory to write or read it) one export format may take: 2 GiB, the glTF buffer
// bound of most readers (byteLength in a signed 32-bit field).
constexpr double kMaxExportBytes = 2147483648.0;

// PC2: written frames x vertices x 12 bytes. glTF (GltfWriter.h): as much for the morph targets plus 12 bytes
// a written frame (its time, and the sparse index and value of its animation weight) in the .bin; in the
// .gltf, and in memory until the run ends, one accessor, buffer view, target and name per cloth and written
// frame (measured: 226 bytes of JSON text and 2.6 kB of memory each, with 40 cloths over 5000 frames). The
// sparse weights address keys x targets elements with 32-bit indices, which bounds the written frames to
// 65536.
constexpr double kGltfTextBytesPerTarget = 240.0, kGltfMemoryBytesPerTarget = 2700.0;

void SceneRun::check_export_sizes() const {
  const double written = std::floor(frames_ / double(std::max(1, sc_.output.every))) + 1.0;
  double vertices = 0.0;
  for (const auto& c : shown_->cloths()) vertices += c->state().size();
  const double targets = (written - 1.0) * static_cast<double>(shown_->cloths().size());
  for (const std::string& f : sc_.output.formats) {
    double bytes = 0.0;
    if (f == "pc2")
      bytes = written * vertices * 12.0;
    else if (f == "gltf")
      bytes = std::max(written * vertices * 12.0 + written * 12.0, targets * kGltfTextBytesPerTarget);
    else
      continue;
    if (f == "gltf" && written * (written - 1.0) > 4294967295.0)
      throw Error(scene_path_, "output.formats",
                  "\"gltf\" would hold " + std::to_string(static_cast<long long>(written)) +
                      " written frames, above the 65536 its animation weights can address (32-bit sparse "
                      "indices): lower --frames (or raise output.every) or drop \"gltf\"");
    if (f == "gltf")
      scene::check_memory(
          scene_path_, "output.formats", targets * kGltfMemoryBytesPerTarget,
          "\"gltf\" (one morph target per cloth and written frame: " + scene::show_count(targets) + ") needs",
          "lower --frames (or raise output.every), or drop \"gltf\"");
    if (bytes <= kMaxExportBytes) continue;
    char figure[160];
    std::snprintf(figure, sizeof figure, "%.3g GB for %.0f written frames of %.0f vertices in %zu cloths",
                  bytes / 1e9, written, vertices, shown_->cloths().size());
    throw Error(
        scene_path_, "output.formats",
        "\"" + f + "\" would take " + figure +
            ", above the 2.15 GB an export may take: lower --frames (or raise output.every) or drop \"" + f +
            "\"");
  }
#ifdef LOOM_HAVE_RENDER
  // --render keeps every rendered frame's positions until the run ends and then draws supersampled images:
  // what that needs is known now, so a size past the memory there is is refused before the run.
  if (o_.render) {
    render::RenderSettings rs;
    rs.width = sc_.output.render.width;
    rs.height = sc_.output.render.height;
    const double rendered = std::floor(frames_ / double(std::max(1, sc_.output.render.every))) + 1.0;
    const auto colliders = pipeline_->colliders();
    const double need =
        render::render_memory_bytes(rs, rendered, vertices, colliders ? double(colliders->size()) : 0.0);
    scene::check_memory(scene_path_, "output.render.width", need,
                        "--render at " + std::to_string(rs.width) + "x" + std::to_string(rs.height) +
                            " px for " + std::to_string(static_cast<long long>(rendered)) +
                            " rendered frames of " + std::to_string(static_cast<long long>(vertices)) +
                            " vertices needs",
                        "lower output.render.width and height, raise output.render.every or lower --frames");
    // The video is encoded after the run by ffmpeg, a process of its own under the same limits.
    scene::check_memory(scene_path_, "output.render.width", eval::ffmpeg_memory_bytes(rs.width, rs.height),
                        "ffmpeg's encoding of " + std::to_string(rs.width) + "x" + std::to_string(rs.height) +
                            " px frames with " + std::to_string(eval::ffmpeg_threads()) + " threads needs",
                        "lower output.render.width and height", "", scene::MemoryOf::child_process);
  }
#endif
}

// The output folder (OutputFolder.h): out/<scene name> by default (the scene layer keeps `name` a plain file
// name); a run writes only paths it claims in the folder's manifest and deletes only listed ones. On --resume
// everything is checked before a file changes: the state, the frame log, the stats rows.
void SceneRun::open_outputs() {
  out_ = o_.out.empty() ? fs::path("out") / sc_.name : fs::path(o_.out);
  if (o_.out.empty() && fs::path(sc_.name).filename() != fs::path(sc_.name))
    throw Error(scene_path_, "name", "is not a plain file name, so it cannot name the output folder");
  if (o_.out.empty() && !resume_) eval::refuse_linked_default(out_, "--out");
#ifndef LOOM_HAVE_RENDER
  if (o_.render)
    throw Error("", "--render",
                "this loom was built without the offscreen renderer (Debian: libosmesa6-dev libstb-dev)");
#else
  if (o_.render) {
    // The video runs after the whole simulation: what would stop it is refused before the run. Its frame
    // rate is fps / output.render.every; ffmpeg's encoders fail below 1 Hz (or run without bound making
    // the GIF), and no player shows more than 1000.
    const double video_fps = 1.0 / (sc_.setup.frame_dt * sc_.output.render.every);
    if (!(video_fps >= 1.0 && video_fps <= 1000.0))
      throw Error(
          scene_path_, "fps",
          "with --render, fps / output.render.every is the video's frame rate and must be in [1, 1000] "
          "(got " +
              video_rate_text(video_fps) + ")");
    if (!eval::program_on_path("ffmpeg"))
      throw Error("ffmpeg", "--render",
                  "ffmpeg not found (Debian package: ffmpeg); install it or run without --render");
  }
#endif
  shown_ = std::make_unique<DetailView>(sc_, *sim_);
  check_export_sizes();
  // Every path this run may write, checked before the folder changes (a refused run leaves it as it was).
  std::vector<std::string> writes = {"frames/",
                                     "frames/frame_#.obj",
                                     "stats.csv.partial",
                                     "stats.csv",
                                     "summary.json",
                                     "summary.json.tmp",
                                     "bodies.csv",
                                     "checkpoint/",
                                     "checkpoint/checkpoint.bin",
                                     "checkpoint/checkpoint.bin.tmp",
                                     "checkpoint/frames.bin",
                                     "render/",
                                     "render/frame_#.png",
                                     "render.mp4",
                                     "render.gif",
                                     "animation.gltf",
                                     "animation.gltf.tmp",
                                     "animation.bin"};
  for (const std::string& n : exporter::Exporters::file_names(shown_->cloths()))
    writes.insert(writes.end(), {"pc2/", "pc2/" + n + ".obj", "pc2/" + n + ".pc2"});
  std::vector<std::string> inputs = {scene_path_};
  inputs.insert(inputs.end(), sc_.inputs.begin(), sc_.inputs.end());
  folder_ = std::make_unique<OutputFolder>(out_, resume_ ? "--resume" : "--out", o_.overwrite,
                                           resume_.has_value(), writes, inputs);
  first_ = resume_ ? resume_->frame : 0;
  bool in_memory = o_.render;
  for (const std::string& f : sc_.output.formats) in_memory = in_memory || f == "pc2" || f == "gltf";
  std::string kept_rows;
  if (resume_) {
    cloth::StateReader in(resume_->state, (out_ / "checkpoint" / "checkpoint.bin").string());
    sim_->load_state(in);
    check_resumed_state((out_ / "checkpoint" / "checkpoint.bin").string(), *sim_, first_, sc_.setup.frame_dt,
                        !sc_.character);
    kept_rows = kept_stats_rows(out_, first_);
    check_state_matches_stats((out_ / "checkpoint" / "checkpoint.bin").string(), sim_->measure(), first_,
                              kept_rows);
    check_totals_match_stats((out_ / "checkpoint" / "checkpoint.bin").string(), *resume_, kept_rows);
  }
  if (in_memory)
    log_ = std::make_unique<FrameLog>(*folder_, resume_ ? resume_->logged_frames : 0,
                                      resume_ ? resume_->log_hash : 0, shown_->cloths());
  digits_ = resume_ ? resume_->frame_digits : frame_digits(frames_);
  if (resume_) check_kept_frames();
  folder_->claim("frames/");
  if (resume_) {  // the stats rows and OBJ frames up to the checkpoint's frame are kept, later ones dropped
    remove_listed_frames("frames", ".obj", first_ + 1);
    remove_listed_frames("render", ".png", 0);  // rendered again from the whole recording
    folder_->remove_owned("render.mp4");
    folder_->remove_owned("render.gif");
    folder_->remove_owned("summary.json");
    folder_->remove_owned("stats.csv");
  }
  stats_partial_ = folder_->claim("stats.csv.partial");
  csv_.open(stats_partial_, std::ios::trunc);
  if (!csv_) throw Error(stats_partial_.string(), "", "cannot write");
  csv_ << std::setprecision(10);
  csv_ << "frame,time,kinetic_energy,potential_energy,elastic_energy,max_strain,mean_strain,ms_total";
  for (const auto& n : sim_->stage_names()) csv_ << ",ms_" << n;
  csv_ << "\n" << kept_rows;
  // output.formats: "obj" below (with output.frames), "pc2" and "gltf" through loom::export.
  obj_ = sc_.output.frames &&
         std::find(sc_.output.formats.begin(), sc_.output.formats.end(), "obj") != sc_.output.formats.end();
  for (const std::string& f : sc_.output.formats) {  // the exporters' files (Exporters.h), claimed first
    if (f == "pc2") {
      folder_->claim("pc2/");
      for (const std::string& n : exporter::Exporters::file_names(shown_->cloths()))
        export_files_.insert(export_files_.end(), {"pc2/" + n + ".obj", "pc2/" + n + ".pc2"});
    } else if (f == "gltf") {
      export_files_.insert(export_files_.end(), {"animation.gltf", "animation.gltf.tmp", "animation.bin"});
    }
  }
  for (const std::string& n : export_files_) folder_->claim(n);
  exports_ = std::make_unique<exporter::Exporters>(out_.string(), sc_.output.formats, shown_->cloths(),
                                                   sc_.output.every);
#ifdef LOOM_HAVE_RENDER
  if (o_.render) recording_ = std::make_unique<render::Recording>(shown_->cloths(), pipeline_->colliders());
#endif
}

void SceneRun::write_row(const cloth::FrameStats& s) {
  csv_ << s.frame << ',' << s.time << ',' << s.kinetic << ',' << s.potential << ',' << s.elastic << ','
       << s.max_strain << ',' << s.mean_strain << ',' << s.total_ms;
  for (double ms : s.stage_ms) csv_ << ',' << ms;
  csv_ << "\n";
}

// Scenes with bodies: DIR/bodies.csv, one row per body per frame (centre of mass, velocity).
void SceneRun::write_bodies(int f) {
#ifdef LOOM_HAVE_BULLET
  if (!bodies_world_) return;
  if (!bodies_csv_.is_open()) {
    bodies_csv_.open(folder_->claim("bodies.csv"));
    if (!bodies_csv_) throw Error((out_ / "bodies.csv").string(), "", "cannot write");
    bodies_csv_ << std::setprecision(10) << "frame,time,body,x,y,z,vx,vy,vz\n";
  }
  for (size_t k = 0; k < bodies_world_->num_bodies(); ++k) {
    const cloth::Vec3 p = bodies_world_->body_position(k), v = bodies_world_->body_velocity(k);
    bodies_csv_ << f << ',' << f * sc_.setup.frame_dt << ',' << eval::csv_text(sc_.bodies[k].name) << ','
                << p.x() << ',' << p.y() << ',' << p.z() << ',' << v.x() << ',' << v.y() << ',' << v.z()
                << "\n";
  }
#else
  (void)f;
#endif
}

// --census: exact count of intersecting triangle pairs (self, non-adjacent, and between cloths) and the
// deepest vertex inside a collider, after every frame; summary.json gets the largest of each.
// A census past its candidate bound (collision::kCensusCandidateBound: triangles piled onto each other) stops
// the run with the frame and the cloths named; the frames before are valid.
bool SceneRun::run_census(int f) {
  if (!o_.census) return true;
  std::vector<collision::CensusInput> in;
  for (const auto& c : sim_->cloths()) in.push_back({&c->mesh(), &c->state().x});
  // A stop request (Ctrl-C, SIGTERM) ends a long census at once (-1: no count); the run then stops as
  // interrupted at its next check.
  try {
    census_intersections_ = std::max(
        census_intersections_, collision::count_all_intersections(in, sc_.setup.threads, &g_interrupted));
  } catch (const collision::CensusBoundExceeded& e) {
    const auto& cloths = sim_->cloths();
    const std::string a = "'" + cloths[e.cloth_a]->name() + "'", b = "'" + cloths[e.cloth_b]->name() + "'";
    error_ = "--census: at frame " + std::to_string(f) + " the triangles of cloth " + a +
             (e.cloth_a == e.cloth_b ? "" : " and cloth " + b) + " are piled onto each other: more than " +
             std::to_string(e.bound) +
             " candidate triangle pairs, past the census's bound; run without --census" +
             (f == first_ ? "; stopped before frame " + std::to_string(f) + ", no frame written"
                          : "; stopped, frames up to " + std::to_string(f - 1) + " are valid");
    return false;
  }
  if (pipeline_->colliders())
    census_penetration_ =
        std::max(census_penetration_, collision::max_penetration(in, *pipeline_->colliders()));
  return true;
}

std::string SceneRun::frame_name(int f) const {
  std::string n = std::to_string(f);
  if (static_cast<int>(n.size()) < digits_) n.insert(0, static_cast<size_t>(digits_) - n.size(), '0');
  return "frames/frame_" + n + ".obj";
}

void SceneRun::remove_listed_frames(const std::string& folder, const std::string& ext, long from) {
  std::error_code ec;
  if (!fs::is_directory(fs::symlink_status(out_ / folder, ec))) return;
  std::vector<std::string> stale;
  for (fs::directory_iterator it(out_ / folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    if (n.size() <= 6 + ext.size() || n.compare(0, 6, "frame_") != 0 ||
        n.compare(n.size() - ext.size(), ext.size(), ext) != 0)
      continue;
    const std::string digits = n.substr(6, n.size() - 6 - ext.size());
    if (digits.size() > 10 || digits.find_first_not_of("0123456789") != std::string::npos) continue;
    if (std::stoll(digits) >= from) stale.push_back(folder + "/" + n);
  }
  for (const std::string& n : stale) folder_->remove_owned(n);  // only listed files are deleted
}

void SceneRun::check_kept_frames() {
  const bool obj = sc_.output.frames && std::find(sc_.output.formats.begin(), sc_.output.formats.end(),
                                                  "obj") != sc_.output.formats.end();
  std::uint64_t h = kFnvOffset;
  std::vector<std::uint64_t> hashes;  // each file's own
  std::string changed;                // the first file whose own hash differs from the checkpoint's
  const int every = std::max(1, sc_.output.every);
  for (int f = 0; obj && f <= first_; f += every) {
    const fs::path path = out_ / frame_name(f);
    std::error_code ec;
    if (!fs::exists(fs::symlink_status(path, ec)))
      throw Error(path.string(), "--resume",
                  "is missing: the run wrote it before its checkpoint at frame " + std::to_string(first_) +
                      ", so the folder no longer holds the whole run; run the scene again");
    const std::string bytes = read_text_file(path.string());
    h = fnv1a(bytes.data(), bytes.size(), h);
    hashes.push_back(fnv1a(bytes.data(), bytes.size(), kFnvOffset));
    const std::size_t k = hashes.size() - 1;
    if (changed.empty() && k < resume_->frame_hashes.size() && hashes[k] != resume_->frame_hashes[k])
      changed = path.string();
  }
  if (h != resume_->frames_hash)
    throw Error(changed.empty() ? (out_ / "frames").string() : changed, "--resume",
                std::string(changed.empty() ? "the frame files written" : "this frame file, written") +
                    " before the checkpoint at frame " + std::to_string(first_) +
                    (changed.empty() ? ", were" : ", was") +
                    " changed since (contents no longer match the checkpoint), so the folder no "
                    "longer holds the whole run; run the scene again");
  frames_hash_ = h;
  frame_hashes_ = hashes;
}

void SceneRun::keep_frame(bool exported, bool rendered) {
  if (exported) exports_->frame(sim_->time(), shown_->cloths());
#ifdef LOOM_HAVE_RENDER
  if (recording_ && rendered) recording_->add(shown_->cloths());
#endif
  if (log_ && (exported || rendered))
    log_->append(sim_->time(), (exported ? 1 : 0) | (rendered ? 2 : 0), shown_->cloths());
}

void SceneRun::save_checkpoint() {
  csv_.flush();
  if (log_) log_->flush();
  Checkpoint c;
  c.scene = scene_abs_;
  c.scene_text = scene_text_;
  c.run_id = folder_->run_id();
  c.inputs = inputs_;
  c.sets = o_.sets;
  c.frames_total = frames_;
  c.threads = sc_.setup.threads;
  c.checkpoint_every = o_.checkpoint_every;
  c.render = o_.render;
  c.frame = done_;
  c.frame_digits = digits_;
  c.max_strain = max_strain_;
  c.mean_strain_sum = mean_strain_sum_;
  c.sim_ms = sim_ms_;
  c.logged_frames = log_ ? log_->entries() : 0;
  c.log_hash = log_ ? log_->hash() : 0;
  c.frames_hash = frames_hash_;
  c.frame_hashes = frame_hashes_;
  cloth::StateWriter w;
  sim_->save_state(w);
  c.state = w.data();
  write_checkpoint(*folder_, c);
}

// Frame 0 is written only when it is finite (NaN is never written); a resumed run replays the frames
// pc2/gltf/--render hold in memory from the log instead.
void SceneRun::start() {
  if (resume_) {
    max_strain_ = resume_->max_strain;
    mean_strain_sum_ = resume_->mean_strain_sum;
    sim_ms_ = resume_->sim_ms;
    if (log_)
      log_->replay(shown_->cloths(), [&](double time, int flags) {
        if (flags & 1) exports_->frame(time, shown_->cloths());
#ifdef LOOM_HAVE_RENDER
        if (recording_ && (flags & 2)) recording_->add(shown_->cloths());
#endif
      });
    shown_->update();  // the replayed frames left their positions in the shown cloths
    done_ = first_;
    return;
  }
  const cloth::FrameStats s0 = sim_->measure();
  finite_ = s0.finite && out_of_range_cloth(shown_->cloths()).empty();
  if (!finite_) {
    const std::string bad = non_finite_cloth(sim_->cloths());
    const std::string shown_bad = non_finite_cloth(shown_->cloths());
    error_ =
        !bad.empty() ? "cloth '" + bad + "' starts at a non-finite position"
        : !shown_bad.empty()
            ? "the detail surface of cloth '" + shown_bad + "' is not finite at the start (cloths[].detail)"
        : !out_of_range_cloth(shown_->cloths()).empty()
            ? "cloth '" + out_of_range_cloth(shown_->cloths()) +
                  "' starts beyond the coordinate bound (1e6 m): its mesh's origin, scale or translate (a "
                  "garment's scale, or the clip's pose) put it there"
            : "the start state's energy is not finite (an initial velocity, pin offset or anchor too large "
              "for double precision)";
    no_frame_written_ = true;
    error_ += "; stopped before frame 0, no frame written";
    // Only the energy is a matter of the scene's values and regime; the others are the start geometry's.
    if (bad.empty() && shown_bad.empty() && out_of_range_cloth(shown_->cloths()).empty())
      error_ += scene::divergence_suspects(sc_);
    return;
  }
  if (!run_census(first_)) {
    no_frame_written_ = true;
    return;
  }
  write_row(s0);
  write_bodies(0);
  if (obj_)
    frames_hash_ = write_obj(folder_->claim(frame_name(0)), shown_->cloths(), frames_hash_, frame_hashes_);
  keep_frame(true, true);
  // Frame 0 counts in the run's max_strain only when every pin starts at its vertex's rest position: a pin
  // anchored elsewhere puts its vertex at its target before any step, a stretch no solver made (the row of
  // stats.csv still shows it). docs/cli.md, summary.json.
  bool pins_at_rest = true;
  for (const auto& c : sim_->cloths())
    for (const cloth::Pin& p : c->pins())
      pins_at_rest = pins_at_rest && p.target(0.0) == c->mesh().rest_positions()[p.vertex];
  max_strain_ = pins_at_rest ? s0.max_strain : 0.0;
  done_ = first_;
}

bool SceneRun::stopped_non_finite(const cloth::FrameStats& s, int f) {
  const std::string valid = "; stopped, frames up to " + std::to_string(f - 1) + " are valid";
  if (!s.finite) {
    error_ = (sim_->failure().empty() ? "the state became non-finite in frame " + std::to_string(f) +
                                            " (t = " + std::to_string(s.time) + " s)"
                                      : sim_->failure()) +
             valid + scene::divergence_suspects(sc_);
    return true;
  }
#ifdef LOOM_HAVE_BULLET
  for (size_t k = 0; bodies_world_ && k < bodies_world_->num_bodies(); ++k)
    if (!bodies_world_->body_position(k).allFinite() || !bodies_world_->body_velocity(k).allFinite()) {
      error_ = "body '" + sc_.bodies[k].name + "' became non-finite in frame " + std::to_string(f) + valid +
               scene::divergence_suspects(sc_);
      return true;
    }
#endif
  shown_->update();
  if (const std::string bad = non_finite_cloth(shown_->cloths()); !bad.empty()) {  // NaN is never written
    error_ = "the shown surface of cloth '" + bad + "' became non-finite in frame " + std::to_string(f) +
             (sc_.detail.empty() ? "" : " (check cloths[].detail)") + valid;
    return true;
  }
  if (const std::string far = out_of_range_cloth(shown_->cloths()); !far.empty()) {
    error_ = "cloth '" + far +
             "' left the coordinate bound (a position beyond 1e6 m, more than the outputs hold) in frame " +
             std::to_string(f) + " (t = " + std::to_string(s.time) + " s)" + valid +
             scene::divergence_suspects(sc_);
    return true;
  }
  return false;
}

// Ctrl-C (SIGINT) stops the loop within the frame in progress (that frame is dropped, the state is the last
// frame written); the run then writes a checkpoint and valid outputs. A scene with rigid bodies stops within
// the frame too (the cloth within its step, the Bullet world's remaining substeps without cloth) and writes
// no checkpoint (the Bullet world is not saved); its outputs hold the frames before.
void SceneRun::step_frames() {
  ProgressBar bar(frames_);
  sim_->set_stop_flag(&g_interrupted);
  for (int f = first_ + 1; f <= frames_ && finite_; ++f) {
    if (g_interrupted) {
      interrupted_ = true;
      break;
    }
    const auto frame_start = std::chrono::steady_clock::now();
    const cloth::FrameStats s = pipeline_->step_frame();
    if (pipeline_->interrupted()) {
      interrupted_ = true;
      break;
    }
    sim_ms_ += s.total_ms;
    wall_ms_ +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - frame_start).count();
    ++stepped_;
    if (stopped_non_finite(s, f)) {
      finite_ = false;
      break;
    }
    if (!run_census(f)) break;
    write_row(s);
    write_bodies(f);
    if (obj_ && f % sc_.output.every == 0)
      frames_hash_ = write_obj(folder_->claim(frame_name(f)), shown_->cloths(), frames_hash_, frame_hashes_);
    if (s.max_strain > max_strain_) max_strain_ = s.max_strain, max_strain_frame_ = f;
    mean_strain_sum_ += s.mean_strain;
    done_ = f;
    bool rendered = false;
#ifdef LOOM_HAVE_RENDER
    rendered = f % sc_.output.render.every == 0;
#endif
    keep_frame(f % sc_.output.every == 0, rendered);
    if (o_.checkpoint_every > 0 && f % o_.checkpoint_every == 0 && f < frames_) save_checkpoint();
    bar.update(done_ - first_, sim_ms_ / std::max(1, done_ - first_));
  }
  if (g_interrupted) interrupted_ = done_ < frames_;
  sim_->set_stop_flag(nullptr);
  if (interrupted_ && resumable_) save_checkpoint();
  bar.finish();
}

void SceneRun::run() {
  // Ctrl-C is caught from here to the end of finish(): the simulation and the render phase stop cleanly.
  g_interrupted = 0;
  for (size_t k = 0; k < std::size(kStopSignals); ++k) {
    old_handlers_[k] = std::signal(kStopSignals[k], on_sigint);
    if (kStopSignals[k] != SIGINT && old_handlers_[k] == SIG_IGN) std::signal(kStopSignals[k], SIG_IGN);
  }
  start();
  if (finite_ && error_.empty()) step_frames();
  exports_->finish();
  // A run stopped before frame 0 wrote no frame: exports holding none are not left as if they were a run.
  if (no_frame_written_)
    for (const std::string& n : export_files_) folder_->remove_owned(n);
}

// An interrupted run renders when it is resumed and ends.
void SceneRun::render_video() {
#ifdef LOOM_HAVE_RENDER
  if (!recording_ || interrupted_) return;
  folder_->claim("render/");
  for (int f = 0; f < recording_->frames(); ++f) {
    char name[40];
    std::snprintf(name, sizeof name, "render/frame_%05d.png", f);
    folder_->claim(name);
  }
  folder_->claim("render.mp4");
  folder_->claim("render.gif");
  render::RenderSettings rs;
  rs.width = sc_.output.render.width;
  rs.height = sc_.output.render.height;
  if (sc_.output.render.camera)
    rs.camera = render::Camera{sc_.output.render.eye, sc_.output.render.target, sc_.output.render.fov};
  const double fps = 1.0 / (sc_.setup.frame_dt * sc_.output.render.every);
  remove_listed_frames("render", ".png", recording_->frames());  // an earlier run's later frames
  // A frame that cannot be drawn or written (a full disk, memory) ends the render like a failed encoding:
  // the simulation's outputs are whole and a checkpoint renders again.
  render::RenderReport rep;
  try {
    rep = render::render_recording(out_.string(), *recording_, rs, fps, &g_interrupted);
  } catch (const Error& e) {
    render_error_ = e.what();
  } catch (const std::bad_alloc&) {
    render_error_ = out_.string() + "/render: --render: out of memory while drawing the frames";
  }
  render_interrupted_ = rep.stopped || !render_error_.empty();
  // Ctrl-C reaches ffmpeg too (the terminal signals the whole process group): a failed encoding then is
  // the interruption, not an error.
  auto encode = [&](const std::vector<std::string>& args, const char* file) {
    if (render_interrupted_) return;
    try {
      eval::ffmpeg_video(*folder_, "render", fps, args, file, "--render", rep.frames);
    } catch (const Error& e) {
      // A failed encoding leaves the simulation's outputs whole: no video, a checkpoint to render again.
      if (!g_interrupted) render_error_ = e.what();
      render_interrupted_ = true;
    }
    if (g_interrupted) render_interrupted_ = true;
  };
  if (render_interrupted_ || g_interrupted) {
    render_interrupted_ = true;
    for (const char* v : {"render.mp4", "render.gif"}) folder_->remove_owned(v);
  } else if (rep.frames > 0) {
    // H.264 needs even sizes: pad by one pixel when the image is odd. The GIF: the first 4 s, 15 fps, 320 px.
    encode({"-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "20",
            "-movflags", "+faststart", "-f", "mp4"},
           "render.mp4");
    encode({"-t", "4", "-vf",
            "fps=15,scale=320:-1:flags=lanczos,split[a][b];[a]palettegen=max_colors=96[p];[b][p]"
            "paletteuse=dither=bayer:bayer_scale=4",
            "-loop", "0", "-f", "gif"},
           "render.gif");
    if (render_interrupted_)
      for (const char* v : {"render.mp4", "render.gif"}) folder_->remove_owned(v);
  }
  render_summary_ = {
      {"frames", rep.frames}, {"ms_per_frame", rep.ms_per_frame}, {"width", rs.width}, {"height", rs.height}};
  if (render_interrupted_) {
    render_summary_["interrupted"] = render_error_.empty();
    render_summary_["video"] = render_error_.empty() ? "not written" : "failed: " + render_error_;
    if (resumable_) save_checkpoint();  // the whole simulation: a resume renders it again without a step
    if (render_error_.empty())
      std::cout << "loom: rendering interrupted after " << rep.frames << " of " << recording_->frames()
                << " frames; render.mp4 and render.gif not written\n";
    return;
  }
  std::cout << "loom: rendered " << rep.frames << " frames (" << std::fixed << std::setprecision(1)
            << rep.ms_per_frame << " ms/frame) -> " << printable((out_ / "render").string()) << "/, "
            << printable((out_ / "render.mp4").string()) << ", " << printable((out_ / "render.gif").string())
            << "\n";
#endif
}

// The `unresolved` counter of the last body-contact stage of a step (the one with the last word on
// penetration): vertices it left inside a collider, a cloth pinched between colliders, summed over steps;
// -1 without such a stage.
double SceneRun::unresolved_contacts() const {
  double n = -1.0;
  for (const cloth::StageProfile& p : sim_->profile()) {
    if (p.name != "body_collision" && p.name != "realtime_contact" && p.name != "realtime_contact_final")
      continue;
    for (const auto& [k, v] : p.counters)
      if (k == "unresolved") n = v;
  }
  return n;
}

// The tier's strain limit (docs/scene-format.md, Quality) is held unless a frame ends with an edge above
// kStrainBreach times its limit: a few sweeps with contact after them leave strains of a few times the limit
// where pins and contacts pull hardest; five times the limit is a cloth the limit no longer holds.
bool SceneRun::tier_strain_held() const {
  constexpr double kStrainBreach = 5.0;  // 1, times the limit
  return !sc_.strain_limit_after_contact ||
         max_strain_ <= kStrainBreach * sc_.strain_limit_after_contact->max_stretch;
}

// summary.json: completed = every frame asked for was simulated; interrupted = stopped by Ctrl-C (resumable).
nlohmann::ordered_json SceneRun::summary() const {
  nlohmann::ordered_json j;
  j["scene"] = scene_abs_;
  j["frames"] = done_;
  j["sim_seconds"] = done_ * sc_.setup.frame_dt;
  j["wall_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start_).count();
  j["ms_per_frame"] = done_ ? sim_ms_ / done_ : 0.0;  // the cloth pipeline's stages
  // The whole frame's wall time: with a Bullet world's own step and the scene's work outside the stages.
  j["wall_ms_per_frame"] = stepped_ ? wall_ms_ / stepped_ : 0.0;
  nlohmann::ordered_json stages, per_frame, counters;
  for (const cloth::StageProfile& p : sim_->profile()) {
    stages[p.name] = p.total_ms;
    per_frame[p.name] = done_ ? p.total_ms / done_ : 0.0;
    nlohmann::ordered_json c = nlohmann::ordered_json::object();
    for (const auto& [k, v] : p.counters) c[k] = v;
    counters[p.name] = c;
  }
  j["stages"] = stages;
  j["stages_ms_per_frame"] = per_frame;
  j["counters"] = counters;
  j["max_strain"] = max_strain_;
  j["mean_strain"] = done_ ? mean_strain_sum_ / done_ : 0.0;
  j["finite"] = finite_;
  if (o_.census) {
    j["intersections"] = census_intersections_;
    j["max_penetration"] = census_penetration_;
  }
  // Vertices left inside a collider at a step's end (pinched between colliders), summed over steps.
  if (const double u = unresolved_contacts(); u >= 0.0) j["unresolved_contacts"] = u;
  if (sc_.strain_limit_after_contact) {  // the tier's strain limit: held, or where it broke
    nlohmann::ordered_json sl;
    sl["max_stretch"] = sc_.strain_limit_after_contact->max_stretch;
    sl["held"] = tier_strain_held();
    if (!tier_strain_held() && max_strain_frame_ > 0) sl["breach_frame"] = max_strain_frame_;
    j["tier_strain_limit"] = sl;
  }
  j["completed"] = error_.empty() && !interrupted_ && done_ == frames_;
  if (interrupted_) j["interrupted"] = true;
  if (resume_) j["resumed_from_frame"] = first_;
  j["rollbacks"] = sim_->rollbacks();
  j["quality"] = sc_.quality.name;
  j["solver"] = sim_->setup().solver.method;  // in a Bullet world: the solver the bridge's tier runs
  j["substeps"] = sim_->setup().substeps;  // the steps run per frame (the static solver: one, Simulation.h)
  j["dt"] = sim_->step_size();
#ifdef LOOM_HAVE_BULLET
  if (bodies_world_) {  // a Bullet world: the fewest cloth steps per frame and the longest step (adaptive)
    j["substeps"] = bodies_world_->min_cloth_steps_per_frame();
    j["dt"] = bodies_world_->frame_dt() / bodies_world_->min_cloth_steps_per_frame();
  }
#endif
  j["threads"] = sc_.setup.threads;
  int vertices = 0, triangles = 0;
  for (const auto& c : sim_->cloths()) {
    vertices += c->state().size();
    triangles += c->mesh().num_triangles();
  }
  j["vertices"] = vertices;
  j["triangles"] = triangles;
  if (!render_summary_.is_null()) j["render"] = render_summary_;
#ifdef LOOM_HAVE_BULLET
  if (bodies_world_) j["bullet_tier"] = bullet::tier_name(bodies_world_->options());
  if (bodies_world_) {  // the rigid bodies' end state; the trajectories are in bodies.csv
    nlohmann::ordered_json bj = nlohmann::ordered_json::array();
    for (size_t k = 0; k < bodies_world_->num_bodies(); ++k) {
      const cloth::Vec3 p = bodies_world_->body_position(k), v = bodies_world_->body_velocity(k);
      bj.push_back({{"name", sc_.bodies[k].name},
                    {"position", {p.x(), p.y(), p.z()}},
                    {"velocity", {v.x(), v.y(), v.z()}}});
    }
    j["bodies"] = bj;
    j["bodies_file"] = "bodies.csv";
    j["bullet_substeps"] = bodies_world_->bullet_substeps();
    j["cloth_steps"] = bodies_world_->cloth_steps();
    if (!bodies_world_->warnings().empty()) j["unsupported_shapes"] = bodies_world_->warnings();
  }
#endif
  if (!error_.empty()) j["error"] = error_;
  return j;
}

// What summary.json records of a tier guarantee not met, on the terminal too.
void SceneRun::print_warnings() const {
  const double unresolved = unresolved_contacts();
  if (unresolved > 0.0)
    std::cerr << "loom: warning: " << printable(scene_path_) << ": " << static_cast<long>(unresolved)
              << " vertex steps ended inside a collider (cloth pinched between colliders; summary.json: "
                 "unresolved_contacts)\n";
  if (!tier_strain_held()) {
    std::cerr << "loom: warning: " << printable(scene_path_) << ": the " << sc_.quality.name
              << " tier's strain limit (" << 100.0 * sc_.strain_limit_after_contact->max_stretch
              << " %) did not hold: max strain " << std::fixed << std::setprecision(1) << 100.0 * max_strain_
              << " %";
    if (max_strain_frame_ > 0) std::cerr << " at frame " << max_strain_frame_;
    std::cerr << std::defaultfloat << " (summary.json: tier_strain_limit)\n";
  }
}

int SceneRun::finish() {
  render_video();
  for (size_t k = 0; k < std::size(kStopSignals); ++k) std::signal(kStopSignals[k], old_handlers_[k]);
  csv_.close();
  if (!csv_) throw Error(stats_partial_.string(), "", csv_.write_failure());
  const fs::path stats = folder_->claim("stats.csv");
  rename_output(stats_partial_.string(), stats.string());
  write_atomically(folder_->claim("summary.json"), folder_->claim("summary.json.tmp"),
                   summary().dump(2) + "\n");
  if (o_.profile) print_profile(*sim_, done_);
  print_warnings();
  if (!error_.empty()) {
    std::cerr << "loom: error: " << printable(scene_path_) << ": " << printable(error_) << "\n";
    return 3;
  }
  if (!render_error_.empty()) {
    std::cerr << "loom: error: " << printable(render_error_)
              << "; the simulation is complete and its outputs are written, render.mp4 and render.gif are not"
              << (resumable_ ? "; render again with: loom run --resume " + printable(out_.string()) : "")
              << "\n";
    return 1;
  }
  if (render_interrupted_) {
    std::cerr << "loom: interrupted while rendering; the simulation is complete and its outputs are written"
              << (resumable_ ? "; render again with: loom run --resume " + printable(out_.string()) : "")
              << "\n";
    return interrupted_exit_code();
  }
  if (interrupted_) {
    std::cerr << "loom: interrupted after frame " << done_ << " of " << frames_
              << "; outputs so far are valid";
    if (!resumable_)
      std::cerr << " (a scene with rigid bodies cannot be resumed)\n";
    else
      std::cerr << "; continue with: loom run --resume " << printable(out_.string()) << "\n";
    return interrupted_exit_code();
  }
  std::cout << "loom: " << done_ << " frames of " << printable(sc_.name) << " in " << std::fixed
            << std::setprecision(2) << (done_ ? sim_ms_ / done_ : 0.0) << " ms/frame -> "
            << printable(out_.string()) << "\n";
  return 0;
}

}  // namespace

int run_command(const RunOptions& options) {
  SceneRun run(options);
  run.run();
  return run.finish();
}

}  // namespace loom::app
