#include "Checkpoint.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>

#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/InputFile.h"
#include "loom/cloth/OutputFile.h"
#include "loom/eval/Hex.h"
#include "loom/eval/OutputFolder.h"

namespace fs = std::filesystem;

namespace loom::app {

using eval::hex;

namespace {
constexpr const char* kMagicPrefix = "LOOMCKPT";
constexpr size_t kMagicBytes = 10;  // "LOOMCKPT" + one digit + "\n"
fs::path checkpoint_file(const fs::path& out) { return out / "checkpoint" / "checkpoint.bin"; }

std::uint64_t unhex(const std::string& s) {
  if (s.size() != 16 || s.find_first_not_of("0123456789abcdef") != std::string::npos)
    throw std::invalid_argument("expected 16 hex digits");
  return std::stoull(s, nullptr, 16);
}
void put_u64(std::string& out, std::uint64_t v) { out.append(reinterpret_cast<const char*>(&v), sizeof v); }
// An integer JSON value in [lo, hi], checked before any conversion (a float or a wider value is refused).
long long integer_in(const nlohmann::json& v, long long lo, long long hi) {
  if (!v.is_number_integer()) throw std::invalid_argument("expected an integer");
  if (v.is_number_unsigned() ? v.get<std::uint64_t>() > static_cast<std::uint64_t>(hi)
                             : v.get<long long>() > hi)
    throw std::out_of_range("too large");
  if (!v.is_number_unsigned() && v.get<long long>() < lo) throw std::out_of_range("too small");
  return v.is_number_unsigned() ? static_cast<long long>(v.get<std::uint64_t>()) : v.get<long long>();
}
constexpr long long kIntMax = 2147483647;
}  // namespace

std::uint64_t fnv1a(const char* data, size_t n, std::uint64_t h) {
  for (size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 0x100000001b3ull;
  }
  return h;
}

std::string read_text_file(const std::string& path, std::uint64_t max_bytes) {
  return loom::read_input_file(path, max_bytes);  // a regular file of bounded size (InputFile.h)
}

InputFile fingerprint(const std::string& path) {
  InputFile f;
  std::error_code ec;
  // Resolved as the system resolves it: a link followed before a ".." (lexically, "lk/../x" names ./x).
  const fs::path abs = fs::weakly_canonical(fs::absolute(path), ec);
  f.path = (ec ? fs::path(path) : abs).string();
  const std::string data = read_text_file(f.path);
  f.bytes = data.size();
  f.hash = fnv1a(data);
  return f;
}

std::string kept_stats_rows(const fs::path& out, int frame) {
  const fs::path partial = out / "stats.csv.partial", done = out / "stats.csv";
  const fs::path from = fs::exists(partial) ? partial : done;
  if (!fs::exists(from))
    throw Error(done.string(), "--resume", "missing: the run's stats are needed to resume");
  std::istringstream in(read_text_file(from.string()));
  std::string line, rows;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (std::atol(line.c_str()) > frame) break;
    rows += line + "\n";
  }
  return rows;
}

std::string encode_checkpoint(const Checkpoint& c) {
  nlohmann::json j;
  j["format"] = kCheckpointFormat;
  j["scene"] = c.scene;
  j["scene_text"] = c.scene_text;
  j["sets"] = c.sets;
  j["run_id"] = hex(c.run_id);
  nlohmann::json inputs = nlohmann::json::array();
  for (const InputFile& f : c.inputs)
    inputs.push_back({{"path", f.path}, {"bytes", f.bytes}, {"hash", hex(f.hash)}});
  j["inputs"] = inputs;
  j["frames_total"] = c.frames_total;
  j["threads"] = c.threads;
  j["checkpoint_every"] = c.checkpoint_every;
  j["render"] = c.render;
  j["frame"] = c.frame;
  j["frame_digits"] = c.frame_digits;
  j["max_strain"] = c.max_strain;
  j["mean_strain_sum"] = c.mean_strain_sum;
  j["sim_ms"] = c.sim_ms;
  j["logged_frames"] = c.logged_frames;
  j["log_hash"] = hex(c.log_hash);
  j["frames_hash"] = hex(c.frames_hash);
  std::string frame_hashes;  // 16 hex digits per frame file
  for (std::uint64_t h : c.frame_hashes) frame_hashes += hex(h);
  j["frame_hashes"] = frame_hashes;
  const std::string header = j.dump();
  std::string out = std::string(kMagicPrefix) + std::to_string(kCheckpointFormat) + "\n";
  put_u64(out, header.size());
  out += header;
  put_u64(out, c.state.size());
  out += c.state;
  put_u64(out, fnv1a(out));
  return out;
}

