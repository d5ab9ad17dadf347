#include "loom/cloth/StateArchive.h"

#include <cstring>

#include "loom/cloth/Error.h"

namespace loom::cloth {

namespace {
template <class T>
void append(std::string& s, const T& v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof(T));
}
// Arrays go in one copy each: a Vec3s is n packed triples of doubles, the same bytes as writing them one by
// one.
static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");
// An empty array's data() may be null: nothing is copied from it.
void append_array(std::string& s, const void* data, size_t n) {
  if (n > 0) s.append(static_cast<const char*>(data), n);
}
}  // namespace

void StateWriter::tag(const std::string& name) { bytes(name); }
void StateWriter::f64(double v) { append(data_, v); }
void StateWriter::i64(std::int64_t v) { append(data_, v); }

void StateWriter::vec3s(const Vec3s& v) {
  i64(static_cast<std::int64_t>(v.size()));
  append_array(data_, v.data(), v.size() * sizeof(Vec3));
}

void StateWriter::doubles(const std::vector<double>& v) {
  i64(static_cast<std::int64_t>(v.size()));
  append_array(data_, v.data(), v.size() * sizeof(double));
}

void StateWriter::bytes(const std::string& b) {
  i64(static_cast<std::int64_t>(b.size()));
  data_ += b;
}

void StateReader::take(void* out, size_t n, const char* what) {
  if (n > data_.size() - pos_)
    throw Error(source_, "after '" + last_tag_ + "'",
                std::string("state archive is cut short (reading ") + what + ")");
  if (n == 0)
    return;  // an empty array's data() may be null, and memcpy's pointers must not be, even for 0 bytes
  std::memcpy(out, data_.data() + pos_, n);
  pos_ += n;
}

void StateReader::tag(const std::string& name) {
  const std::string got = bytes();
  if (got != name)
    throw Error(source_, "after '" + last_tag_ + "'",
                "state archive does not match this simulation (expected '" + name + "', found '" +
                    got.substr(0, 64) + "')");
  last_tag_ = name;
}

double StateReader::f64() {
  double v;
  take(&v, sizeof v, "a number");
  return v;
}

std::int64_t StateReader::i64() {
  std::int64_t v;
  take(&v, sizeof v, "an integer");
  return v;
}

Vec3s StateReader::vec3s() {
  const std::int64_t n = i64();
  if (n < 0 || static_cast<std::uint64_t>(n) > (data_.size() - pos_) / 24)
    throw Error(source_, "after '" + last_tag_ + "'", "state archive holds a bad array length");
  Vec3s v(static_cast<size_t>(n));
  take(v.data(), v.size() * sizeof(Vec3), "an array of points");
  return v;
}

std::vector<double> StateReader::doubles() {
  const std::int64_t n = i64();
  if (n < 0 || static_cast<std::uint64_t>(n) > (data_.size() - pos_) / 8)
    throw Error(source_, "after '" + last_tag_ + "'", "state archive holds a bad array length");
  std::vector<double> v(static_cast<size_t>(n));
  take(v.data(), v.size() * sizeof(double), "an array of numbers");
  return v;
}

std::string StateReader::bytes() {
  const std::int64_t n = i64();
  if (n < 0 || static_cast<std::uint64_t>(n) > data_.size() - pos_)
    throw Error(source_, "after '" + last_tag_ + "'", "state archive holds a bad string length");
  std::string s = data_.substr(pos_, static_cast<size_t>(n));
  pos_ += static_cast<size_t>(n);
  return s;
}

}  // namespace loom::cloth
