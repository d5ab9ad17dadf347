#include "loom/eval/OutputFolder.h"

#include <algorithm>
#include <cstdio>
#include <random>
#include <sstream>
#include <vector>

#include "loom/cloth/Error.h"
#include "loom/eval/Hex.h"

namespace fs = std::filesystem;

namespace loom::eval {

namespace {

// True when a folder on the way from `dir` to dir/rel (rel's parents, not rel itself) is a symbolic link: a
// forged manifest entry such as "frames/link/file" must never delete through the link.
bool under_a_link(const fs::path& dir, const std::string& rel) {
  std::error_code ec;
  fs::path at = dir;
  const fs::path rp(rel);
  for (auto it = rp.begin(); it != rp.end() && std::next(it) != rp.end(); ++it) {
    at /= *it;
    if (fs::is_symlink(fs::symlink_status(at, ec))) return true;
  }
  return false;
}

constexpr const char* kHeader = "loom-manifest 1 run ";

// A manifest line is a path relative to the folder: no root, no "..", no control character.
bool valid_entry(const std::string& rel) {
  if (rel.empty() || rel.size() > 4096) return false;
  for (unsigned char ch : rel)
    if (ch < 0x20 || ch == 0x7f) return false;
  const fs::path p(rel);
  if (p.is_absolute() || p.has_root_name() || p.has_root_directory()) return false;
  for (const fs::path& part : p)
    if (part == "..") return false;
  return true;
}

struct Manifest {
  std::uint64_t run_id = 0;
  std::vector<std::string> entries;
};

Manifest read_manifest(const fs::path& file, const std::string& flag) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(file.string(), flag, "cannot read the output folder's manifest");
  Manifest m;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (number == 1) {
      const std::string h(kHeader);
      if (line.compare(0, h.size(), h) != 0 || line.size() != h.size() + 16 ||
          line.find_first_not_of("0123456789abcdef", h.size()) != std::string::npos)
        throw Error(file.string(), "line 1", "not a Loom manifest (expected '" + h + "<16 hex digits>')");
      m.run_id = std::stoull(line.substr(h.size()), nullptr, 16);
      continue;
    }
    if (!valid_entry(line))
      throw Error(
          file.string(), "line " + std::to_string(number),
          "not a path inside the output folder: the manifest is corrupt, Loom deletes nothing it lists");
    m.entries.push_back(line);
  }
  if (number == 0) throw Error(file.string(), "line 1", "empty manifest");
  return m;
}

}  // namespace

std::uint64_t read_run_id(const fs::path& dir) {
  const fs::path file = dir / OutputFolder::kManifest;
  std::error_code ec;
  if (!fs::is_regular_file(fs::symlink_status(file, ec))) return 0;
  return read_manifest(file, "--resume").run_id;
}

