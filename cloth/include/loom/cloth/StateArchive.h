#pragma once
// StateArchive: the byte image of a simulation's changing state. The non-finite guard keeps one in
// memory per frame to roll a failed frame back; checkpoints write one to disk (DIR/checkpoint/state.bin).
// Values are stored raw (native doubles, little-endian 64-bit integers on the machines we build for), so a
// restored state is bit-identical to the saved one. A reader that runs out of bytes or meets the wrong tag
// throws loom::Error naming the archive and the field.
#include <cstdint>
#include <string>
#include <vector>

#include "loom/cloth/Types.h"

namespace loom::cloth {

class StateWriter {
 public:
  // `tag`: a short name checked on reading, so a mismatched archive fails loudly, not silently.
  void tag(const std::string& name);
  void f64(double v);
  void i64(std::int64_t v);
  void vec3s(const Vec3s& v);
  void doubles(const std::vector<double>& v);
  void bytes(const std::string& b);
  const std::string& data() const { return data_; }
  void clear() { data_.clear(); }

 private:
  std::string data_;
};

class StateReader {
 public:
  // `source`: the file (or "memory") named in errors.
  StateReader(const std::string& data, std::string source) : data_(data), source_(std::move(source)) {}
  void tag(const std::string& name);
  double f64();
  std::int64_t i64();
  Vec3s vec3s();
  std::vector<double> doubles();
  std::string bytes();
  bool at_end() const { return pos_ == data_.size(); }
  const std::string& source() const { return source_; }

 private:
  void take(void* out, size_t n, const char* what);
  const std::string& data_;
  std::string source_;
  size_t pos_ = 0;
  std::string last_tag_ = "(start)";
};

}  // namespace loom::cloth