Checkpoint decode_checkpoint(const std::string& data, const std::string& source) {
  auto bad = [&](const std::string& what) { return Error(source, "", "not a valid checkpoint: " + what); };
  if (data.size() < kMagicBytes || data.compare(0, 8, kMagicPrefix) != 0 || data[9] != '\n')
    throw bad("wrong header");
  if (data[8] != '0' + kCheckpointFormat)
    throw Error(source, "format",
                "not a valid checkpoint for this loom: written in checkpoint format " +
                    std::string(1, std::isprint(static_cast<unsigned char>(data[8])) ? data[8] : '?') +
                    "; this loom reads format " + std::to_string(kCheckpointFormat) + " only");
  if (data.size() < kMagicBytes + 3 * sizeof(std::uint64_t)) throw bad("cut short");
  std::uint64_t sum;
  std::memcpy(&sum, data.data() + data.size() - sizeof sum, sizeof sum);
  const size_t end = data.size() - sizeof sum;
  if (fnv1a(data.data(), end) != sum)
    throw Error(source, "checksum",
                "does not match the contents: the checkpoint was changed or damaged after it was written");
  size_t pos = kMagicBytes;
  auto u64 = [&](const char* what) {
    std::uint64_t v;
    if (end - pos < sizeof v) throw bad(std::string("cut short before the ") + what);
    std::memcpy(&v, data.data() + pos, sizeof v);
    pos += sizeof v;
    return v;
  };
  const std::uint64_t hn = u64("header");
  if (hn > end - pos) throw bad("cut short in the header");
  Checkpoint c;
  std::string field;
  const std::string header = data.substr(pos, hn);
  // The header as encode_checkpoint writes it, byte for byte: a key given twice, a key Loom does not write,
  // other spacing or nesting (checked before parsing) are a header Loom did not write.
  check_json_nesting(source, header, 3);
  try {
    const nlohmann::json j = nlohmann::json::parse(header);
    if (j.dump() != header) throw bad("the header is not as Loom writes it (a key twice, or edited)");
    static const std::set<std::string> kKeys = {
        "format",       "scene",           "scene_text",       "sets",          "run_id",   "inputs",
        "frames_total", "threads",         "checkpoint_every", "render",        "frame",    "frame_digits",
        "max_strain",   "mean_strain_sum", "sim_ms",           "logged_frames", "log_hash", "frames_hash",
        "frame_hashes"};
    for (auto it = j.begin(); it != j.end(); ++it)
      if (!kKeys.count(it.key()))
        throw bad("the header holds a key Loom does not write: '" + show_value(it.key()) + "'");
    auto at = [&](const char* key) -> const nlohmann::json& {
      field = key;
      return j.at(key);
    };
    if (integer_in(at("format"), 0, kIntMax) != kCheckpointFormat)
      throw bad("the header's format differs from the file's");
    c.scene = at("scene").get<std::string>();
    c.scene_text = at("scene_text").get<std::string>();
    c.sets = at("sets").get<std::vector<std::string>>();
    c.run_id = unhex(at("run_id").get<std::string>());
    for (const auto& f : at("inputs")) {
      InputFile in;
      in.path = f.at("path").get<std::string>();
      in.bytes =
          static_cast<std::uint64_t>(integer_in(f.at("bytes"), 0, std::numeric_limits<long long>::max()));
      in.hash = unhex(f.at("hash").get<std::string>());
      c.inputs.push_back(in);
    }
    // Every run reads its scene file: a list without it would leave the inputs unchecked.
    if (std::none_of(c.inputs.begin(), c.inputs.end(), [&](const InputFile& f) { return f.path == c.scene; }))
      throw bad("the header's inputs do not list its scene");
    c.frames_total = static_cast<int>(integer_in(at("frames_total"), 0, kIntMax));
    c.threads = static_cast<int>(integer_in(at("threads"), 1, kIntMax));
    c.checkpoint_every = static_cast<int>(integer_in(at("checkpoint_every"), 0, kIntMax));
    c.render = at("render").get<bool>();
    c.frame = static_cast<int>(integer_in(at("frame"), 0, kIntMax));
    // Absent in checkpoints of earlier looms: the width their run's frame count gave.
    if (j.contains("frame_digits")) {
      c.frame_digits = static_cast<int>(integer_in(at("frame_digits"), 5, 10));
    } else {
      c.frame_digits = 5;
      for (long long v = 100000; v <= c.frames_total; v *= 10) ++c.frame_digits;
    }
    c.max_strain = at("max_strain").get<double>();
    c.mean_strain_sum = at("mean_strain_sum").get<double>();
    c.sim_ms = at("sim_ms").get<double>();
    c.logged_frames = static_cast<long>(integer_in(at("logged_frames"), 0, std::numeric_limits<long>::max()));
    c.log_hash = unhex(at("log_hash").get<std::string>());
    c.frames_hash = unhex(at("frames_hash").get<std::string>());
    if (j.contains("frame_hashes")) {  // absent in checkpoints of earlier looms
      const std::string hashes = at("frame_hashes").get<std::string>();
      if (hashes.size() % 16 != 0) throw std::invalid_argument("expected 16 hex digits per frame file");
      for (std::size_t k = 0; k < hashes.size(); k += 16)
        c.frame_hashes.push_back(unhex(hashes.substr(k, 16)));
    }
    field.clear();
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw bad("header" + (field.empty() ? std::string() : " field '" + field + "'") + ": " + e.what());
  }
  auto range = [&](const char* key, bool ok) {
    if (!ok) throw bad(std::string("header field '") + key + "' is out of range");
  };
  range("frames_total", c.frames_total >= 0);
  range("frame", c.frame >= 0 && c.frame <= c.frames_total);
  range("threads", c.threads >= 1);
  range("checkpoint_every", c.checkpoint_every >= 0);
  range("logged_frames", c.logged_frames >= 0 && c.logged_frames <= static_cast<long>(c.frame) + 1);
  range("max_strain", std::isfinite(c.max_strain));
  range("mean_strain_sum", std::isfinite(c.mean_strain_sum));
  range("sim_ms", std::isfinite(c.sim_ms) && c.sim_ms >= 0.0);
  pos += hn;
  const std::uint64_t sn = u64("state");
  if (sn != end - pos) throw bad("the state is cut short or has trailing bytes");
  c.state = data.substr(pos, sn);
  return c;
}

