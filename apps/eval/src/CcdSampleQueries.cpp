// Reader, exact scale/translate and evaluation loop for the CCD sample-query format (CcdSampleQueries.h).
#include "loom/eval/CcdSampleQueries.h"

#include <gmpxx.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/InputFile.h"

namespace loom::eval {
namespace {

// Exact rational -> double; throws when the rational is not exactly a double.
double exact_double(const std::string& num, const std::string& den, const std::string& file, int line) {
  const std::string shown = show_value(num) + "/" + show_value(den);  // a 100,000-digit cell: its first bytes
  // Digits only, an optional sign: GMP's set_str skips blanks inside a number ("1 0" would read as 10).
  auto integer_text = [](const std::string& t) {
    const size_t start = !t.empty() && (t[0] == '-' || t[0] == '+') ? 1 : 0;
    return t.size() > start && t.find_first_not_of("0123456789", start) == std::string::npos;
  };
  mpz_class n, d;
  if (!integer_text(num) || !integer_text(den) || n.set_str(num[0] == '+' ? num.substr(1) : num, 10) != 0 ||
      d.set_str(den[0] == '+' ? den.substr(1) : den, 10) != 0)
    throw loom::Error(file, "line " + std::to_string(line), "'" + shown + "' is not a rational of integers");
  if (d == 0) throw loom::Error(file, "line " + std::to_string(line), "zero denominator in '" + shown + "'");
  mpq_class q(n, d);
  q.canonicalize();
  const double x = q.get_d();  // truncates; checked below
  if (!std::isfinite(x) || mpq_class(x) != q)
    throw loom::Error(file, "line " + std::to_string(line),
                      "'" + shown + "' is not exactly representable as a double");
  return x;
}

// Largest e such that x is an integer multiple of 2^e (x != 0, finite).
int granularity_exponent(double x) {
  int e = std::ilogb(x) - 52;
  double m = std::ldexp(x, -e);  // an integer of at most 53 bits, exact
  while (std::fmod(m, 2.0) == 0.0) m *= 0.5, ++e;
  return e;
}

// a + b is exact iff the TwoSum error term is zero (Knuth, TAOCP vol. 2, Sec. 4.2.2, Theorem B).
bool sum_is_exact(double a, double b) {
  const double s = a + b;
  const double bb = s - a;
  return (a - (s - bb)) + (b - bb) == 0.0;
}

}  // namespace

std::vector<CcdQuery> read_ccd_queries(const std::string& path) {
  const bool vf = path.find("vertex-face") != std::string::npos;
  const bool ee = path.find("edge-edge") != std::string::npos;
  if (vf == ee)
    throw loom::Error(path, "",
                      std::string("cannot tell the query type: the path ") +
                          (vf ? "contains both 'vertex-face' and 'edge-edge'"
                              : "contains neither 'vertex-face' nor 'edge-edge'") +
                          " (it must contain exactly one)");
  std::istringstream in(loom::read_input_file(path));  // a regular file of bounded size (InputFile.h)
  std::vector<CcdQuery> out;
  std::string text;
  int line = 0, row = 0;
  CcdQuery q;
  q.points.fill(Vec3::Zero());
  while (std::getline(in, text)) {
    ++line;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (text.empty()) continue;
    std::vector<std::string> f;
    std::stringstream ss(text);
    for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
    if (f.size() != 7)
      throw loom::Error(path, "line " + std::to_string(line),
                        "expected 7 comma-separated integers, got " + std::to_string(f.size()));
    if (f[6] != "0" && f[6] != "1")
      throw loom::Error(path, "line " + std::to_string(line),
                        "truth column must be 0 or 1, got '" + show_value(f[6]) + "'");
    if (row == 0) {
      q.points.fill(Vec3::Zero());
      q.vertex_face = vf;
      q.line = line;
      q.file = path;
      q.truth = f[6] == "1";
    } else if (q.truth != (f[6] == "1")) {
      throw loom::Error(path, "line " + std::to_string(line), "truth differs from the query's first row");
    }
    for (int k = 0; k < 3; ++k) q.points[row][k] = exact_double(f[2 * k], f[2 * k + 1], path, line);
    if (++row == 8) {
      out.push_back(q);
      row = 0;
    }
  }
  if (row != 0)
    throw loom::Error(path, "line " + std::to_string(line),
                      "incomplete query: the row count is not a multiple of 8");
  // An empty file would report 0 false negatives over 0 queries: a pass that measured nothing.
  if (out.empty()) throw loom::Error(path, "", "holds no queries (an empty file)");
  return out;
}

Vec3 scale_translate_exactly(CcdQuery& query, int k, const Vec3& offset) {
  for (Vec3& p : query.points)
    for (int axis = 0; axis < 3; ++axis) {  // exact unless it overflows or underflows: refused then
      const double scaled = std::ldexp(p[axis], k);
      if (!std::isfinite(scaled) || std::ldexp(scaled, -k) != p[axis]) {
        char text[160];
        std::snprintf(text, sizeof text,
                      "--scale-exp %d: a coordinate %.17g x 2^%d is not a double exactly (it overflows or "
                      "underflows)",
                      k, p[axis], k);
        throw loom::Error(query.file, "line " + std::to_string(query.line), text);
      }
      p[axis] = scaled;
    }
  Vec3 applied = Vec3::Zero();
  for (int axis = 0; axis < 3; ++axis) {
    int g = 1 << 20;
    for (const Vec3& p : query.points)
      if (p[axis] != 0.0) g = std::min(g, granularity_exponent(p[axis]));
    if (g == (1 << 20)) g = std::ilogb(std::abs(offset[axis]) + 1.0) - 52;  // all zero: any double is exact
    double units = std::nearbyint(std::ldexp(offset[axis], -g));
    if (!(std::abs(units) < 0x1p53)) units = std::copysign(0x1p53, offset[axis]);  // also catches inf
    for (;;) {
      const double t = std::ldexp(units, g);
      bool exact = true;
      for (const Vec3& p : query.points) exact = exact && sum_is_exact(p[axis], t);
      if (exact || units == 0.0) break;
      units = std::trunc(units * 0.5);
    }
    applied[axis] = std::ldexp(units, g);
    for (Vec3& p : query.points) p[axis] += applied[axis];
  }
  return applied;
}

CcdEvalStats evaluate_ccd(const std::vector<CcdQuery>& queries, const CcdOptions& options) {
  CcdEvalStats s;
  const auto start = std::chrono::steady_clock::now();
  for (const CcdQuery& q : queries) {
    const auto& p = q.points;
    const CcdResult r = q.vertex_face
                            ? vertex_face_ccd(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], options)
                            : edge_edge_ccd(p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], options);
    ++s.queries;
    s.positives += q.truth;
    s.false_negatives += q.truth && !r.hit;
    s.false_positives += !q.truth && r.hit;
    s.budget_exhausted += r.budget_exhausted;
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

}  // namespace loom::eval
