// `loom run` with hybrid detail: OBJ frames and pc2 exports carry the curved-face surface (65 x 65
// vertices for a 17 x 17 coarse grid at 2 levels), which passes through the simulated coarse vertices; the
// weil example scene runs and writes its one frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "CliRunner.h"

namespace {

namespace fs = std::filesystem;

std::vector<std::array<double, 3>> obj_vertices(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::array<double, 3>> v;
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("v ", 0) == 0) {
      std::istringstream s(line.substr(2));
      std::array<double, 3> a{};
      s >> a[0] >> a[1] >> a[2];
      v.push_back(a);
    }
  return v;
}

const std::string kScenes = std::string("run ") + LOOM_SOURCE_DIR + "/scenes/";

TEST(DetailCli, FramesCarryTheRefinedSurface) {
  const fs::path dir = loom::test::test_dir();
  const fs::path out = dir / "detail";
  fs::remove_all(out);
  const auto r = loom::test::run_loom(kScenes + "hanging_cloth_detail.json --frames 5 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto f0 = obj_vertices(out / "frames" / "frame_00000.obj");
  const auto f5 = obj_vertices(out / "frames" / "frame_00005.obj");
  EXPECT_EQ(f0.size(), 65u * 65u);
  ASSERT_EQ(f5.size(), 65u * 65u);
  // The first 17 x 17 fine vertices are the coarse ones: frame 0 is the flat start grid, so coarse node
  // (iu, iv) sits at (-0.5 + iu / 16, 1.5, -0.5 + iv / 16).
  for (int i = 0; i < 17 * 17; ++i) {
    EXPECT_NEAR(f0[i][0], -0.5 + (i % 17) / 16.0, 1e-9);
    EXPECT_NEAR(f0[i][1], 1.5, 1e-9);
    EXPECT_NEAR(f0[i][2], -0.5 + (i / 17) / 16.0, 1e-9);
  }
  // The sheet fell in 5 frames; the pinned corner (coarse vertex 0) did not.
  double lowest = 1e9;
  for (const auto& p : f5) lowest = std::min(lowest, p[1]);
  EXPECT_LT(lowest, 1.5 - 0.01);
  EXPECT_NEAR(f5[0][1], 1.5, 1e-12);
  std::ifstream obj(out / "frames" / "frame_00005.obj");
  int faces = 0;
  std::string line;
  while (std::getline(obj, line)) faces += line.rfind("f ", 0) == 0;
  EXPECT_EQ(faces, 2 * 16 * 16 * 16);  // 512 coarse triangles x 4²
}

TEST(DetailCli, WrinklesDisplaceTheRefinedSurfaceAndBadValuesAreRefused) {
  // The same run with and without geometric wrinkles: the same coarse simulation, so the frames differ only
  // by the wrinkle displacement, which is small (at most the amplitude) and present where the hanging sheet
  // is compressed (along its top edge, between the pinned corners).
  const fs::path dir = loom::test::test_dir();
  const fs::path plain = dir / "detail_plain", wr = dir / "detail_wrinkles";
  fs::remove_all(plain);
  fs::remove_all(wr);
  ASSERT_EQ(
      loom::test::run_loom(kScenes + "hanging_cloth_detail.json --frames 30 --out " + plain.string()).code,
      0);
  const auto r =
      loom::test::run_loom(kScenes + "hanging_cloth_detail.json --frames 30 --out " + wr.string() +
                           " --set 'cloths[0].detail.wrinkles={\"amplitude\":0.01,\"wavelength\":0.05}'");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto a = obj_vertices(plain / "frames" / "frame_00030.obj");
  const auto b = obj_vertices(wr / "frames" / "frame_00030.obj");
  ASSERT_EQ(a.size(), b.size());
  double largest = 0.0;
  for (size_t i = 0; i < a.size(); ++i)
    largest = std::max(largest, std::hypot(a[i][0] - b[i][0], a[i][1] - b[i][1], a[i][2] - b[i][2]));
  EXPECT_GT(largest, 1e-3);
  EXPECT_LE(largest, 0.01 + 1e-9);
  const auto bad =
      loom::test::run_loom(kScenes + "hanging_cloth_detail.json --frames 1 --out " + wr.string() +
                           " --set 'cloths[0].detail.wrinkles={\"wavelength\":0}'");
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.err.find("cloths[0].detail.wrinkles.wavelength"), std::string::npos) << bad.err;
}

TEST(DetailCli, WeilSceneWritesItsShape) {
  const fs::path out = loom::test::test_dir() / "weil";
  fs::remove_all(out);
  const auto r = loom::test::run_loom(kScenes + "weil_square.json --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto f1 = obj_vertices(out / "frames" / "frame_00001.obj");
  ASSERT_EQ(f1.size(), 33u * 33u);
  EXPECT_LT(f1[16 * 33 + 16][1], 1.5 - 0.1);  // the centre hangs
  const auto bad = loom::test::run_loom(kScenes + "weil_square.json --set duration=1 --out " + out.string());
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.err.find("duration"), std::string::npos) << bad.err;
}

}  // namespace
