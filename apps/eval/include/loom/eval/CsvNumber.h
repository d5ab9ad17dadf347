#pragma once
// One number in a table Loom writes (bench and compare CSVs): `digits` significant digits, and an empty field
// for a value that is not finite (a run that diverged or stopped has no error or drift figure; the row's
// diverged/finite column says so). No table holds "nan" or "inf".
#include <cmath>
#include <cstdio>
#include <string>

namespace loom::eval {

inline std::string csv_number(double v, int digits = 6) {
  if (!std::isfinite(v)) return "";
  char b[64];
  std::snprintf(b, sizeof b, "%.*g", digits, v);
  return b;
}

}  // namespace loom::eval
