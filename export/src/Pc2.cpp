#include "loom/export/Pc2.h"

#include <cstring>
#include <iterator>
#include <string>

#include "loom/cloth/Error.h"
#include "loom/cloth/InputFile.h"

namespace loom::exporter {

namespace {

constexpr char kSignature[12] = {'P', 'O', 'I', 'N', 'T', 'C', 'A', 'C', 'H', 'E', '2', '\0'};
constexpr std::streamoff kSamplesOffset = 12 + 4 + 4 + 4 + 4;  // where the int32 sample count lives
constexpr std::streamoff kHeaderSize = kSamplesOffset + 4;

// Explicit little-endian encoding, whatever the host's byte order.
void put_u32(char* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<char>((v >> (8 * i)) & 0xffu);
}
uint32_t get_u32(const unsigned char* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}
void put_f32(char* p, float f) {
  uint32_t v;
  std::memcpy(&v, &f, 4);
  put_u32(p, v);
}
float get_f32(const unsigned char* p) {
  const uint32_t v = get_u32(p);
  float f;
  std::memcpy(&f, &v, 4);
  return f;
}

}  // namespace

Pc2Writer::Pc2Writer(std::string path, int points, double start_frame, double sample_rate)
    : path_(std::move(path)), out_(path_, std::ios::binary | std::ios::trunc), points_(points) {
  if (!out_) throw Error(path_, "", "cannot write PC2 point cache");
  char header[kHeaderSize];
  std::memcpy(header, kSignature, 12);
  put_u32(header + 12, 1);
  put_u32(header + 16, static_cast<uint32_t>(points));
  put_f32(header + 20, static_cast<float>(start_frame));
  put_f32(header + 24, static_cast<float>(sample_rate));
  put_u32(header + 28, 0);  // sample count, patched by finish()
  out_.write(header, kHeaderSize);
}

Pc2Writer::~Pc2Writer() {
  try {
    finish();
  } catch (...) {
  }
}

void Pc2Writer::add_sample(const cloth::Vec3s& x) {
  if (static_cast<int>(x.size()) != points_)
    throw Error(path_, "",
                "sample has " + std::to_string(x.size()) + " points, the cache " + std::to_string(points_));
  std::vector<char> buf(x.size() * 12);
  for (size_t i = 0; i < x.size(); ++i)
    for (int k = 0; k < 3; ++k) put_f32(buf.data() + 12 * i + 4 * k, static_cast<float>(x[i][k]));
  out_.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  if (!out_) throw Error(path_, "", out_.write_failure());
  ++samples_;
}

void Pc2Writer::finish() {
  if (finished_) return;
  finished_ = true;
  char count[4];
  put_u32(count, static_cast<uint32_t>(samples_));
  out_.seekp(kSamplesOffset);
  out_.write(count, 4);
  out_.close();
  if (!out_) throw Error(path_, "", out_.write_failure());
}

Pc2Cache read_pc2(const std::string& path) {
  const std::string text = read_input_file(path);  // a regular file of bounded size (InputFile.h)
  const std::vector<unsigned char> bytes(text.begin(), text.end());
  if (bytes.size() < static_cast<size_t>(kHeaderSize))
    throw Error(path, "header", "file too short for a PC2 header");
  if (std::memcmp(bytes.data(), kSignature, 12) != 0)
    throw Error(path, "header", "not a PC2 file (no POINTCACHE2 signature)");
  if (get_u32(bytes.data() + 12) != 1) throw Error(path, "header", "unsupported PC2 version");
  Pc2Cache c;
  c.points = static_cast<int>(get_u32(bytes.data() + 16));
  c.start_frame = get_f32(bytes.data() + 20);
  c.sample_rate = get_f32(bytes.data() + 24);
  c.samples = static_cast<int>(get_u32(bytes.data() + 28));
  const size_t floats = size_t(c.samples) * size_t(c.points) * 3;
  if (bytes.size() != kHeaderSize + 4 * floats)
    throw Error(path, "",
                "size " + std::to_string(bytes.size()) + " bytes does not match " +
                    std::to_string(c.samples) + " samples of " + std::to_string(c.points) + " points");
  c.xyz.resize(floats);
  for (size_t i = 0; i < floats; ++i) c.xyz[i] = get_f32(bytes.data() + kHeaderSize + 4 * i);
  return c;
}

}  // namespace loom::exporter
