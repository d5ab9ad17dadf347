#pragma once
// JsonReader: typed, path-tracking access to one JSON object of a scene. Every error names the file, the
// JSON path (`cloths[0].material.areal_density`) and the problem; finish() rejects keys nobody read.
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::scene {

// A number in a message ("got X"): the shortest %g text of at least `min_digits` significant digits that
// reads back to the same double.
std::string show_number(double v, int min_digits = 6);
// `j` with every whole number written with a fraction or an exponent (4.0, 1e2) made the integer it is:
// JSON has one number type, so every integer field takes 4.0 as 4 (parse_scene reads this copy).
nlohmann::json whole_numbers_as_integers(const nlohmann::json& j);

class JsonReader {
 public:
  JsonReader(const nlohmann::json& j, std::string path, std::string file);

  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }
  bool has(const std::string& key) const;
  [[noreturn]] void fail(const std::string& key, const std::string& problem) const;

  // Each getter marks the key as read. `min`/`max` bound the value; strict bounds exclude the limit. A
  // field with a `min` of 0 or more (a positive or non-negative quantity) with a non-zero value below
  // kMinPositive (SceneLimits.h), subnormals included, is refused by finish(), after the field's own
  // checks (which name its own limit): one check for every such field of a scene.
  double number(const std::string& key, std::optional<double> fallback = std::nullopt,
                std::optional<double> min = std::nullopt, bool strict_min = false) const;
  // An integer in [min, max] (default [-1e9, 1e9]): the message gives the field's own limit.
  int integer(const std::string& key, std::optional<int> fallback = std::nullopt,
              std::optional<int> min = std::nullopt, std::optional<int> max = std::nullopt) const;
  // A name (of a cloth, garment, body or collider): a string of 1 to kMaxNameBytes bytes.
  std::string name(const std::string& key, const std::string& fallback) const;
  bool boolean(const std::string& key, std::optional<bool> fallback = std::nullopt) const;
  std::string string(const std::string& key, std::optional<std::string> fallback = std::nullopt,
                     const std::vector<std::string>& allowed = {}) const;
  cloth::Vec3 vec3(const std::string& key, std::optional<cloth::Vec3> fallback = std::nullopt) const;
  std::vector<double> numbers(const std::string& key, size_t count = 0) const;  // count 0: any length >= 1
  // An integer JSON value `v` (at JSON path `where`) in [min, max], checked before any narrowing: a value
  // past 64 bits, or past int, is an error, never a wrapped small number.
  long long integer_value(const nlohmann::json& v, const std::string& where, long long min,
                          long long max) const;
  // True for an integer JSON value in [min, max], compared without narrowing (unsigned values unsigned).
  static bool in_range(const nlohmann::json& v, long long min, long long max);
  // A length in metres (radius, thickness, half extent, scale): > 0 (`strict`) or >= 0 and at most
  // kMaxCoordinate (SceneLimits.h), so no size anywhere in a scene can overflow the geometry built from it.
  double length(const std::string& key, std::optional<double> fallback = std::nullopt,
                bool strict = false) const;
  // A contact thickness in metres: > 0 (`strict`) or >= 0 and at most kMaxContactThickness (SceneLimits.h).
  double thickness(const std::string& key, std::optional<double> fallback = std::nullopt,
                   bool strict = false) const;
  // A Coulomb friction coefficient in [0, kMaxFriction].
  double friction(const std::string& key, std::optional<double> fallback = std::nullopt) const;
  // A point or offset in metres: every coordinate within +-kMaxCoordinate.
  cloth::Vec3 point(const std::string& key, std::optional<cloth::Vec3> fallback = std::nullopt) const;
  // `key` as exactly `count` integers, each in [min, max].
  std::vector<long long> integers(const std::string& key, size_t count, long long min, long long max) const;
  JsonReader object(const std::string& key) const;
  std::vector<JsonReader> objects(const std::string& key) const;  // an array of objects
  const nlohmann::json& raw(const std::string& key) const;        // marks as read, no type check
  // Throws for every key of this object that was never read, then for a positive or non-negative number
  // read here that is non-zero and below kMinPositive (see number()).
  void finish() const;

  std::string child(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

 private:
  const nlohmann::json& at(const std::string& key) const;
  double as_number(const nlohmann::json& v, const std::string& where) const;

  const nlohmann::json& j_;
  std::string path_;
  std::string file_;
  mutable std::set<std::string> read_;
  struct Tiny {
    std::string key;
    double value;
    bool strict;
  };
  mutable std::vector<Tiny> tiny_;  // numbers below kMinPositive, refused by finish()
};

// Refuses (naming keyframe `k`'s `t`) a keyframe reached from the one before (time t0, position p0) faster
// than kMaxSpeed m/s: keyframe times that close (1 m in 1e-300 s) would teleport a collider or a body.
void check_keyframe_speed(const JsonReader& k, double t0, double t1, const cloth::Vec3& p0,
                          const cloth::Vec3& p1);

}  // namespace loom::scene