void write_checkpoint(OutputFolder& out, const Checkpoint& c) {
  out.claim("checkpoint/");
  const fs::path path = out.claim("checkpoint/checkpoint.bin");
  const fs::path tmp = out.claim("checkpoint/checkpoint.bin.tmp");
  write_file_atomically(path.string(), tmp.string(), encode_checkpoint(c));
}

Checkpoint read_checkpoint(const fs::path& out) {
  const fs::path path = checkpoint_file(out);
  std::error_code ec;  // only a missing file is "no checkpoint"; a loop of links gets its own reason below
  if (!fs::exists(path, ec) && (!ec || ec == std::errc::no_such_file_or_directory))
    throw Error(path.string(), "--resume",
                "no checkpoint here (a run writes one with --checkpoint-every N; a scene with rigid "
                "bodies cannot write one, so its runs cannot be resumed)");
  return decode_checkpoint(read_text_file(path.string()), path.string());
}

void check_inputs(const Checkpoint& c) {
  for (const InputFile& f : c.inputs) {
    std::error_code ec;
    if (!fs::exists(f.path, ec) && (!ec || ec == std::errc::no_such_file_or_directory))
      throw Error(f.path, "--resume", "an input of the checkpointed run is missing");
    const InputFile now = fingerprint(f.path);
    if (now.bytes != f.bytes || now.hash != f.hash)
      throw Error(f.path, "--resume",
                  "this input changed since the checkpoint was written (" + std::to_string(f.bytes) +
                      " bytes then, " + std::to_string(now.bytes) + " now): resuming would mix two runs");
  }
}

