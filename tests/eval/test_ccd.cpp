// Conservative VF/EE CCD (loom/collision/Ccd.h) against the exact ground truth of the CCD sample queries
// (tests/data/ccd-sample-queries, MIT, Wang et al. 2021), unscaled and scaled by 2^k and translated.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "TestDir.h"
#include "loom/cloth/Error.h"
#include "loom/eval/CcdSampleQueries.h"

namespace lc = loom::collision;
namespace le = loom::eval;
using lc::Vec3;

namespace {

const std::vector<le::CcdQuery>& all_queries() {
  static const std::vector<le::CcdQuery> queries = [] {
    std::vector<std::string> files;
    for (const auto& e : std::filesystem::recursive_directory_iterator(LOOM_TEST_DATA "/ccd-sample-queries"))
      if (e.path().extension() == ".csv") files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    std::vector<le::CcdQuery> out;
    for (const auto& f : files) {
      auto q = le::read_ccd_queries(f);
      out.insert(out.end(), q.begin(), q.end());
    }
    return out;
  }();
  return queries;
}

}  // namespace

TEST(CcdSampleQueries, DataSetIsComplete) {
  const auto& q = all_queries();
  ASSERT_EQ(q.size(), 7279u);
  EXPECT_EQ(std::count_if(q.begin(), q.end(), [](const auto& x) { return x.vertex_face; }), 3085);
  EXPECT_EQ(std::count_if(q.begin(), q.end(), [](const auto& x) { return x.truth; }), 435);
}

TEST(CcdSampleQueries, NoFalseNegativesUnscaled) {
  const le::CcdEvalStats s = le::evaluate_ccd(all_queries());
  EXPECT_EQ(s.false_negatives, 0);
  EXPECT_EQ(s.positives, 435);
  // Fewer false positives is better; this bound only catches a collapse of the filter into "always hit".
  EXPECT_LT(s.false_positives, 700);
  std::cout << "[ measured ] false_positives=" << s.false_positives
            << " us_per_query=" << 1e6 * s.seconds / s.queries << " budget_exhausted=" << s.budget_exhausted
            << "\n";
}

// The impact zones run the test with a box budget (SelfCollisionStage::impact_zones: 4096 boxes): a query the
// budget cuts short must still come out a hit, never a miss. With that budget and with a budget so small that
// many queries run out of it, every true contact is still reported.
TEST(CcdSampleQueries, NoFalseNegativesWhenTheBoxBudgetRunsOut) {
  for (long budget : {4096L, 16L}) {
    lc::CcdOptions o;
    o.max_boxes = budget;
    o.toi_tolerance = 1e-2;
    o.toi_max_boxes = 32;
    const le::CcdEvalStats s = le::evaluate_ccd(all_queries(), o);
    EXPECT_EQ(s.false_negatives, 0) << "budget " << budget;
    EXPECT_EQ(s.positives, 435);
    if (budget == 16) {
      EXPECT_GT(s.budget_exhausted, 100) << "the small budget should cut queries short";
    }
    std::cout << "[ measured ] budget=" << budget << " false_positives=" << s.false_positives
              << " budget_exhausted=" << s.budget_exhausted << "\n";
  }
}

// Every coordinate times 2^k and translated (exactly, so the ground truth stays valid), every k in [-10, 10].
TEST(CcdSampleQueries, NoFalseNegativesScaledAndTranslated) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int k = -10; k <= 10; ++k) {
    std::vector<le::CcdQuery> qs = all_queries();
    long translated = 0;
    for (auto& q : qs) {
      const Vec3 offset = Vec3(unit(rng), unit(rng), unit(rng)) * 5.0 * std::ldexp(1.0, k);
      translated += le::scale_translate_exactly(q, k, offset).norm() > 0;
    }
    EXPECT_GT(translated, static_cast<long>(qs.size()) / 2) << "k=" << k;  // the translation is not vacuous
    const le::CcdEvalStats s = le::evaluate_ccd(qs);
    EXPECT_EQ(s.false_negatives, 0) << "k=" << k;
    std::cout << "[ measured ] k=" << k << " false_positives=" << s.false_positives
              << " us_per_query=" << 1e6 * s.seconds / s.queries << "\n";
  }
}

