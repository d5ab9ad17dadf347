#pragma once
// One number in a table Loom writes (bench and compare CSVs): `digits` significant digits, and an empty field
// for a value that is not finite (a run that diverged or stopped has no error or drift figure; the row's
// diverged/finite column says so). No table holds "nan" or "inf". A text cell (a name from the scene) is
// quoted per RFC 4180 when it holds a comma, a double quote, CR or LF: enclosed in double quotes, each double
// quote doubled.
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

inline std::string csv_text(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

}  // namespace loom::eval