OutputFolder::OutputFolder(const fs::path& dir, const std::string& flag, bool overwrite, bool resume)
    : dir_(dir), flag_(flag) {
  if (dir.empty()) throw Error("", flag, "is empty: give the output folder");
  std::error_code ec;
  // The folder itself is never a link (with or without a trailing '/'): writing or deleting through it would
  // reach a folder the user never named.
  fs::path named = dir;
  while (!named.has_filename() && named.has_relative_path()) named = named.parent_path();
  if (fs::is_symlink(fs::symlink_status(named, ec)))
    throw Error(dir.string(), flag,
                "is a symbolic link: Loom never writes through a link; give the folder it points to");
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw Error(dir.string(), flag, "cannot create output folder: a file of that name exists");
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw Error(dir.string(), flag, "cannot create output folder: " + ec.message());
  const fs::path manifest = dir / kManifest;
  const fs::file_status ms = fs::symlink_status(manifest, ec);
  Manifest old;
  if (fs::exists(ms)) {
    if (!fs::is_regular_file(ms))
      throw Error(manifest.string(), flag,
                  "is not a regular file (a link or a folder): not a folder Loom owns");
    old = read_manifest(manifest, flag);
  } else {
    if (resume)
      throw Error(dir.string(), flag,
                  "holds no " + std::string(kManifest) + ": not a folder written by loom run");
    const bool empty = fs::directory_iterator(dir, ec) == fs::directory_iterator();
    if (!empty && !overwrite)
      throw Error(
          dir.string(), flag,
          "is not empty and was not written by loom run (no " + std::string(kManifest) +
              "): choose a new or empty folder, or pass --overwrite to write into it (files of the names "
              "Loom writes are then replaced; nothing else is deleted)");
  }
  if (resume) {
    run_id_ = old.run_id;
    listed_.insert(old.entries.begin(), old.entries.end());
    manifest_.open(manifest, std::ios::binary | std::ios::app);
    if (!manifest_) throw Error(manifest.string(), flag, "output folder is not writable");
    return;
  }
  // A new run: what the earlier runs listed goes (files, then folders that are left empty, deepest first).
  std::vector<std::string> entries = old.entries;
  std::sort(entries.begin(), entries.end(),
            [](const std::string& a, const std::string& b) { return a.size() > b.size(); });
  for (const std::string& rel : entries) {
    if (under_a_link(dir, rel)) continue;
    const fs::path p = dir / rel;
    const fs::file_status st = fs::symlink_status(p, ec);
    if (!fs::exists(st)) continue;
    if (fs::is_directory(st)) {
      if (fs::is_empty(p, ec)) fs::remove(p, ec);
    } else {
      fs::remove(p, ec);  // a file, or a link itself (never its target)
    }
  }
  std::random_device rd;
  run_id_ = (static_cast<std::uint64_t>(rd()) << 32) ^ rd() ^ 0x9e3779b97f4a7c15ull;
  if (run_id_ == 0) run_id_ = 1;
  const fs::path tmp = dir / (std::string(kManifest) + ".tmp");
  fs::remove(tmp, ec);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << kHeader << hex(run_id_) << "\n";
    if (!out) throw Error(dir.string(), flag, "output folder is not writable");
  }
  fs::rename(tmp, manifest, ec);
  if (ec) throw Error(manifest.string(), flag, "cannot write the manifest: " + ec.message());
  manifest_.open(manifest, std::ios::binary | std::ios::app);
  if (!manifest_) throw Error(manifest.string(), flag, "output folder is not writable");
}

void OutputFolder::append(const std::string& line) {
  manifest_ << line << "\n";
  manifest_.flush();
  if (!manifest_) throw Error((dir_ / kManifest).string(), flag_, "write failed");
}

fs::path OutputFolder::claim(const std::string& relative) {
  const bool folder = !relative.empty() && relative.back() == '/';
  const std::string rel = folder ? relative.substr(0, relative.size() - 1) : relative;
  if (!valid_entry(rel))
    throw Error((dir_ / relative).string(), flag_, "is not a path inside the output folder");
  std::error_code ec;
  fs::path at = dir_;
  const fs::path rp(rel);
  for (auto it = rp.begin(); it != rp.end(); ++it) {
    at /= *it;
    const fs::file_status st = fs::symlink_status(at, ec);
    if (fs::is_symlink(st))
      throw Error(at.string(), flag_,
                  "is a symbolic link: Loom never writes through a link in its output folder");
    const bool last = std::next(it) == rp.end();
    if (fs::exists(st) && !fs::is_directory(st) && (!last || folder))
      throw Error(at.string(), flag_, "is a file where Loom writes a folder");
    if (last && !folder && fs::is_directory(st))
      throw Error(at.string(), flag_, "is a folder where Loom writes a file");
  }
  if (!listed_.count(relative)) {
    append(relative);
    listed_.insert(relative);
  }
  if (folder) {
    fs::create_directories(at, ec);
    if (ec) throw Error(at.string(), flag_, "cannot create folder: " + ec.message());
  }
  return dir_ / rel;
}

void OutputFolder::remove_owned(const std::string& relative) {
  if (!listed_.count(relative) || under_a_link(dir_, relative)) return;
  std::error_code ec;
  const fs::path p = dir_ / relative;
  const fs::file_status st = fs::symlink_status(p, ec);
  if (fs::exists(st) && !fs::is_directory(st)) fs::remove(p, ec);
}

}  // namespace loom::eval