std::vector<FrameLogEntry> parse_frame_log(const std::string& data, long keep,
                                           const std::vector<size_t>& vertices, const std::string& source) {
  std::uint64_t points = 0;
  for (size_t v : vertices) {
    if (v > (std::uint64_t(1) << 40)) throw Error(source, "", "too many vertices for a frame log");
    points += v;
  }
  const std::uint64_t entry_bytes = sizeof(double) * (2 + 3 * points);
  // keep * entry_bytes <= data.size(), written as a division so that no product can wrap.
  if (keep < 0 || static_cast<std::uint64_t>(keep) > data.size() / entry_bytes)
    throw Error(source, "",
                "frame log is shorter than the checkpoint says (" + std::to_string(keep) + " frames)");
  std::vector<FrameLogEntry> out;
  out.reserve(static_cast<size_t>(keep));
  size_t pos = 0;
  for (long e = 0; e < keep; ++e) {
    double time, flags;
    std::memcpy(&time, data.data() + pos, sizeof time);
    pos += sizeof time;
    std::memcpy(&flags, data.data() + pos, sizeof flags);
    pos += sizeof flags;
    if (!std::isfinite(time) || !(flags >= 0.0 && flags <= 3.0) || flags != std::floor(flags))
      throw Error(source, "entry " + std::to_string(e), "not a frame log entry (time or flags out of range)");
    FrameLogEntry entry{time, static_cast<int>(flags), {}};
    for (size_t v : vertices) {
      cloth::Vec3s x(v);
      for (cloth::Vec3& p : x) {
        std::memcpy(p.data(), data.data() + pos, 3 * sizeof(double));
        pos += 3 * sizeof(double);
        if (!p.allFinite()) throw Error(source, "entry " + std::to_string(e), "holds a non-finite position");
      }
      entry.x.push_back(std::move(x));
    }
    out.push_back(std::move(entry));
  }
  return out;
}

FrameLog::FrameLog(OutputFolder& out, long keep, std::uint64_t hash,
                   const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  out.claim("checkpoint/");
  path_ = out.claim("checkpoint/frames.bin");
  hash_ = fnv1a(nullptr, 0);
  if (keep > 0) {
    std::vector<size_t> vertices;
    for (const auto& c : cloths) vertices.push_back(c->state().size());
    const std::string data = read_text_file(path_.string());
    kept_ = parse_frame_log(data, keep, vertices, path_.string());
    size_t bytes = 0;
    for (size_t v : vertices) bytes += v;
    bytes = sizeof(double) * (2 + 3 * bytes) * static_cast<size_t>(keep);
    hash_ = fnv1a(data.data(), bytes);
    if (hash_ != hash)
      throw Error(path_.string(), "--resume",
                  "the frame log changed since the checkpoint was written (hash mismatch)");
    file_.open(path_.string(), OutputMode::kAppend);
    file_.truncate(bytes);
  } else {
    file_.open(path_, std::ios::binary | std::ios::trunc);
  }
  if (!file_) throw Error(path_.string(), "", "cannot write the frame log");
  entries_ = keep;
}

void FrameLog::put(const void* p, size_t n) {
  file_.write(static_cast<const char*>(p), static_cast<std::streamsize>(n));
  hash_ = fnv1a(static_cast<const char*>(p), n, hash_);
}

void FrameLog::append(double time, int flags, const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  const double f = flags;
  put(&time, sizeof time);
  put(&f, sizeof f);
  for (const auto& c : cloths)
    for (const cloth::Vec3& p : c->state().x) put(p.data(), 3 * sizeof(double));
  if (!file_) throw Error(path_.string(), "", file_.write_failure());
  ++entries_;
}

}  // namespace loom::app
