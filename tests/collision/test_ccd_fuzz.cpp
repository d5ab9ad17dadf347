// Conservativeness of the CCD with a minimum separation, against exact distances at sampled times: whenever
// the primitives come within s at a sampled t, the test must report a hit with toi <= t. Lattice coordinates
// (multiples of 1/8 in [-1, 1]) make the sampled positions exact doubles and produce many degenerate
// (coplanar, parallel, touching) configurations.
#include <gtest/gtest.h>

#include <random>

#include "loom/collision/Ccd.h"
#include "loom/collision/Distance.h"

namespace lc = loom::collision;
using lc::Vec3;

namespace {

Vec3 lattice(std::mt19937_64& rng) {
  std::uniform_int_distribution<int> g(-8, 8);
  return Vec3(g(rng), g(rng), g(rng)) / 8.0;
}

}  // namespace

TEST(CcdFuzz, NeverMissesASampledContactWithinTheSeparation) {
  std::mt19937_64 rng(2024);
  const int kSamples = 32;  // t = i / 32: exact positions for lattice coordinates
  long sampled_contacts = 0, hits = 0, queries = 0;
  for (int it = 0; it < 3000; ++it) {
    Vec3 s[4], e[4];
    for (int i = 0; i < 4; ++i) s[i] = lattice(rng), e[i] = lattice(rng);
    const bool vf = it % 2 == 0;
    lc::CcdOptions o;
    o.min_separation = (it % 3) * 0.0625;  // 0, 1/16, 1/8
    const mpq_class s2 = mpq_class(o.min_separation) * mpq_class(o.min_separation);
    const lc::CcdResult r = vf ? lc::vertex_face_ccd(s[0], s[1], s[2], s[3], e[0], e[1], e[2], e[3], o)
                               : lc::edge_edge_ccd(s[0], s[1], s[2], s[3], e[0], e[1], e[2], e[3], o);
    ++queries;
    hits += r.hit;
    for (int k = 0; k <= kSamples; ++k) {
      const double t = static_cast<double>(k) / kSamples;
      Vec3 x[4];
      for (int i = 0; i < 4; ++i) x[i] = s[i] + t * (e[i] - s[i]);  // exact: 1/8 * 1/32 lattice
      const mpq_class d2 = vf ? lc::point_triangle_distance_squared_exact(x[0], x[1], x[2], x[3])
                              : lc::segment_segment_distance_squared_exact(x[0], x[1], x[2], x[3]);
      if (d2 <= s2) {
        ++sampled_contacts;
        ASSERT_TRUE(r.hit) << "query " << it << " misses a contact at t = " << t;
        EXPECT_LE(r.toi, t) << "query " << it;
        break;
      }
    }
  }
  EXPECT_GT(sampled_contacts, 300);  // the fuzz really produces contacts
  EXPECT_LT(hits, queries);          // and misses
}
