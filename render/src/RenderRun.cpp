#include "loom/render/RenderRun.h"

#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "gl/ColliderShapes.h"
#include "loom/cloth/Error.h"

namespace loom::render {

namespace fs = std::filesystem;

std::vector<RenderMesh> render_meshes(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  static const cloth::Vec3 kColors[] = {
      {0.80, 0.22, 0.18}, {0.20, 0.42, 0.75}, {0.90, 0.68, 0.20}, {0.30, 0.62, 0.35}};
  std::vector<RenderMesh> meshes;
  for (size_t i = 0; i < cloths.size(); ++i) {
    RenderMesh m;
    m.triangles = cloths[i]->mesh().triangles();
    for (const auto& f : cloths[i]->mesh().triangle_frames()) m.corner_uv.push_back(f.rest_uv);
    m.color = kColors[i % 4];
    meshes.push_back(std::move(m));
  }
  return meshes;
}

void Recording::add(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  frames_.emplace_back();
  for (const auto& c : cloths) frames_.back().push_back(c->state().x);
  poses_.emplace_back();
  if (colliders_)
    for (const collision::Collider& c : *colliders_) poses_.back().push_back(c.curr);
}

collision::ColliderSet Recording::colliders(int f) const {
  collision::ColliderSet set;
  if (!colliders_) return set;
  set = *colliders_;
  for (size_t k = 0; k < set.size() && k < poses_[f].size(); ++k) set[k].curr = poses_[f][k];
  set.resize(std::min(set.size(), poses_[f].size()));
  return set;
}

Bounds Recording::bounds() const {
  Bounds b;
  for (const auto& f : frames_)
    for (const auto& x : f)
      for (const cloth::Vec3& p : x) b.add(p);
  for (int f = 0; f < frames(); ++f) gl::add_collider_bounds(b, colliders(f));
  return b;
}

Bounds Recording::action_bounds(int f) const {
  Bounds cloth;
  for (const auto& x : frames_[f])
    for (const cloth::Vec3& p : x) cloth.add(p);
  if (cloth.empty()) return cloth;
  const cloth::Vec3 reach = 0.5 * (cloth.hi - cloth.lo) + cloth::Vec3::Constant(0.05);
  Bounds b = cloth;
  for (const collision::Collider& c : colliders(f)) {
    Bounds one;
    gl::add_collider_bounds(one, collision::ColliderSet{c});
    if (one.empty()) continue;
    const bool near = (one.lo.array() <= (cloth.hi + reach).array()).all() &&
                      (one.hi.array() >= (cloth.lo - reach).array()).all();
    if (near) {
      b.add(one.lo);
      b.add(one.hi);
    }
  }
  return b;
}

namespace {

// Camera for a recording: the direction and field of view of auto_camera, at the largest distance any
// frame's action needs (no zoom pumping), looking at each frame's action centre smoothed over about
// 0.3 s (a critically damped follow would lag more; an unsmoothed one shakes with the cloth).
std::vector<cloth::Vec3> tracked_targets(const Recording& rec, double fps, double aspect, Bounds& widest) {
  std::vector<cloth::Vec3> targets;
  double distance = 0.0;
  const double alpha = 1.0 - std::exp(-1.0 / (0.3 * std::max(fps, 1.0)));
  for (int f = 0; f < rec.frames(); ++f) {
    const Bounds b = rec.action_bounds(f);
    if (b.empty()) {
      targets.push_back(targets.empty() ? cloth::Vec3::Zero() : targets.back());
      continue;
    }
    const cloth::Vec3 centre = 0.5 * (b.lo + b.hi);
    targets.push_back(targets.empty() ? centre : targets.back() + alpha * (centre - targets.back()));
    const Camera c = auto_camera(b, aspect);
    const double d = (c.eye - c.target).norm();
    if (d > distance) {
      distance = d;
      widest = b;
    }
  }
  return targets;
}

std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs `command` by /bin/sh as a child that gets SIGKILL when this process dies (PR_SET_PDEATHSIG, kept
// across exec), so a loom killed while ffmpeg works leaves no ffmpeg behind. Returns the child's exit status
// (-1 when it could not run or was killed).
int run_child(const std::string& command) {
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);  // the parent died before prctl took effect
    ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// ffmpeg writes `target` as a new file in a private folder (mode 0700, a name that did not exist: `staging`,
// or one made here by mkdtemp inside `out`), from which it is renamed into place: ffmpeg never opens a path
// where something could have been planted (a link it would follow, a FIFO it would block on). `args` ends
// with the output format option.
void run_ffmpeg(const fs::path& out, const std::string& staging, const std::string& args,
                const std::string& target) {
  std::string folder = staging;
  if (folder.empty()) {
    folder = (out / ".loom-ffmpeg-XXXXXX").string();
    if (!::mkdtemp(folder.data())) throw Error(out.string(), "--render", "cannot create a temporary folder");
  }
  const fs::path staged = fs::path(folder) / fs::path(target).filename();
  // exec: ffmpeg replaces the shell, so the death signal reaches ffmpeg itself.
  const std::string cmd = "exec ffmpeg -hide_banner -loglevel error -n " + args + " " +
                          quote(fs::absolute(staged).string()) + " </dev/null";
  const int status = run_child(cmd);
  std::error_code ec;
  const bool made = fs::is_regular_file(fs::symlink_status(staged, ec));
  if (status == 0 && made) fs::rename(staged, target, ec);
  const bool moved = status == 0 && made && !ec;
  if (staging.empty()) {
    fs::remove_all(folder, ec);
  } else if (!moved) {
    fs::remove(staged, ec);
  }
  if (!moved) throw Error(target, "--render", "ffmpeg failed (command: " + cmd.substr(5) + ")");
}

}  // namespace

RenderReport render_recording(const std::string& out_dir, const Recording& rec,
                              const RenderSettings& settings, double fps, bool video,
                              const std::string& staging) {
  const fs::path out(out_dir), dir = out / "render";
  std::error_code ec;  // the caller owns the folder and removes its earlier files (RenderRun.h)
  fs::create_directories(dir, ec);
  if (ec) throw Error(dir.string(), "--render", "cannot create folder: " + ec.message());

  const auto start = std::chrono::steady_clock::now();
  Renderer r(settings, rec.meshes());
  const collision::ColliderSet first = rec.frames() ? rec.colliders(0) : collision::ColliderSet{};
  Bounds widest;
  const std::vector<cloth::Vec3> targets =
      tracked_targets(rec, fps, double(settings.width) / settings.height, widest);
  if (widest.empty()) widest = rec.bounds();
  r.frame(widest, &first);
  for (int f = 0; f < rec.frames(); ++f) {
    r.look_at(targets[f]);
    std::vector<const cloth::Vec3s*> x;
    for (const auto& p : rec.positions()[f]) x.push_back(&p);
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.png", f);
    const collision::ColliderSet colliders = rec.colliders(f);
    write_png((dir / name).string(), r.render(x, &colliders));
  }
  RenderReport rep;
  rep.frames = rec.frames();
  rep.ms_per_frame =
      rec.frames()
          ? std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() /
                rec.frames()
          : 0.0;
  if (!video || rec.frames() == 0) return rep;

  if (std::system("command -v ffmpeg >/dev/null 2>&1") != 0)
    throw Error("ffmpeg", "--render",
                "ffmpeg not found (Debian package: ffmpeg); the PNG frames are in " + dir.string());
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.6g", fps);
  // ffmpeg reads the frames by a pattern in which '%' is special: a '%' of the folder's own path is doubled.
  std::string pattern;
  // Paths are absolute, so none starts with '-' (ffmpeg would read it as an option).
  for (char c : std::filesystem::absolute(dir).string())
    pattern += c == '%' ? std::string("%%") : std::string(1, c);
  const std::string input = std::string("-framerate ") + rate + " -i " + quote(pattern + "/frame_%05d.png");
  rep.mp4 = (out / "render.mp4").string();
  // H.264 needs even sizes: pad by one pixel when the image is odd.
  run_ffmpeg(out, staging,
             input +
                 " -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' -c:v libx264 -pix_fmt yuv420p -crf 20 "
                 "-movflags +faststart -f mp4",
             rep.mp4);
  rep.gif = (out / "render.gif").string();
  run_ffmpeg(out, staging,
             input +
                 " -t 4 -vf "
                 "'fps=15,scale=320:-1:flags=lanczos,split[a][b];[a]palettegen=max_colors=96[p];[b][p]"
                 "paletteuse=dither=bayer:bayer_scale=4' -loop 0 -f gif",
             rep.gif);
  return rep;
}

}  // namespace loom::render
