// `loom body`: a body mesh fitted to a mocap skeleton, with a skinned cape (BodyCommand.h).
#include "BodyCommand.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "CliValue.h"
#include "loom/characters/BodyFit.h"
#include "loom/characters/GarmentInstance.h"
#include "loom/cloth/Error.h"
#include "loom/collision/Distance.h"
#include "loom/eval/OutputFolder.h"
#include "loom/scene/SceneLimits.h"
#ifdef LOOM_HAVE_RENDER
#include "loom/render/Renderer.h"
#endif

namespace loom::app {
namespace {

namespace ch = loom::characters;

const char* kBodyUsage =
    "Usage: loom body MESH CLIP.bvh [--seconds S] [--image FILE.png]\n"
    "\n"
    "Fits MESH (its first mesh: a static human body standing upright, facing +z, in an A-pose, e.g.\n"
    "tests/data/body/human.zae) to the skeleton of CLIP and skins it with automatic weights, puts a cape on\n"
    "its back (skinned at the shoulders, free at the hem: max distance 0 to 0.3 m, a backstop 1 cm behind),\n"
    "colliding with capsules fitted to the body (5 mm contact thickness) that move with the clip, plays the\n"
    "clip for S seconds at 30 frames per second and prints one line:\n"
    "  vertices=V joints=J frames=N cape_vertices=C worst_over_max_distance=D worst_behind_backstop=B\n"
    "  hem_motion=H deepest_in_body_capsules=P (m; P: the cape's deepest vertex inside a capsule, 0 if "
    "none)\n"
    "\n"
    "Options:\n"
    "  --seconds S      clip time to play (s; default 3, at most the clip's length)\n"
    "  --image FILE.png render the last frame (body and cape, seen from behind) into FILE.png\n"
    "  -h, --help       this text\n";

// --image FILE: checked before the clip runs. Refused by name: a symbolic link (never written through),
// anything but a regular file (a device such as /dev/full, a FIFO, a folder), a file another name shares (a
// hard link), an input of this run (by device and inode), a folder that does not exist.
void check_image_path(const std::string& image, const std::vector<std::string>& inputs) {
  struct stat st;
  if (::lstat(image.c_str(), &st) == 0) {
    if (S_ISLNK(st.st_mode))
      throw Error(image, "--image", "is a symbolic link: loom body never writes through a link");
    if (!S_ISREG(st.st_mode))
      throw Error(image, "--image", "is not a regular file (a folder, device or FIFO): give a PNG file path");
    if (st.st_nlink > 1)
      throw Error(image, "--image",
                  "is a hard link (other names share this file): writing it would change them too");
    for (const std::string& in : inputs) {
      struct stat is;
      if (::stat(in.c_str(), &is) == 0 && is.st_dev == st.st_dev && is.st_ino == st.st_ino)
        throw Error(image, "--image", "is the input " + in + ": writing the image would destroy it");
    }
  } else if (errno != ENOENT) {
    throw Error(image, "--image", std::string("cannot be written: ") + std::strerror(errno));
  }
  std::string parent =
      image.substr(0, image.find_last_of('/') == std::string::npos ? 0 : image.find_last_of('/') + 1);
  if (parent.empty()) parent = ".";
  if (::stat(parent.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    // A folder reached through a symbolic link whose target is missing: named, with the link's target.
    for (std::size_t end = parent.find('/', 1);; end = parent.find('/', end + 1)) {
      const std::string prefix = parent.substr(0, end);
      struct stat ls, ts;
      if (::lstat(prefix.c_str(), &ls) == 0 && S_ISLNK(ls.st_mode) && ::stat(prefix.c_str(), &ts) != 0) {
        char target[4096];
        const ssize_t n = ::readlink(prefix.c_str(), target, sizeof target - 1);
        throw Error(image, "--image",
                    "its folder is reached through the symbolic link " + printable(prefix) + " to '" +
                        printable(std::string(target, n > 0 ? static_cast<std::size_t>(n) : 0)) +
                        "', which does not exist (a relative target is read from the link's folder)");
      }
      if (end == std::string::npos) break;
    }
    throw Error(image, "--image", "its folder does not exist");
  }
}

// Writes `bytes` to `path` through a new temporary file (O_EXCL | O_NOFOLLOW, never an existing file or a
// link) and a rename, so `path` is whole or untouched; every failed write or close is an error.
[[maybe_unused]] void write_file_replacing(const std::string& path, const std::string& bytes) {
  const std::string tmp = path + ".tmp" + std::to_string(::getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) throw Error(tmp, "--image", std::string("cannot create: ") + std::strerror(errno));
  size_t done = 0;
  int err = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      err = n < 0 ? errno : EIO;
      break;
    }
    done += static_cast<size_t>(n);
  }
  if (::close(fd) != 0 && !err) err = errno;
  if (!err && ::rename(tmp.c_str(), path.c_str()) != 0) err = errno;
  if (err) {
    ::unlink(tmp.c_str());
    throw Error(path, "--image", std::string("write failed: ") + std::strerror(err));
  }
}

// True when `path`'s first bytes are a BVH file's ("HIERARCHY"), or its name ends in ".bvh" (any case).
bool looks_like_bvh(const std::string& path) {
  std::string lower = path;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (lower.size() >= 4 && lower.compare(lower.size() - 4, 4, ".bvh") == 0) return true;
  char head[16] = {};
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return false;
  struct stat st;
  const bool regular = ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode);
  const ssize_t n = regular ? ::read(fd, head, sizeof head - 1) : 0;
  ::close(fd);
  std::string text(head, n > 0 ? static_cast<size_t>(n) : 0);
  const std::size_t start = text.find_first_not_of(" \t\r\n\xef\xbb\xbf");
  return start != std::string::npos && text.compare(start, 9, "HIERARCHY") == 0;
}

