#pragma once
// The CCD sample-query format of Wang et al. 2021 ("A Large-Scale Benchmark and an Inclusion-Based Algorithm
// for Continuous Collision Detection"; data: github.com/Continuous-Collision-Detection/Sample-Queries, MIT).
// A CSV file holds 8 rows per query, 7 integer columns per row: x_num,x_den,y_num,y_den,z_num,z_den,truth.
// VF rows: v_t0, f0_t0, f1_t0, f2_t0, v_t1, f0_t1, f1_t1, f2_t1. EE rows: ea0_t0, ea1_t0, eb0_t0, eb1_t0,
// ea0_t1, ea1_t1, eb0_t1, eb1_t1. The query type is not in the file: it comes from the path, which contains
// `vertex-face` or `edge-edge`. Rationals are read exactly (GMP mpq) and must be doubles exactly.
#include <array>
#include <string>
#include <vector>

#include "loom/collision/Ccd.h"

namespace loom::eval {
using namespace loom::collision;

struct CcdQuery {
  bool vertex_face = true;     // else edge-edge
  std::array<Vec3, 8> points;  // m; in the row order above
  bool truth = false;          // ground truth: the primitives touch at some t in [0, 1]
  int line = 0;                // first CSV line of the query (1-based)
  std::string file;            // the CSV file it was read from
};

// Throws loom::Error(file, "line N", problem) for unreadable files, malformed rows, zero denominators,
// non-dyadic or out-of-range rationals (not exactly a double), truth columns that disagree within a query.
std::vector<CcdQuery> read_ccd_queries(const std::string& path);

// The same query with every coordinate multiplied by 2^k (exact) and then translated by about
// `offset` (m, per axis): the translation is rounded to a multiple of the coordinates' granularity and halved
// until every sum is exact, so the ground truth is unchanged. Returns the translation actually applied. A
// coordinate that 2^k takes past double range (or below its precision) throws loom::Error naming the query's
// file and line and the option.
Vec3 scale_translate_exactly(CcdQuery& query, int k, const Vec3& offset);

struct CcdEvalStats {
  long queries = 0;
  long positives = 0;         // ground-truth positives
  long false_negatives = 0;   // truth 1, reported 0
  long false_positives = 0;   // truth 0, reported 1
  long budget_exhausted = 0;  // hits reported because the box budget ran out
  double seconds = 0;         // s; wall time spent in the CCD calls only
};

CcdEvalStats evaluate_ccd(const std::vector<CcdQuery>& queries, const CcdOptions& options = {});

}  // namespace loom::eval
