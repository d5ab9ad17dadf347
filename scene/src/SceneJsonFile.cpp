// Scene files as JSON: reading one (size-bounded, duplicate keys refused, errors with line and column) and
// `--set PATH=VALUE` overrides applied to the parsed tree (Scene.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/InputFile.h"
#include "loom/scene/Scene.h"
#include "loom/scene/SceneLimits.h"

namespace loom::scene {

namespace {

// "line L, column C" of byte offset `at` of `text`.
std::string line_column(const std::string& text, size_t at) {
  at = std::min(at, text.size());
  int line = 1, col = 1;
  for (size_t i = 0; i < at; ++i) {
    if (text[i] == '\n') {
      ++line;
      col = 1;
    } else {
      ++col;
    }
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(col);
}

// A SAX pass that refuses a key given twice in one object (the DOM parser would keep the last silently),
// naming its JSON path.
class DuplicateKeys : public nlohmann::json::json_sax_t {
 public:
  // `prefix`: the JSON path of the parsed text's root ("" for a whole scene; the PATH of --set PATH=VALUE).
  DuplicateKeys(std::string file, std::string prefix) : file_(std::move(file)), prefix_(std::move(prefix)) {}
  bool null() override { return value(); }
  bool boolean(bool) override { return value(); }
  bool number_integer(number_integer_t) override { return value(); }
  bool number_unsigned(number_unsigned_t) override { return value(); }
  // A number whose text is not zero but reads as zero (1e-400, -1e-400: below the smallest subnormal
  // double): the file holds a value Loom cannot use as written. Refused naming its path and showing it as
  // written; a subnormal one reads as itself and meets its field's checks, whose messages quote numbers by
  // their shortest text (show_number), which reads back to the same value.
  bool number_float(number_float_t v, const string_t& text) override {
    value();
    const std::size_t e = text.find_first_of("eE");
    const bool zero_text = text.substr(0, e).find_first_of("123456789") == std::string::npos;
    if (!zero_text && v == 0.0)
      throw Error(file_, value_path(),
                  show_value(text) + " is below the smallest double (4.9e-324): it would read as " +
                      (std::signbit(v) ? "-0" : "0") +
                      ", not as written; write 0 or a value that is no smaller " + "than 1e-300");
    return true;
  }
  bool string(string_t&) override { return value(); }
  bool binary(binary_t&) override { return value(); }
  bool start_object(std::size_t) override {
    value();
    frames_.push_back({true, {}, "", 0});
    return true;
  }
  bool key(string_t& k) override {
    Frame& f = frames_.back();
    if (!f.keys.insert(k).second)
      throw Error(file_, path() + (path().empty() ? "" : ".") + show_value(k), "key given twice");
    f.key = k;
    return true;
  }
  bool end_object() override {
    frames_.pop_back();
    return true;
  }
  bool start_array(std::size_t) override {
    value();
    frames_.push_back({false, {}, "", -1});
    return true;
  }
  bool end_array() override {
    frames_.pop_back();
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override {
    return false;
  }

 private:
  struct Frame {
    bool object;
    std::set<std::string> keys;
    std::string key;
    long index;
  };
  bool value() {
    if (!frames_.empty() && !frames_.back().object) ++frames_.back().index;
    return true;
  }
  std::string value_path() const {  // of the value just read (value() has counted it)
    std::string p = prefix_;
    for (const Frame& f : frames_) {
      if (f.object)
        p += (p.empty() ? "" : ".") + f.key;
      else
        p += "[" + std::to_string(f.index) + "]";
    }
    return p.empty() ? "(top level)" : p;
  }
  std::string path() const {  // of the object whose key is read: the enclosing keys and indices
    std::string p = prefix_;
    for (size_t i = 0; i + 1 < frames_.size(); ++i) {
      const Frame& f = frames_[i];
      if (f.object)
        p += (p.empty() ? "" : ".") + f.key;
      else
        p += "[" + std::to_string(f.index) + "]";
    }
    return p;
  }
  std::string file_, prefix_;
  std::vector<Frame> frames_;
};

// A JSON parser's message with the input it quotes ("last read: '...'", "number overflow parsing '...'")
// cut to kShownValueBytes (show_value): an unterminated 100 KB string is quoted as its first bytes.
std::string bounded_quote(const std::string& what) {
  const size_t q1 = what.find('\''), q2 = what.rfind('\'');
  if (q1 == std::string::npos || q2 <= q1) return what;
  return what.substr(0, q1 + 1) + show_value(what.substr(q1 + 1, q2 - q1 - 1)) + what.substr(q2);
}

}  // namespace

nlohmann::json read_json_file(const std::string& path) {
  // A folder, /dev/zero (or a link to it) or a huge file is refused before reading.
  const std::string text = loom::read_input_file(path, kMaxInputBytes);
  // JSON text holds no NUL byte (RFC 8259 Sec. 7: control characters are escaped); the parser would take the
  // first one for the end of the input.
  if (const size_t nul = text.find('\0'); nul != std::string::npos)
    throw Error(path, line_column(text, nul), "not JSON text: a NUL byte (binary data)");
  check_json_nesting(path, text, kMaxJsonDepth);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    std::string what = e.what();
    const size_t p = what.find("syntax error");
    throw Error(path, line_column(text, e.byte == 0 ? 0 : e.byte - 1),
                "invalid JSON: " + bounded_quote(p == std::string::npos ? what : what.substr(p)));
  } catch (const nlohmann::json::exception& e) {
    // A number past double range ("number overflow parsing '1e999'"): its first occurrence in the text.
    std::string what = e.what(), where = "(unknown position)";
    const size_t q1 = what.find('\''), q2 = q1 == std::string::npos ? q1 : what.find('\'', q1 + 1);
    if (q2 != std::string::npos) {
      const size_t at = text.find(what.substr(q1 + 1, q2 - q1 - 1));
      if (at != std::string::npos) where = line_column(text, at);
    }
    const size_t p = what.find("] ");
    throw Error(path, where,
                "invalid JSON: " + bounded_quote(p == std::string::npos ? what : what.substr(p + 2)));
  }
  DuplicateKeys dup(path, "");
  nlohmann::json::sax_parse(text, &dup);
  return j;
}

void apply_override(nlohmann::json& root, const std::string& assignment, const std::string& file) {
  const size_t eq = assignment.find('=');
  const std::string where = "--set " + show_value(assignment);
  if (eq == std::string::npos || eq == 0) throw Error(file, where, "expected PATH=VALUE");
  const std::string path = assignment.substr(0, eq);
  const std::string value = assignment.substr(eq + 1);
  // PATH := KEY ( '.' KEY | '[' DIGITS ']' )*, KEY a non-empty run of characters other than '.', '[', ']'
  // (a KEY of digits also indexes an array: cloths.0.mass). Anything else is refused by position, never
  // read as a nearby path: "solver..method", "cloths[0.mass", "cloths[x]", "a.".
  struct Part {
    std::string key;
    bool bracket;
  };
  std::vector<Part> parts;
  auto bad = [&](size_t at, const std::string& problem) {
    throw Error(file, where, "malformed PATH at character " + std::to_string(at + 1) + ": " + problem);
  };
  for (size_t i = 0; i <= path.size();) {
    if (i == path.size()) {
      if (parts.empty()) throw Error(file, where, "empty path");
      break;
    }
    if (path[i] == '[') {
      if (parts.empty()) bad(i, "'[' needs an array name before it");
      const size_t close = path.find(']', i);
      if (close == std::string::npos) bad(i, "'[' is not closed by ']'");
      const std::string digits = path.substr(i + 1, close - i - 1);
      if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos)
        bad(i + 1, "'[" + show_value(digits) + "]' is not an array index (a whole number)");
      parts.push_back({digits, true});
      i = close + 1;
      if (i < path.size() && path[i] != '.' && path[i] != '[') bad(i, "expected '.' or '[' after ']'");
    } else {
      if (path[i] == '.') {
        if (parts.empty()) bad(i, "the path starts with '.'");
        ++i;
      }
      const size_t end = path.find_first_of(".[]", i);
      const std::string key = path.substr(i, end == std::string::npos ? std::string::npos : end - i);
      if (key.empty())
        bad(i, i == path.size()
                   ? "the path ends with '.'"
                   : (path[i] == ']' ? "']' without '['" : "empty key (two separators in a row)"));
      parts.push_back({key, false});
      i = end == std::string::npos ? path.size() : end;
    }
  }
  nlohmann::json* node = &root;
  for (size_t k = 0; k < parts.size(); ++k) {
    const std::string& key = parts[k].key;
    const bool last = k + 1 == parts.size();
    if (parts[k].bracket && !node->is_array())
      throw Error(file, where, "'[" + key + "]' indexes a value that is not an array");
    if (node->is_array()) {
      size_t used = 0;
      long idx = -1;
      try {
        idx = std::stol(key, &used);
      } catch (...) {
      }
      if (used != key.size() || idx < 0 || idx >= static_cast<long>(node->size()))
        throw Error(file, where,
                    "'" + show_value(key) + "' is not an index of the array (size " +
                        std::to_string(node->size()) + ")");
      node = &(*node)[idx];
    } else {
      if (node->is_null()) *node = nlohmann::json::object();
      if (!node->is_object())
        throw Error(file, where, "'" + show_value(key) + "' goes inside a value that is not an object");
      if (!last && !node->contains(key)) (*node)[key] = nlohmann::json::object();
      node = &(*node)[key];
    }
  }
  check_json_nesting(file + ": " + where, value, kMaxJsonDepth);
  nlohmann::json v;
  try {
    v = nlohmann::json::parse(value);
  } catch (...) {
    v = value;  // a bare word is a string
  }
  if (v.is_structured() || v.is_number()) {  // a key given twice inside the value; a number that underflows
    DuplicateKeys dup(file, assignment.substr(0, eq));
    nlohmann::json::sax_parse(value, &dup);
  }
  *node = v;
}

}  // namespace loom::scene
