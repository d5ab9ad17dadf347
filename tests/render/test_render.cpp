// The offscreen renderer, headless (OSMesa software GL): image size as asked, not blank, cloth pixels
// exactly where the cloth projects, checks visible on the cloth, both sides lit, a shadow on the ground;
// `loom run --render` writes the PNGs, an MP4 whose frame count ffprobe reads, and a GIF.
#include <gtest/gtest.h>
#include <signal.h>
#include <stb_image.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "TestDir.h"
#include "loom/cloth/ClothMesh.h"
#include "loom/render/Renderer.h"

namespace loom::render {
namespace {

namespace fs = std::filesystem;
using cloth::Vec2;
using cloth::Vec3;

// Red cloth (any check, lit or not) against grey ground, grey shadow and blue sky.
bool is_cloth(const std::array<uint8_t, 3>& c) { return c[0] > 30 && c[0] > 1.8 * c[1] && c[0] > 1.8 * c[2]; }
int luminance(const std::array<uint8_t, 3>& c) { return (c[0] * 3 + c[1] * 6 + c[2]) / 10; }

// A flat 1 m square at height 1 m, centred over the origin.
struct Flat {
  std::shared_ptr<const cloth::ClothMesh> mesh;
  RenderMesh rm;
  Flat() {
    cloth::GridSpec g;
    g.nodes_u = g.nodes_v = 9;
    g.origin = Vec3(-0.5, 1.0, -0.5);
    mesh = cloth::ClothMesh::grid(g);
    rm.triangles = mesh->triangles();
    for (const auto& f : mesh->triangle_frames()) rm.corner_uv.push_back(f.rest_uv);
  }
};

Image render_flat(const Vec3& eye, Renderer** keep = nullptr, std::unique_ptr<Renderer>* owner = nullptr) {
  Flat f;
  RenderSettings s;
  s.width = 200;
  s.height = 150;
  s.camera = Camera{eye, Vec3(0, 1, 0), 40.0};
  auto r = std::make_unique<Renderer>(s, std::vector<RenderMesh>{f.rm});
  Bounds b;
  for (const Vec3& p : f.mesh->rest_positions()) b.add(p);
  r->frame(b);
  const Image img = r->render({&f.mesh->rest_positions()});
  if (keep && owner) {
    *keep = r.get();
    *owner = std::move(r);
  }
  return img;
}

TEST(Render, ClothPixelsWhereTheClothProjects) {
  Renderer* r = nullptr;
  std::unique_ptr<Renderer> owner;
  const Image img = render_flat(Vec3(0.3, 2.6, 2.2), &r, &owner);
  ASSERT_EQ(img.width, 200);
  ASSERT_EQ(img.height, 150);
  ASSERT_EQ(img.rgb.size(), 200u * 150u * 3u);
  // The projected square: its inside (shrunk by 10%) is cloth, a band outside it (grown by 25%) is not.
  int inside = 0, inside_cloth = 0, outside = 0, outside_cloth = 0, lo = 255, hi = 0;
  for (double u = -0.5; u <= 0.5; u += 0.05)
    for (double v = -0.5; v <= 0.5; v += 0.05) {
      for (double scale : {0.9, 1.25}) {
        if (scale > 1.0 && std::max(std::abs(u), std::abs(v)) < 0.45) continue;  // only the outer ring
        const Vec2 px = r->project(Vec3(scale * u, 1.0, scale * v));
        const int x = static_cast<int>(px.x()), y = static_cast<int>(px.y());
        ASSERT_TRUE(x >= 0 && y >= 0 && x < img.width && y < img.height)
            << "cloth not framed: " << x << "," << y;
        const auto c = img.at(x, y);
        if (scale < 1.0) {
          ++inside;
          inside_cloth += is_cloth(c);
          lo = std::min(lo, luminance(c));
          hi = std::max(hi, luminance(c));
        } else {
          ++outside;
          outside_cloth += is_cloth(c);
        }
      }
    }
  EXPECT_EQ(inside_cloth, inside);
  EXPECT_EQ(outside_cloth, 0) << "of " << outside;
  EXPECT_GT(hi - lo, 25) << "no warp/weft checks visible on the cloth";
  // Not blank, and the top rows are sky (blue above red/green).
  const auto sky = img.at(100, 2);
  EXPECT_GT(sky[2], sky[0]);
  EXPECT_FALSE(is_cloth(sky));
}

TEST(Render, BackSideIsLitAndShadowFallsOnTheGround) {
  Renderer* r = nullptr;
  std::unique_ptr<Renderer> owner;
  // From below (y = 0.1 < 1): the camera sees the cloth's other side, lit, not black.
  const Image below = render_flat(Vec3(0.2, 0.1, 1.3), &r, &owner);
  const Vec2 c = r->project(Vec3(0, 1, 0));
  int sum = 0, n = 0;  // mean over a window spanning several checks
  for (int dy = -6; dy <= 6; ++dy)
    for (int dx = -6; dx <= 6; ++dx) {
      const auto px = below.at(int(c.x()) + dx, int(c.y()) + dy);
      EXPECT_TRUE(is_cloth(px)) << int(px[0]) << "," << int(px[1]) << "," << int(px[2]);
      sum += px[0];
      ++n;
    }
  EXPECT_GT(sum / n, 60) << "the side facing away from the key light is too dark";

  // From above: the ground where the cloth's centre casts its shadow is darker than ground in the open.
  const Image above = render_flat(Vec3(0.3, 2.6, 2.2), &r, &owner);
  EXPECT_EQ(r->ground(), 0.0);
  const Vec3 to_light = Vec3(0.45, 1.0, 0.35).normalized();
  // A shadowed ground point not hidden by the cloth itself: under the cloth's corner nearest the light's
  // opposite side.
  const Vec3 corner(-0.2, 1.0, 0.45);
  const Vec3 shadow = corner - to_light * corner.y() / to_light.y();
  const Vec2 s = r->project(shadow), open = r->project(Vec3(0.8, 0.0, 0.2));
  for (const Vec2& p : {s, open})
    ASSERT_TRUE(p.x() >= 0 && p.y() >= 0 && p.x() < above.width && p.y() < above.height) << p.transpose();
  const auto sp = above.at(int(s.x()), int(s.y())), op = above.at(int(open.x()), int(open.y()));
  EXPECT_FALSE(is_cloth(sp));
  EXPECT_LT(luminance(sp), 0.8 * luminance(op))
      << "shadow " << luminance(sp) << " open ground " << luminance(op);
}

TEST(Render, LoomRunRenderWritesPngsVideoAndGif) {
  const fs::path out = loom::test::test_dir() / "run";
  fs::remove_all(out);
  const std::string cmd =
      std::string(LOOM_BINARY) + " run " + LOOM_SOURCE_DIR +
      "/scenes/hanging_cloth.json --frames 6 --render --out " + out.string() +
      " --set 'output={\"formats\": [], \"render\": {\"width\": 160, \"height\": 120}}' >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  for (int f = 0; f <= 6; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.png", f);
    int w = 0, h = 0, n = 0;
    unsigned char* data = stbi_load((out / "render" / name).string().c_str(), &w, &h, &n, 3);
    ASSERT_NE(data, nullptr) << name;
    EXPECT_EQ(w, 160);
    EXPECT_EQ(h, 120);
    int cloth = 0;
    for (int i = 0; i < w * h; ++i) cloth += is_cloth({data[3 * i], data[3 * i + 1], data[3 * i + 2]});
    EXPECT_GT(cloth, w * h / 50) << name << ": too few cloth pixels";
    stbi_image_free(data);
  }
  EXPECT_FALSE(fs::exists(out / "render" / "frame_00007.png"));
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00000.obj"));  // formats: [] writes no OBJ
  ASSERT_TRUE(fs::exists(out / "render.gif"));
  const fs::path count = out / "count.txt";
  const std::string probe =
      "ffprobe -v error -count_frames -select_streams v:0 -show_entries stream=nb_read_frames,width,height "
      "-of csv=p=0 " +
      (out / "render.mp4").string() + " > " + count.string();
  ASSERT_EQ(std::system(probe.c_str()), 0);
  std::FILE* fp = std::fopen(count.string().c_str(), "r");
  ASSERT_NE(fp, nullptr);
  int w = 0, h = 0, frames = 0;
  ASSERT_EQ(std::fscanf(fp, "%d,%d,%d", &w, &h, &frames), 3);
  std::fclose(fp);
  EXPECT_EQ(w, 160);
  EXPECT_EQ(h, 120);
  EXPECT_EQ(frames, 7);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int video_frames(const fs::path& out) {
  const fs::path count = out / "count.txt";
  const std::string probe =
      "ffprobe -v error -count_frames -select_streams v:0 -show_entries "
      "stream=nb_read_frames -of csv=p=0 " +
      (out / "render.mp4").string() + " > " + count.string();
  if (std::system(probe.c_str()) != 0) return -1;
  std::FILE* fp = std::fopen(count.string().c_str(), "r");
  int frames = -1;
  if (fp && std::fscanf(fp, "%d", &frames) != 1) frames = -1;
  if (fp) std::fclose(fp);
  fs::remove(count);
  return frames;
}

// The video holds exactly the frames the run rendered: PNGs of higher numbers in the folder (a foreign
// folder taken with --overwrite, a longer run resumed with fewer frames) never reach it, and a resume
// deletes the listed ones.
TEST(Render, TheVideoReadsOnlyTheRunsOwnFrames) {
  const fs::path dir = loom::test::test_dir(), out = dir / "run", foreign = dir / "foreign";
  fs::remove_all(out);
  fs::remove_all(foreign);
  const std::string run = std::string(LOOM_BINARY) + " run " + LOOM_SOURCE_DIR +
                          "/scenes/hanging_cloth.json --render --set 'output={\"formats\": [], \"render\": "
                          "{\"width\": 96, \"height\": 64}}' ";
  ASSERT_EQ(std::system(
                (run + "--frames 8 --checkpoint-every 4 --out " + out.string() + " >/dev/null 2>&1").c_str()),
            0);
  EXPECT_EQ(video_frames(out), 9);
  const std::string resume =
      std::string(LOOM_BINARY) + " run --resume " + out.string() + " --frames 5 >/dev/null 2>&1";
  ASSERT_EQ(std::system(resume.c_str()), 0);
  EXPECT_TRUE(fs::exists(out / "render" / "frame_00005.png"));
  for (const char* stale : {"frame_00006.png", "frame_00007.png", "frame_00008.png"})
    EXPECT_FALSE(fs::exists(out / "render" / stale)) << stale;
  EXPECT_EQ(video_frames(out), 6);

  fs::create_directories(foreign / "render");
  for (const char* name : {"frame_00004.png", "frame_00005.png", "frame_00006.png", "frame_00007.png"})
    fs::copy_file(out / "render" / "frame_00000.png", foreign / "render" / name);
  ASSERT_EQ(
      std::system((run + "--frames 3 --overwrite --out " + foreign.string() + " >/dev/null 2>&1").c_str()),
      0);
  EXPECT_EQ(video_frames(foreign), 4);
  EXPECT_TRUE(fs::exists(foreign / "render" / "frame_00007.png"));  // not the run's: never deleted
}

// Ctrl-C in the render phase (after the simulation): rendering stops between frames, the simulation's
// outputs and summary are written (completed, the render marked interrupted, no video), exit 130; a resume
// renders again without a step.
TEST(Render, CtrlCWhileRenderingWritesTheSimulationsOutputsAndNoVideo) {
  const fs::path dir = loom::test::test_dir(), out = dir / "run";
  fs::remove_all(out);
  const std::string log = (dir / "child.txt").string();
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    if (!freopen(log.c_str(), "w", stdout) || !freopen(log.c_str(), "a", stderr)) _exit(99);
    const std::string scene = std::string(LOOM_SOURCE_DIR) + "/scenes/hanging_cloth.json";
    execl(LOOM_BINARY, LOOM_BINARY, "run", scene.c_str(), "--frames", "150", "--render", "--out",
          out.string().c_str(), "--set", "cloths[0].mesh.nodes=[5,5]", "--set",
          "output={\"formats\": [\"pc2\"], \"render\": {\"width\": 160, \"height\": 120}}", (char*)nullptr);
    _exit(98);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(out / "render" / "frame_00002.png") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  kill(pid, SIGINT);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status)) << slurp(log);
  EXPECT_EQ(WEXITSTATUS(status), 130) << slurp(log);
  EXPECT_NE(slurp(log).find("interrupted while rendering"), std::string::npos);
  ASSERT_TRUE(fs::exists(out / "summary.json"));
  const auto j = nlohmann::json::parse(slurp(out / "summary.json"));
  EXPECT_TRUE(j["completed"].get<bool>());
  EXPECT_EQ(j["frames"], 150);
  EXPECT_TRUE(j["render"]["interrupted"].get<bool>());
  const int rendered = j["render"]["frames"];
  EXPECT_LT(rendered, 151);
  char next[32];
  std::snprintf(next, sizeof next, "frame_%05d.png", rendered);
  EXPECT_FALSE(fs::exists(out / "render" / next));
  EXPECT_TRUE(fs::exists(out / "stats.csv"));
  EXPECT_FALSE(fs::exists(out / "stats.csv.partial"));
  EXPECT_FALSE(fs::exists(out / "render.mp4"));
  EXPECT_TRUE(fs::exists(out / "pc2" / "sheet.pc2"));
  const std::string resume = std::string(LOOM_BINARY) + " run --resume " + out.string() + " >/dev/null 2>&1";
  ASSERT_EQ(std::system(resume.c_str()), 0);
  EXPECT_EQ(video_frames(out), 151);
}

}  // namespace
}  // namespace loom::render
