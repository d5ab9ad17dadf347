#pragma once
// The command line of every `loom` command (CliArgs) and the values of its options. Numbers: the whole text
// must be one number, finite ("nan", "inf", "1e999" are refused), inside the option's range; integers are
// whole ("5.9", "5x" are refused) and checked before they are narrowed. A refusal names the option, the text
// as given (at most kShownValueBytes of it, HiddenText.h) and the range, and exits with 2 (bad command line).
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>
#include <vector>

#include "Terminal.h"

namespace loom::app {

[[noreturn]] inline void cli_refuse(const std::string& flag, const std::string& text,
                                    const std::string& expected) {
  std::fprintf(stderr, "loom: error: %s expects %s, got '%s'\n", printable(flag).c_str(), expected.c_str(),
               loom::show_value(text).c_str());
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
// taken as "the default"; so is "-", which by convention means standard input or output (Loom reads and
// writes files: give ./- for a file or folder of that name).
inline std::string cli_path(const std::string& flag, const std::string& text) {
  if (text.empty()) cli_error(flag, "is an empty string (an unset variable?); give a path");
  if (text == "-")
    cli_error(
        flag,
        "'-' (standard input/output) is not a path Loom reads or writes; give a file or folder (./- for "
        "one of that name)");
  return text;
}

// An option that takes a value may be given once (`--set` excepted): a second `--out` or `--frames` would
// silently win over the first. Records `flag` in `seen` and refuses it (exit 2) the second time.
inline void cli_once(std::set<std::string>& seen, const std::string& flag) {
  if (flag == "--set" || seen.insert(flag).second) return;
  std::fprintf(stderr, "loom: error: %s given twice (give each option once)\n", printable(flag).c_str());
  std::exit(2);
}

// A comma-separated list option (`--sizes 8,16`, `--methods a,b`): its entries in order. An empty entry
// (a stray comma, an unset variable: "8,", ",8", "8,,16", "") and an entry given twice (`--sizes 8,8` would
// run and report size 8 twice) are refused naming the option and the entry (exit 2).
inline std::vector<std::string> cli_list(const std::string& flag, const std::string& text) {
  std::vector<std::string> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = text.find(',', start);
    out.push_back(text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (out.back().empty())
      cli_error(flag, "an empty entry in '" + loom::show_value(text) +
                          "' (a stray comma or an unset variable?); give a comma-separated list");
    if (std::count(out.begin(), out.end() - 1, out.back()))
      cli_error(flag, "'" + loom::show_value(out.back()) + "' is listed twice (each entry would run twice)");
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

// The arguments of one command, walked in order (`while (args.next()) { const std::string& a = args.arg();
// ... }`), the same way in every command:
//  - an option that takes a value takes it as the next argument (`--out DIR`) or after '=' (`--out=DIR`);
//  - a missing value, or a next argument that starts with "--" (`--out --frames 5`: the next option), is
//    refused naming the option (a value that starts with "--" can be given as `--out=--x`);
//  - an option that takes no value given one (`--overwrite=yes`) is refused;
//  - an option that takes a value is given once (`--set` excepted: a second `--out` would silently win);
//  - `--` ends the options: every later argument is an operand (a scene named -x.json).
// Every refusal exits 2 (bad command line), naming the option and "see loom COMMAND --help".
class CliArgs {
 public:
  CliArgs(int argc, char** argv, int first, std::string command)
      : argc_(argc), argv_(argv), i_(first - 1), command_(std::move(command)) {}

  // Moves to the next argument; false after the last.
  bool next() {
    if (inline_ && !used_)
      fail(name_, "takes no value (got '" + name_ + "=" + loom::show_value(value_) + "')");
    inline_ = used_ = false;
    value_.clear();
    if (++i_ >= argc_) return false;
    name_ = argv_[i_];
    if (!operands_only_ && name_ == "--") {
      operands_only_ = true;
      return next();
    }
    operand_ = operands_only_ || name_.size() < 2 || name_[0] != '-';
    const std::size_t eq = name_.find('=');
    if (!operand_ && name_.rfind("--", 0) == 0 && eq != std::string::npos) {
      value_ = name_.substr(eq + 1);
      name_.resize(eq);
      inline_ = true;
    }
    return true;
  }
  // The current argument: an option's name without its "=VALUE", or an operand as given.
  const std::string& arg() const { return name_; }
  // True when the current argument is an operand: it does not start with '-', it is "-" alone, or it comes
  // after `--`.
  bool operand() const { return operand_; }
  // The current option's value.
  std::string value() {
    if (!inline_) {
      if (i_ + 1 >= argc_) fail(name_, "needs a value");
      const std::string next = argv_[i_ + 1];
      if (next.rfind("--", 0) == 0)
        fail(name_, "needs a value; the next argument '" + loom::show_value(next) + "' is an option (write " +
                        name_ + "=VALUE for a value that starts with '--')");
      value_ = next;
      ++i_;
    }
    used_ = true;
    cli_once(seen_, name_);
    return value_;
  }
  // Refuses the current argument as an unknown option (exit 2).
  [[noreturn]] void unknown() const {
    std::fprintf(stderr, "loom: error: unknown option '%s' (see loom %s --help%s)\n",
                 loom::show_value(name_).c_str(), command_.c_str(),
                 name_.rfind("--", 0) == 0 ? "" : "; a file name that starts with '-' goes after --");
    std::exit(2);
  }
  // Refuses the command line: "loom: error: FLAG: PROBLEM (see loom COMMAND --help)", exit 2.
  [[noreturn]] void fail(const std::string& flag, const std::string& problem) const {
    std::fprintf(stderr, "loom: error: %s: %s (see loom %s --help)\n", loom::show_value(flag).c_str(),
                 printable(problem).c_str(), command_.c_str());
    std::exit(2);
  }

 private:
  int argc_;
  char** argv_;
  int i_;
  std::string command_;
  std::string name_, value_;
  bool inline_ = false, used_ = false, operand_ = false, operands_only_ = false;
  std::set<std::string> seen_;  // options that took a value
};

}  // namespace loom::app
