// loom-view under Xvfb (no real display): starts, plays 100 frames, saves a screenshot and exits cleanly;
// the screenshot has the asked window size and shows the (red) cloth.
#include <gtest/gtest.h>
#include <stb_image.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "TestDir.h"

namespace {

namespace fs = std::filesystem;

TEST(Viewer, XvfbRunsHundredFramesAndScreenshotShowsCloth) {
  const fs::path dir = loom::test::test_dir();
  fs::create_directories(dir);
  const fs::path shot = dir / "view.png";
  fs::remove(shot);
  const std::string cmd = std::string("xvfb-run -a -s '-screen 0 1024x768x24' ") + LOOM_VIEW_BINARY + " " +
                          LOOM_SOURCE_DIR + "/scenes/hanging_cloth.json --frames 100 --screenshot " +
                          shot.string() + " > " + (dir / "log.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  int w = 0, h = 0, n = 0;
  unsigned char* px = stbi_load(shot.string().c_str(), &w, &h, &n, 3);
  ASSERT_NE(px, nullptr);
  EXPECT_EQ(w, 960);
  EXPECT_EQ(h, 720);
  int cloth = 0;
  for (int i = 0; i < w * h; ++i) {
    const int r = px[3 * i], g = px[3 * i + 1], b = px[3 * i + 2];
    cloth += r > 30 && r > 1.8 * g && r > 1.8 * b;
  }
  stbi_image_free(px);
  EXPECT_GT(cloth, w * h / 40) << "the screenshot shows too little cloth";
}

// A scene with colliders: the screenshot shows the sphere collider (slate-teal) under the draped cloth.
TEST(Viewer, XvfbScreenshotShowsColliders) {
  const fs::path dir = loom::test::test_dir();
  fs::create_directories(dir);
  const fs::path shot = dir / "colliders.png";
  fs::remove(shot);
  const std::string cmd =
      std::string("xvfb-run -a -s '-screen 0 1024x768x24' ") + LOOM_VIEW_BINARY + " " + LOOM_SOURCE_DIR +
      "/scenes/sphere_spin.json --set cloths.0.mesh.nodes=[17,17] --frames 20 --screenshot " + shot.string() +
      " > " + (dir / "log_colliders.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  int w = 0, h = 0, n = 0;
  unsigned char* px = stbi_load(shot.string().c_str(), &w, &h, &n, 3);
  ASSERT_NE(px, nullptr);
  int collider = 0;
  for (int i = 0; i < w * h; ++i) {
    const int r = px[3 * i], g = px[3 * i + 1], b = px[3 * i + 2];
    collider += g > 1.4 * r && b > 1.3 * r && std::abs(g - b) < 30;
  }
  stbi_image_free(px);
  EXPECT_GT(collider, w * h / 200) << "the screenshot shows too little of the sphere collider";
}

// A scene with Bullet rigid bodies: loom-view runs it in a Bullet world and draws the box as a
// collider (slate-teal) on the red sheet. Only when built with the Bullet bridge.
#ifdef LOOM_HAVE_BULLET
TEST(Viewer, XvfbRunsBulletBodiesSceneAndShowsTheBox) {
  const fs::path dir = loom::test::test_dir();
  fs::create_directories(dir);
  const fs::path shot = dir / "bodies.png";
  fs::remove(shot);
  const std::string cmd =
      std::string("xvfb-run -a -s '-screen 0 1024x768x24' ") + LOOM_VIEW_BINARY + " " + LOOM_SOURCE_DIR +
      "/scenes/trampoline.json --set cloths.0.mesh.nodes=[11,11] --frames 20 --screenshot " + shot.string() +
      " > " + (dir / "log_bodies.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  int w = 0, h = 0, n = 0;
  unsigned char* px = stbi_load(shot.string().c_str(), &w, &h, &n, 3);
  ASSERT_NE(px, nullptr);
  int box = 0, cloth = 0;
  for (int i = 0; i < w * h; ++i) {
    const int r = px[3 * i], g = px[3 * i + 1], b = px[3 * i + 2];
    box += g > 1.4 * r && b > 1.3 * r && std::abs(g - b) < 30;
    cloth += r > 30 && r > 1.8 * g && r > 1.8 * b;
  }
  stbi_image_free(px);
  std::printf("box pixels %d, cloth pixels %d of %d\n", box, cloth, w * h);
  EXPECT_GT(box, w * h / 400) << "the screenshot shows too little of the box";
  EXPECT_GT(cloth, w * h / 40) << "the screenshot shows too little cloth";
}
#endif

}  // namespace
