#pragma once
// Numbers given on the command line: the whole text must be one number, finite ("nan", "inf", "1e999" are
// refused), inside the option's range; integers are whole ("5.9", "5x" are refused) and checked before
// they are narrowed. A refusal names the option, the text as given and the range, and exits with 2 (bad
// command line).
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>

#include "Terminal.h"

namespace loom::app {

[[noreturn]] inline void cli_refuse(const std::string& flag, const std::string& text,
                                    const std::string& expected) {
  std::fprintf(stderr, "loom: error: %s expects %s, got '%s'\n", flag.c_str(), expected.c_str(),
               printable(text).c_str());
  std::exit(2);
}

inline std::string cli_show(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%g", v);
  return s;
}

// A finite number in [lo, hi].
inline double cli_number(const std::string& flag, const std::string& text, double lo, double hi) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);  // overflow gives +-HUGE_VAL: not finite
  const std::string expected = "a finite number in [" + cli_show(lo) + ", " + cli_show(hi) + "]";
  if (text.empty() || *end || !std::isfinite(v) || v < lo || v > hi) cli_refuse(flag, text, expected);
  return v;
}

// True when `text` is exactly a whole number: decimal digits, a '-' before them only when `negative` is
// allowed; no space, no '+', nothing after (strtoll alone would skip leading white space).
inline bool cli_whole_text(const std::string& text, bool negative) {
  const std::size_t first = negative && !text.empty() && text[0] == '-' ? 1 : 0;
  return text.size() > first && text.find_first_not_of("0123456789", first) == std::string::npos;
}

// A whole number in [lo, hi]: `text` must be exactly the number (cli_whole_text). The message states the
// range the option accepts.
inline long long cli_integer(const std::string& flag, const std::string& text, long long lo, long long hi) {
  char* end = nullptr;
  errno = 0;
  const long long v = cli_whole_text(text, lo < 0) ? std::strtoll(text.c_str(), &end, 10) : 0;
  if (!cli_whole_text(text, lo < 0) || *end || errno == ERANGE || v < lo || v > hi)
    cli_refuse(flag, text, "a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return v;
}

// A command-line mistake that is not a number: "loom: error: FLAG: PROBLEM", exit 2 (bad command line).
[[noreturn]] inline void cli_error(const std::string& flag, const std::string& problem) {
  std::fprintf(stderr, "loom: error: %s: %s\n", printable(flag).c_str(), printable(problem).c_str());
  std::exit(2);
}

// A path option's value: an empty one (an unset shell variable, `--out "$DIR"`) is refused (exit 2), never
// taken as "the default".
inline std::string cli_path(const std::string& flag, const std::string& text) {
  if (text.empty()) cli_error(flag, "is an empty string (an unset variable?); give a path");
  return text;
}

// An option that takes a value may be given once (`--set` excepted): a second `--out` or `--frames` would
// silently win over the first. Records `flag` in `seen` and refuses it (exit 2) the second time.
inline void cli_once(std::set<std::string>& seen, const std::string& flag) {
  if (flag == "--set" || seen.insert(flag).second) return;
  std::fprintf(stderr, "loom: error: %s given twice (give each option once)\n", printable(flag).c_str());
  std::exit(2);
}

}  // namespace loom::app
