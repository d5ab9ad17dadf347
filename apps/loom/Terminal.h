#pragma once
// Text from inputs (file names, scene values, error messages quoting them) on its way to a terminal:
// control characters (C0, DEL) are shown as \xNN, so an input cannot move the cursor, clear the screen or
// forge lines of output.
#include <cstdio>
#include <string>

namespace loom::app {

inline std::string printable(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (unsigned char ch : s) {
    if (ch < 0x20 || ch == 0x7f) {
      char esc[8];
      std::snprintf(esc, sizeof esc, "\\x%02x", ch);
      out += esc;
    } else {
      out += static_cast<char>(ch);
    }
  }
  return out;
}

}  // namespace loom::app
