#include "Checkpoint.h"

#include <cstring>
#include <nlohmann/json.hpp>
#include <sstream>

#include "loom/cloth/Error.h"

namespace fs = std::filesystem;

namespace loom::app {

namespace {
constexpr const char* kMagic = "LOOMCKPT1\n";
fs::path checkpoint_file(const fs::path& out) { return out / "checkpoint" / "checkpoint.bin"; }
}  // namespace

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "", "cannot open file");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string kept_stats_rows(const fs::path& out, int frame) {
  const fs::path partial = out / "stats.csv.partial", done = out / "stats.csv";
  const fs::path from = fs::exists(partial) ? partial : done;
  if (!fs::exists(from)) throw Error(done.string(), "--resume", "missing: the run's stats are needed to resume");
  std::istringstream in(read_text_file(from.string()));
  std::string line, rows;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (std::atoi(line.c_str()) > frame) break;
    rows += line + "\n";
  }
  return rows;
}

void write_checkpoint(const fs::path& out, const Checkpoint& c) {
  nlohmann::json j;
  j["scene"] = c.scene;
  j["scene_text"] = c.scene_text;
  j["sets"] = c.sets;
  j["frames_total"] = c.frames_total;
  j["threads"] = c.threads;
  j["checkpoint_every"] = c.checkpoint_every;
  j["render"] = c.render;
  j["frame"] = c.frame;
  j["max_strain"] = c.max_strain;
  j["mean_strain_sum"] = c.mean_strain_sum;
  j["sim_ms"] = c.sim_ms;
  j["logged_frames"] = c.logged_frames;
  const std::string header = j.dump();
  const fs::path path = checkpoint_file(out);
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    const std::uint64_t hn = header.size(), sn = c.state.size();
    f << kMagic;
    f.write(reinterpret_cast<const char*>(&hn), sizeof hn);
    f << header;
    f.write(reinterpret_cast<const char*>(&sn), sizeof sn);
    f << c.state;
    f.flush();
    if (!f) throw Error(tmp.string(), "", "cannot write checkpoint");
  }
  fs::rename(tmp, path, ec);
  if (ec) throw Error(path.string(), "", "cannot move the checkpoint into place: " + ec.message());
}

Checkpoint read_checkpoint(const fs::path& out) {
  const fs::path path = checkpoint_file(out);
  if (!fs::exists(path)) throw Error(path.string(), "--resume", "no checkpoint here (write one with --checkpoint-every N)");
  const std::string data = read_text_file(path.string());
  const size_t m = std::strlen(kMagic);
  auto bad = [&](const std::string& what) { return Error(path.string(), "", "not a valid checkpoint: " + what); };
  if (data.compare(0, m, kMagic) != 0) throw bad("wrong header");
  size_t pos = m;
  auto u64 = [&](const char* what) {
    std::uint64_t v;
    if (data.size() - pos < sizeof v) throw bad(std::string("cut short before the ") + what);
    std::memcpy(&v, data.data() + pos, sizeof v);
    pos += sizeof v;
    return v;
  };
  const std::uint64_t hn = u64("header");
  if (hn > data.size() - pos) throw bad("cut short in the header");
  Checkpoint c;
  try {
    const nlohmann::json j = nlohmann::json::parse(data.substr(pos, hn));
    c.scene = j.at("scene").get<std::string>();
    c.scene_text = j.at("scene_text").get<std::string>();
    c.sets = j.at("sets").get<std::vector<std::string>>();
    c.frames_total = j.at("frames_total").get<int>();
    c.threads = j.at("threads").get<int>();
    c.checkpoint_every = j.at("checkpoint_every").get<int>();
    c.render = j.at("render").get<bool>();
    c.frame = j.at("frame").get<int>();
    c.max_strain = j.at("max_strain").get<double>();
    c.mean_strain_sum = j.at("mean_strain_sum").get<double>();
    c.sim_ms = j.at("sim_ms").get<double>();
    c.logged_frames = j.at("logged_frames").get<long>();
  } catch (const nlohmann::json::exception& e) {
    throw bad(std::string("header: ") + e.what());
  }
  pos += hn;
  const std::uint64_t sn = u64("state");
  if (sn != data.size() - pos) throw bad("the state is cut short or has trailing bytes");
  c.state = data.substr(pos);
  return c;
}

FrameLog::FrameLog(const fs::path& out, long keep, const std::vector<std::unique_ptr<cloth::Cloth>>& cloths)
    : path_(out / "checkpoint" / "frames.bin") {
  size_t vertices = 0;
  for (const auto& c : cloths) vertices += c->state().size();
  entry_bytes_ = sizeof(double) * (2 + 3 * vertices);
  std::error_code ec;
  fs::create_directories(path_.parent_path(), ec);
  if (keep > 0) {
    const std::string data = read_text_file(path_.string());
    if (data.size() < entry_bytes_ * static_cast<size_t>(keep))
      throw Error(path_.string(), "", "frame log is shorter than the checkpoint says (" + std::to_string(keep) + " frames)");
    size_t pos = 0;
    for (long e = 0; e < keep; ++e) {
      double time, flags;
      std::memcpy(&time, data.data() + pos, sizeof time);
      pos += sizeof time;
      std::memcpy(&flags, data.data() + pos, sizeof flags);
      pos += sizeof flags;
      std::vector<cloth::Vec3s> xs;
      for (const auto& c : cloths) {
        cloth::Vec3s x(c->state().size());
        for (cloth::Vec3& p : x) {
          std::memcpy(p.data(), data.data() + pos, 3 * sizeof(double));
          pos += 3 * sizeof(double);
        }
        xs.push_back(std::move(x));
      }
      kept_.push_back(Entry{time, static_cast<int>(flags), std::move(xs)});
    }
    fs::resize_file(path_, entry_bytes_ * static_cast<size_t>(keep), ec);
    if (ec) throw Error(path_.string(), "", "cannot truncate the frame log: " + ec.message());
    file_.open(path_, std::ios::binary | std::ios::app);
  } else {
    file_.open(path_, std::ios::binary | std::ios::trunc);
  }
  if (!file_) throw Error(path_.string(), "", "cannot write the frame log");
  entries_ = keep;
}

void FrameLog::append(double time, int flags, const std::vector<std::unique_ptr<cloth::Cloth>>& cloths) {
  const double f = flags;
  file_.write(reinterpret_cast<const char*>(&time), sizeof time);
  file_.write(reinterpret_cast<const char*>(&f), sizeof f);
  for (const auto& c : cloths)
    for (const cloth::Vec3& p : c->state().x) file_.write(reinterpret_cast<const char*>(p.data()), 3 * sizeof(double));
  if (!file_) throw Error(path_.string(), "", "write failed");
  ++entries_;
}

}  // namespace loom::app