TEST(CcdSampleQueries, ScaleTranslateKeepsCoordinatesExact) {
  le::CcdQuery q;
  q.points.fill(Vec3(0.1, 1.0 / 3.0, 3.0));
  q.points[4] = Vec3(0x1p-60, -2.5, 0.0);
  le::CcdQuery s = q;
  const Vec3 t = le::scale_translate_exactly(s, -3, Vec3(7.3, -0.4, 1e30));
  for (int i = 0; i < 8; ++i)
    for (int a = 0; a < 3; ++a) EXPECT_EQ(s.points[i][a] - t[a], std::ldexp(q.points[i][a], -3));
}

TEST(CcdSampleQueries, ReaderErrorsNameFileAndLine) {
  const std::string dir = (loom::test::test_dir() / "vertex-face").string();
  std::filesystem::create_directories(dir);
  const std::string f = dir + "/bad.csv";
  {
    std::ofstream o(f);
    for (int i = 0; i < 3; ++i) o << "0,1,1,1,0,1,0\n";
    o << "1,3,0,1,0,1,0\n";  // 1/3 is not a double
  }
  try {
    le::read_ccd_queries(f);
    FAIL() << "expected loom::Error";
  } catch (const loom::Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv: line 4"), std::string::npos) << e.what();
  }
  EXPECT_THROW(le::read_ccd_queries((loom::test::test_dir() / "no-type.csv").string()), loom::Error);
}

// A vertex falling through the centre of a triangle: FCL's mesh CCD misses this at 1 mm scale.
TEST(Ccd, VertexThroughTriangleAtEveryScale) {
  for (int k = -40; k <= 20; k += 5) {
    const double s = std::ldexp(1.0, k);
    const Vec3 a(0, 0, 0), b(s, 0, 0), c(0, s, 0), p0(s / 4, s / 4, s / 2), p1(s / 4, s / 4, -s / 2);
    const lc::CcdResult r = lc::vertex_face_ccd(p0, a, b, c, p1, a, b, c);
    EXPECT_TRUE(r.hit) << "k=" << k;
    EXPECT_LE(r.toi, 0.5) << "k=" << k;  // the true contact time is 0.5; toi is a lower bound
    EXPECT_GT(r.toi, 0.49) << "k=" << k;
    // Shifted beside the triangle, the same motion misses.
    EXPECT_FALSE(lc::vertex_face_ccd(p0 + Vec3(2 * s, 0, 0), a, b, c, p1 + Vec3(2 * s, 0, 0), a, b, c).hit);
  }
}

TEST(Ccd, MinimumSeparation) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  // The vertex passes 0.01 above the triangle, parallel to it.
  const Vec3 p0(-1, 0.2, 0.01), p1(2, 0.2, 0.01);
  lc::CcdOptions o;
  EXPECT_FALSE(lc::vertex_face_ccd(p0, a, b, c, p1, a, b, c, o).hit);
  o.min_separation = 0.02;
  const lc::CcdResult r = lc::vertex_face_ccd(p0, a, b, c, p1, a, b, c, o);
  EXPECT_TRUE(r.hit);
  EXPECT_LE(r.toi, 1.0 / 3.0);  // enters the triangle's footprint at t = 1/3
  o.min_separation = 0.005;
  EXPECT_FALSE(lc::vertex_face_ccd(p0, a, b, c, p1, a, b, c, o).hit);
  // Two crossing edges 0.01 apart in z, not moving.
  const Vec3 e0(-1, 0, 0), e1(1, 0, 0), f0(0, -1, 0.01), f1(0, 1, 0.01);
  o.min_separation = 0;
  EXPECT_FALSE(lc::edge_edge_ccd(e0, e1, f0, f1, e0, e1, f0, f1, o).hit);
  o.min_separation = 0.0101;
  EXPECT_TRUE(lc::edge_edge_ccd(e0, e1, f0, f1, e0, e1, f0, f1, o).hit);
}

TEST(Ccd, CoplanarSlidingEdgesTouch) {
  // Both edges in the plane z = 0 all the time; they cross at t = 0.5 exactly (degenerate cubic).
  const Vec3 a0(0, 0, 0), a1(1, 0, 0);
  const Vec3 b0s(0.5, 1, 0), b1s(0.5, 2, 0), b0e(0.5, -1, 0), b1e(0.5, 0, 0);
  const lc::CcdResult r = lc::edge_edge_ccd(a0, a1, b0s, b1s, a0, a1, b0e, b1e);
  EXPECT_TRUE(r.hit);
  EXPECT_LE(r.toi, 0.5);
  // The same edges 1e-3 apart in z never touch.
  const Vec3 dz(0, 0, 1e-3);
  EXPECT_FALSE(lc::edge_edge_ccd(a0, a1, b0s + dz, b1s + dz, a0, a1, b0e + dz, b1e + dz).hit);
}
