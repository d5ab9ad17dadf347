#include "loom/scene/JsonReader.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/scene/SceneLimits.h"

namespace loom::scene {

namespace {
std::string type_name(const nlohmann::json& v) {
  if (v.is_null()) return "null";
  if (v.is_boolean()) return "a boolean";
  if (v.is_number()) return "a number";
  if (v.is_string()) return "a string";
  if (v.is_array()) return "an array";
  return "an object";
}
}  // namespace

std::string show_number(double v, int min_digits) {
  // The shortest %g text of at least `min_digits` digits that reads back to v: a message's "got X" is the
  // value Loom read, never a rounding of it (0.30000001 is not shown as 0.3).
  char s[32];
  for (int digits = min_digits; digits <= 17; ++digits) {
    std::snprintf(s, sizeof s, "%.*g", digits, v);
    if (std::strtod(s, nullptr) == v) break;
  }
  return s;
}

nlohmann::json whole_numbers_as_integers(const nlohmann::json& j) {
  if (j.is_structured()) {
    nlohmann::json out = j;
    for (auto& v : out) v = whole_numbers_as_integers(v);
    return out;
  }
  if (j.is_number_float()) {
    const double d = j.get<double>();
    // Whole and within 64-bit integers (2^63 is exact as a double): an integer; 1e300 stays a number and
    // is refused by its field's range.
    if (std::isfinite(d) && d == std::floor(d) && d >= -9223372036854775808.0 && d < 9223372036854775808.0)
      return nlohmann::json(static_cast<long long>(d));
  }
  return j;
}

JsonReader::JsonReader(const nlohmann::json& j, std::string path, std::string file)
    : j_(j), path_(std::move(path)), file_(std::move(file)) {
  if (!j_.is_object())
    throw Error(file_, path_.empty() ? "(top level)" : path_, "expected an object, got " + type_name(j_));
}

bool JsonReader::has(const std::string& key) const { return j_.contains(key); }

void JsonReader::fail(const std::string& key, const std::string& problem) const {
  throw Error(file_, key.empty() ? path_ : child(key), problem);
}

const nlohmann::json& JsonReader::at(const std::string& key) const {
  read_.insert(key);
  return j_.at(key);
}

const nlohmann::json& JsonReader::raw(const std::string& key) const {
  if (!has(key)) fail(key, "is required");
  return at(key);
}

double JsonReader::as_number(const nlohmann::json& v, const std::string& where) const {
  if (!v.is_number()) throw Error(file_, where, "expected a number, got " + type_name(v));
  const double d = v.get<double>();
  if (!std::isfinite(d)) throw Error(file_, where, "must be a finite number");
  return d;
}

double JsonReader::number(const std::string& key, std::optional<double> fallback, std::optional<double> min,
                          bool strict_min) const {
  if (!has(key)) {
    if (fallback) return *fallback;
    fail(key, "is required");
  }
  const double d = as_number(at(key), child(key));
  if (min && (strict_min ? !(d > *min) : !(d >= *min)))
    fail(key, "must be " + std::string(strict_min ? "> " : ">= ") + show_number(*min) + " (got " +
                  show_number(d) + ")");
  // Refused in finish(), after the field's own checks, which name its own limit when it has one.
  if (min && *min >= 0.0 && d != 0.0 && d < kMinPositive) tiny_.push_back({key, d, strict_min});
  return d;
}

std::string JsonReader::name(const std::string& key, const std::string& fallback) const {
  const std::string s = string(key, fallback);
  if (s.empty() || s.size() > kMaxNameBytes)
    fail(key, "must be 1 to " + std::to_string(kMaxNameBytes) + " bytes long (got " +
                  std::to_string(s.size()) + "): a name becomes a file name or a table cell");
  return s;
}

int JsonReader::integer(const std::string& key, std::optional<int> fallback, std::optional<int> min,
                        std::optional<int> max) const {
  if (!has(key)) {
    if (fallback) return *fallback;
    fail(key, "is required");
  }
  return static_cast<int>(
      integer_value(at(key), child(key), min ? *min : -1000000000LL, max ? *max : 1000000000LL));
}

long long JsonReader::integer_value(const nlohmann::json& v, const std::string& where, long long min,
                                    long long max) const {
  if (v.is_number_float() && std::isfinite(v.get<double>()) &&
      v.get<double>() == std::floor(v.get<double>()) &&
      !(v.get<double>() >= static_cast<double>(min) && v.get<double>() <= static_cast<double>(max)))
    throw Error(file_,
                where,  // a whole number too large for an integer type (1e300): its range, not "fractional"
                "must be in [" + std::to_string(min) + ", " + std::to_string(max) + "] (got " +
                    show_number(v.get<double>()) + ")");
  if (!v.is_number_integer())
    throw Error(file_, where,
                "expected an integer, got " + (v.is_number() ? show_number(v.get<double>()) : type_name(v)));
  // Unsigned values are compared unsigned: a value past 2^63 would turn negative as long long.
  if (v.is_number_unsigned() && v.get<std::uint64_t>() > static_cast<std::uint64_t>(max))
    throw Error(
        file_, where,
        "must be <= " + std::to_string(max) + " (got " + std::to_string(v.get<std::uint64_t>()) + ")");
  const long long i = v.get<long long>();
  if (i < min)
    throw Error(file_, where, "must be >= " + std::to_string(min) + " (got " + std::to_string(i) + ")");
  if (i > max)
    throw Error(file_, where, "must be <= " + std::to_string(max) + " (got " + std::to_string(i) + ")");
  return i;
}

bool JsonReader::in_range(const nlohmann::json& v, long long min, long long max) {
  if (!v.is_number_integer()) return false;
  if (v.is_number_unsigned())
    return max >= 0 && v.get<std::uint64_t>() <= static_cast<std::uint64_t>(max) &&
           static_cast<long long>(v.get<std::uint64_t>()) >= min;
  const long long i = v.get<long long>();
  return i >= min && i <= max;
}

std::vector<long long> JsonReader::integers(const std::string& key, size_t count, long long min,
                                            long long max) const {
  const nlohmann::json& v = raw(key);
  if (!v.is_array() || v.size() != count)
    fail(key, "expected " + std::to_string(count) + " integers, got " +
                  (v.is_array() ? std::to_string(v.size()) + " values" : type_name(v)));
  std::vector<long long> out;
  for (size_t i = 0; i < count; ++i)
    out.push_back(integer_value(v[i], child(key) + "[" + std::to_string(i) + "]", min, max));
  return out;
}

double JsonReader::length(const std::string& key, std::optional<double> fallback, bool strict) const {
  const double v = number(key, fallback, 0.0, strict);
  if (v > kMaxCoordinate)
    fail(key, "must be <= " + std::to_string(static_cast<long>(kMaxCoordinate)) + " m (got " +
                  show_number(v) + ")");
  return v;
}

double JsonReader::thickness(const std::string& key, std::optional<double> fallback, bool strict) const {
  const double v = number(key, fallback, 0.0, strict);
  if (v > kMaxContactThickness)
    fail(key, "must be <= " + show_number(kMaxContactThickness) + " m, a contact thickness (got " +
                  show_number(v) + ")");
  return v;
}

double JsonReader::friction(const std::string& key, std::optional<double> fallback) const {
  const double v = number(key, fallback, 0.0);
  if (v > kMaxFriction)
    fail(key,
         "must be <= " + show_number(kMaxFriction) + ", a Coulomb coefficient (got " + show_number(v) + ")");
  return v;
}

cloth::Vec3 JsonReader::point(const std::string& key, std::optional<cloth::Vec3> fallback) const {
  const cloth::Vec3 p = vec3(key, fallback);
  if (!(p.cwiseAbs().maxCoeff() <= kMaxCoordinate))
    fail(key, "coordinates must be within +-" + std::to_string(static_cast<long>(kMaxCoordinate)) + " m");
  return p;
}

bool JsonReader::boolean(const std::string& key, std::optional<bool> fallback) const {
  if (!has(key)) {
    if (fallback) return *fallback;
    fail(key, "is required");
  }
  const nlohmann::json& v = at(key);
  if (!v.is_boolean()) fail(key, "expected a boolean, got " + type_name(v));
  return v.get<bool>();
}

std::string JsonReader::string(const std::string& key, std::optional<std::string> fallback,
                               const std::vector<std::string>& allowed) const {
  if (!has(key)) {
    if (fallback) return *fallback;
    fail(key, "is required");
  }
  const nlohmann::json& v = at(key);
  if (!v.is_string()) fail(key, "expected a string, got " + type_name(v));
  std::string s = v.get<std::string>();
  // Control and invisible format characters (a newline, a NUL, an escape, a bidi override) would reach
  // output files and terminals as they are (HiddenText.h).
  const HiddenChar h = find_hidden_char(s);
  if (h.length)
    fail(key, "holds a control character (" + show_code(h.code) + " at byte " + std::to_string(h.byte) +
                  "): control, bidirectional and zero-width characters are not allowed in scene text");
  if (!allowed.empty()) {
    bool ok = false;
    std::string list;
    for (const auto& a : allowed) {
      ok = ok || a == s;
      list += (list.empty() ? "" : ", ") + a;
    }
    if (!ok) fail(key, "unknown value '" + show_value(s) + "' (expected one of: " + list + ")");
  }
  return s;
}

std::vector<double> JsonReader::numbers(const std::string& key, size_t count) const {
  const nlohmann::json& v = raw(key);
  if (!v.is_array()) fail(key, "expected an array of numbers, got " + type_name(v));
  if (count && v.size() != count)
    fail(key, "expected " + std::to_string(count) + " numbers, got " + std::to_string(v.size()));
  if (!count && v.empty()) fail(key, "must not be empty");
  std::vector<double> out;
  for (size_t i = 0; i < v.size(); ++i)
    out.push_back(as_number(v[i], child(key) + "[" + std::to_string(i) + "]"));
  return out;
}

cloth::Vec3 JsonReader::vec3(const std::string& key, std::optional<cloth::Vec3> fallback) const {
  if (!has(key)) {
    if (fallback) return *fallback;
    fail(key, "is required");
  }
  const auto n = numbers(key, 3);
  return cloth::Vec3(n[0], n[1], n[2]);
}

JsonReader JsonReader::object(const std::string& key) const {
  const nlohmann::json& v = raw(key);
  if (!v.is_object()) fail(key, "expected an object, got " + type_name(v));
  return JsonReader(v, child(key), file_);
}

std::vector<JsonReader> JsonReader::objects(const std::string& key) const {
  const nlohmann::json& v = raw(key);
  if (!v.is_array()) fail(key, "expected an array, got " + type_name(v));
  std::vector<JsonReader> out;
  for (size_t i = 0; i < v.size(); ++i) {
    const std::string where = child(key) + "[" + std::to_string(i) + "]";
    if (!v[i].is_object()) throw Error(file_, where, "expected an object, got " + type_name(v[i]));
    out.emplace_back(v[i], where, file_);
  }
  return out;
}

void JsonReader::finish() const {
  for (auto it = j_.begin(); it != j_.end(); ++it)
    if (!read_.count(it.key())) fail(it.key(), "unknown key");
  for (const Tiny& t : tiny_)
    fail(t.key, "must be " + std::string(t.strict ? "" : "0 or ") + "at least " + show_number(kMinPositive) +
                    " (got " + show_number(t.value) +
                    "): a smaller value is no physical setting and overflows the solver");
}

void check_keyframe_speed(const JsonReader& k, double t0, double t1, const cloth::Vec3& p0,
                          const cloth::Vec3& p1) {
  const double distance = (p1 - p0).norm();
  if (!(distance <= kMaxSpeed * (t1 - t0)))
    k.fail("t", "is " + show_number(t1 - t0) + " s after the keyframe before, which is " +
                    show_number(distance) + " m away: at most " + show_number(kMaxSpeed) +
                    " m/s between keyframes (give the keyframes further apart)");
}

}  // namespace loom::scene