// MESH and CLIP.bvh given the other way round (`loom body clip.bvh mesh.zae`) would fail deep in the
// mesh reader with a message about the wrong file: refused here, by the operands' order (exit 2).
void check_file_order(const std::string& mesh, const std::string& clip) {
  if (looks_like_bvh(mesh) && !looks_like_bvh(clip)) {
    std::fprintf(stderr,
                 "loom: error: body: the operands are swapped: '%s' is a BVH clip and '%s' is not; give "
                 "MESH first, then CLIP.bvh (loom body %s %s)\n",
                 printable(mesh).c_str(), printable(clip).c_str(), printable(clip).c_str(),
                 printable(mesh).c_str());
    std::exit(2);
  }
  if (looks_like_bvh(mesh)) {
    std::fprintf(stderr,
                 "loom: error: body: MESH '%s' is a BVH clip, not a body mesh: give a skinned mesh (glTF, "
                 "COLLADA, FBX, ...) first, then CLIP.bvh\n",
                 printable(mesh).c_str());
    std::exit(2);
  }
}

}  // namespace

constexpr double kBodyFps = 30.0;  // frames per second the clip is played at

int body_main(int argc, char** argv) {
  std::vector<std::string> files;
  double seconds = 3.0;
  std::string image;
  CliArgs args(argc, argv, 2, "body");
  while (args.next()) {
    const std::string a = args.arg();
    if (args.operand()) {
      if (files.size() == 2)
        args.fail("body", "a third file '" + printable(a) +
                              "': loom body takes MESH and CLIP.bvh only (given '" + printable(files[0]) +
                              "', '" + printable(files[1]) + "')");
      files.push_back(cli_path(files.empty() ? "MESH" : "CLIP.bvh", a));
    } else if (a == "-h" || a == "--help") {
      std::cout << kBodyUsage;
      return 0;
    } else if (a == "--seconds") {
      seconds = cli_number(a, args.value(), 1.0 / 30.0, 3600.0);  // at least one frame at 30 fps
    } else if (a == "--image") {
      image = cli_path(a, args.value());
    } else {
      args.unknown();
    }
  }
  if (files.size() != 2) {
    std::fprintf(stderr, "loom: error: body needs MESH and CLIP.bvh (%s given; see loom body --help)\n",
                 files.empty() ? "none" : "only MESH");
    return 2;
  }
  check_file_order(files[0], files[1]);
#ifndef LOOM_HAVE_RENDER
  if (!image.empty()) throw Error("--image", "", "this build has no renderer (OSMesa)");
#endif
  // What reading the mesh and the clip holds, against the memory, before anything is read or written.
  {
    const ch::MemoryEstimate mesh = ch::estimate_import_memory(files[0]);
    const ch::MemoryEstimate clip = ch::estimate_clip_memory(files[1]);
    scene::check_memory(files[1], "CLIP", mesh.bytes + clip.bytes,
                        "reading the mesh (" + mesh.basis + ") and the clip (" + clip.basis + ") needs",
                        "use a shorter clip or a smaller mesh");
  }
  const ch::Motion motion = ch::Motion::load(files[1]);
  // The clip plays at 30 frames per second: a clip shorter than one frame plays nothing to measure.
  if (motion.duration() * kBodyFps + 1e-9 < 1.0)
    throw Error(files[1], "CLIP",
                "lasts " + cli_show(motion.duration()) +
                    " s, less than one frame at 30 frames per second: nothing to play");
  // The image's folder and those above it are locked (shared) for the command (eval::FolderLock): a folder
  // another loom command is using (a run's output folder), or one inside it, is refused, so the PNG never
  // lands among that run's files.
  std::shared_ptr<eval::FolderLock> image_folder_lock;
  if (!image.empty()) {
    std::vector<std::string> inputs = files;
    inputs.insert(inputs.end(), motion.files().begin(), motion.files().end());
    check_image_path(image, inputs);
    const std::size_t slash = image.find_last_of('/');
    image_folder_lock = eval::FolderLock::acquire(slash == std::string::npos ? std::string(".")
                                                  : slash == 0               ? std::string("/")
                                                                             : image.substr(0, slash),
                                                  "--image", /*exclusive=*/false);
  }
  const ch::BodyFit fit = ch::fit_body(ch::load_static_mesh(files[0], 0), motion);
  const ch::BackCape cape = ch::make_back_cape(fit, motion);
  ch::GarmentSettings settings;
  settings.constraints.max_distance = cape.max_distance;
  settings.constraints.backstop_distance.assign(cape.positions.size(), 0.01);
  settings.material.bend_weft = settings.material.bend_warp = 1e-4;  // a coat fabric
  settings.material.damping = 0.05;

  const std::vector<int> joint_of_bone = ch::match_bones(fit.body.skin, motion, files[0]);
  std::vector<ch::Transform> joints;
  std::vector<ch::Affine> bones, matrices;
  auto pose_at = [&](double t) {
    motion.pose(t, joints);
    ch::pose_from_motion(joint_of_bone, joints, bones);
    return bones;
  };
  ch::GarmentInstance garment(cape.positions, cape.triangles, cape.skin, settings, pose_at(0.0), "cape");
  // The body's fitted capsules, moving with the clip, collide with the cape after its constraints.
  collision::RealtimeContactSettings contact;
  contact.thickness = 0.005;
  garment.set_colliders(ch::body_colliders(fit, motion), contact);
  const ch::CapsuleRig rig = ch::CapsuleRig::build(motion, ch::body_capsule_radii(fit, motion));
  const double fps = kBodyFps, end = std::min(seconds, motion.duration());
  const int frames = static_cast<int>(std::floor(end * fps + 1e-9));
  double worst_over = 0.0, worst_behind = 0.0, hem = 0.0, deepest = 0.0;
  for (int f = 1; f <= frames; ++f) {
    garment.set_pose(pose_at(f / fps));
    garment.step(1.0 / fps);
    const cloth::Vec3s& x = garment.positions();
    motion.pose(garment.time(), joints);
    for (const cloth::Vec3& p : x)
      for (const ch::Bone& b : rig.bones())
        deepest =
            std::max(deepest, b.radius - collision::point_segment_distance(p, joints[b.joint].translation(),
                                                                           joints[b.child].translation()));
    for (int i = 0; i < garment.num_vertices(); ++i) {
      if (!x[i].allFinite())
        throw Error(
            files[1], "cape positions",
            "not finite at frame " + std::to_string(f) + " of the clip (with the body " + files[0] + ")");
      const double d = (x[i] - garment.targets()[i]).norm();
      worst_over = std::max(worst_over, d - cape.max_distance[i]);
      worst_behind = std::max(worst_behind, garment.constraints().backstop_depth(
                                                i, x[i], garment.targets()[i], garment.target_normals()[i]));
      if (i >= (cape.rows - 1) * cape.columns) hem = std::max(hem, d);
    }
  }
  std::printf(
      "vertices=%zu joints=%d frames=%d cape_vertices=%d worst_over_max_distance=%.3g "
      "worst_behind_backstop=%.3g hem_motion=%.3f deepest_in_body_capsules=%.4f\n",
      fit.body.positions.size(), motion.num_joints(), frames, garment.num_vertices(), worst_over,
      worst_behind, hem, deepest);
#ifdef LOOM_HAVE_RENDER
  if (!image.empty()) {
    fit.body.skin.skinning_matrices(pose_at(frames / fps), matrices);
    cloth::Vec3s body;
    fit.body.skin.apply(matrices, fit.body.positions, body);
    render::Bounds b;
    for (const auto& p : body) b.add(p);
    for (const auto& p : garment.positions()) b.add(p);
    render::RenderSettings rs;
    render::Camera cam;
    cam.target = 0.5 * (b.lo + b.hi);
    const double size = (b.hi - b.lo).norm();
    cam.fov_deg = 35.0;
    cam.eye = cam.target + 1.4 * size * cloth::Vec3(0.55, 0.2, -1.0).normalized();  // behind, to the right
    rs.camera = cam;
    render::RenderMesh body_mesh, cape_mesh;
    body_mesh.triangles = fit.body.triangles;
    body_mesh.color = cloth::Vec3(0.82, 0.64, 0.52);
    cape_mesh.triangles = cape.triangles;
    cape_mesh.color = cloth::Vec3(0.20, 0.30, 0.70);
    render::Renderer renderer(rs, {body_mesh, cape_mesh});
    renderer.frame(b);
    write_file_replacing(image, render::encode_png(renderer.render({&body, &garment.positions()})));
  }
#endif
  return 0;
}

}  // namespace loom::app
