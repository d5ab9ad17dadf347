#include "loom/eval/OutputFolder.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <random>
#include <sstream>
#include <vector>

#include "loom/cloth/Error.h"
#include "loom/cloth/OutputFile.h"
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

// What stands at a path, for messages: "a symbolic link", "a folder", "a FIFO", ...
std::string type_name(const fs::file_status& st) {
  switch (st.type()) {
    case fs::file_type::regular:
      return "a regular file";
    case fs::file_type::directory:
      return "a folder";
    case fs::file_type::symlink:
      return "a symbolic link";
    case fs::file_type::fifo:
      return "a FIFO";
    case fs::file_type::socket:
      return "a socket";
    case fs::file_type::character:
      return "a character device";
    case fs::file_type::block:
      return "a block device";
    default:
      return "of an unknown type";
  }
}

// True when a new run deletes the manifest entry `entry` ("frames/" a folder, else a file) found as `st`
// (never followed): only what a run made is deleted. A link is removed itself (never its target) whatever
// the entry; a listed file only as a regular file; a listed folder only as a folder (and only when empty,
// which remove_output checks). Anything else (a folder where a file was listed, a file, FIFO, socket or
// device where a folder was listed, a FIFO or device where a file was listed) is left alone.
bool deleted_as_listed(const std::string& entry, const fs::file_status& st) {
  if (fs::is_symlink(st)) return true;
  const bool folder = !entry.empty() && entry.back() == '/';
  return folder ? fs::is_directory(st) : fs::is_regular_file(st);
}

Manifest read_manifest(const fs::path& file, const std::string& flag) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(file.string(), flag, "cannot read the output folder's manifest");
  // A run of the longest allowed (1e7 frames) lists about 0.3 GB of paths.
  constexpr std::uintmax_t kMaxManifestBytes = std::uintmax_t(1) << 30;
  std::error_code ec;
  const std::uintmax_t bytes = fs::file_size(file, ec);
  if (!ec && bytes > kMaxManifestBytes)
    throw Error(file.string(), flag,
                "the output folder's manifest holds " + std::to_string(bytes) +
                    " bytes, more than a run lists (1 GiB): the manifest is corrupt, Loom deletes nothing it "
                    "lists");
  Manifest m;
  std::string line;
  int number = 0;
  // A listed path is at most PATH_MAX bytes: a longer line (a file of NUL bytes, one of gigabytes) is
  // refused when it passes that, not read whole.
  constexpr std::size_t kMaxLine = 4096 + 16;
  std::vector<char> buf(kMaxLine + 2);
  while (true) {
    in.getline(buf.data(), static_cast<std::streamsize>(buf.size()));
    const std::streamsize got = in.gcount();
    if (got == 0 && !in) break;  // the end
    if (in.fail() && !in.eof())  // the buffer filled before a newline came
      throw Error(file.string(), "line " + std::to_string(number + 1),
                  "longer than " + std::to_string(kMaxLine) +
                      " bytes: not a path inside the output folder; the manifest is corrupt, Loom deletes "
                      "nothing it lists");
    const bool newline = !in.eof();  // getline counts the newline it took in gcount
    line.assign(buf.data(), static_cast<std::size_t>(got - (newline ? 1 : 0)));
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

// One flock on one folder, shared by every FolderLock of the process that needs it: a second flock on
// another descriptor of the same folder would refuse the process itself.
struct detail::Flock {
  int fd = -1;
  bool exclusive = false;
  ~Flock() { ::close(fd); }  // closing the last descriptor releases the flock
};

namespace {

using detail::Flock;

std::mutex held_mutex;
std::map<std::pair<dev_t, ino_t>, std::weak_ptr<Flock>> held;  // guarded by held_mutex

// The path the system gives an open folder (/proc/self/fd), or `fallback`.
std::string path_of(int fd, const std::string& fallback) {
  char buf[4096];
  const std::string link = "/proc/self/fd/" + std::to_string(fd);
  const ssize_t n = ::readlink(link.c_str(), buf, sizeof buf - 1);
  return n > 0 ? std::string(buf, static_cast<size_t>(n)) : fallback;
}

// Locks the folder open at `fd` (taken over: closed unless kept). nullptr with `*err` = errno when another
// process holds a conflicting lock (EWOULDBLOCK) or flock fails; within the process a lock already held is
// returned (a shared one where an exclusive one is asked: EWOULDBLOCK, this command holds a folder below).
std::shared_ptr<Flock> lock_folder(int fd, bool exclusive, int* err) {
  struct stat st;
  if (::fstat(fd, &st) != 0) {
    *err = errno;
    ::close(fd);
    return nullptr;
  }
  std::lock_guard<std::mutex> guard(held_mutex);
  const auto key = std::make_pair(st.st_dev, st.st_ino);
  if (auto live = held[key].lock()) {
    ::close(fd);
    if (exclusive && !live->exclusive) {
      *err = EWOULDBLOCK;
      return nullptr;
    }
    return live;
  }
  if (::flock(fd, (exclusive ? LOCK_EX : LOCK_SH) | LOCK_NB) != 0) {
    *err = errno;
    ::close(fd);
    return nullptr;
  }
  auto lock = std::make_shared<Flock>();
  lock->fd = fd;
  lock->exclusive = exclusive;
  held[key] = lock;
  return lock;
}

// A folder below `folder` (a path from path_of) that another process holds exclusively, found through
// /proc/locks ("N: FLOCK ADVISORY WRITE PID MAJ:MIN:INODE 0 EOF") and that process's open descriptors; ""
// when none can be named.
std::string held_folder_below(const std::string& folder) {
  std::ifstream locks("/proc/locks");
  std::string line;
  const std::string own = std::to_string(::getpid());
  while (std::getline(locks, line)) {
    std::istringstream in(line);
    std::string id, kind, advisory, mode, pid, device;
    in >> id >> kind;
    if (kind == "->") in >> kind;  // a waiting request
    in >> advisory >> mode >> pid >> device;
    if (kind != "FLOCK" || mode != "WRITE" || pid == own) continue;
    const size_t colon = device.find_last_of(':');
    if (colon == std::string::npos) continue;
    const std::string inode = device.substr(colon + 1);
    std::error_code ec;
    for (fs::directory_iterator it("/proc/" + pid + "/fd", ec), end; !ec && it != end; it.increment(ec)) {
      struct stat st;
      if (::stat(it->path().c_str(), &st) != 0 || !S_ISDIR(st.st_mode) || std::to_string(st.st_ino) != inode)
        continue;
      const std::string path = fs::read_symlink(it->path(), ec).string();
      if (!ec && path.size() > folder.size() + 1 && path.compare(0, folder.size(), folder) == 0 &&
          (folder == "/" || path[folder.size()] == '/'))
        return path;
    }
  }
  return "";
}

[[noreturn]] void throw_in_use(const fs::path& named, const std::string& flag, const std::string& why) {
  throw Error(named.string(), "",
              "in use by another loom command (" + why +
                  "): wait for it to finish or choose another output folder (" + flag + ")");
}

}  // namespace

std::shared_ptr<FolderLock> FolderLock::acquire(const fs::path& dir, const std::string& flag, bool exclusive,
                                                const fs::path& named_as) {
  const fs::path named = named_as.empty() ? dir : named_as;
  std::string trimmed = dir.string();
  while (trimmed.size() > 1 && trimmed.back() == '/') trimmed.pop_back();
  const int fd = ::open(trimmed.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return nullptr;
  std::shared_ptr<FolderLock> lock(new FolderLock());
  // The folders above, shared, from the folder's own ".." up to the root (the folders the system reaches,
  // whatever links the path went through). One that cannot be read is passed over.
  int at = ::open(trimmed.c_str(), O_PATH | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  const std::string self_path = path_of(fd, dir.string());
  while (at >= 0) {
    const int up = ::openat(at, "..", O_PATH | O_DIRECTORY | O_CLOEXEC);
    struct stat a, b;
    const bool top = up < 0 || ::fstat(at, &a) != 0 || ::fstat(up, &b) != 0 ||
                     (a.st_dev == b.st_dev && a.st_ino == b.st_ino);
    ::close(at);
    at = -1;
    if (top) {
      if (up >= 0) ::close(up);
      break;
    }
    at = up;
    const int readable = ::openat(up, ".", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (readable < 0) continue;
    const std::string above = path_of(readable, "a folder above it");
    int err = 0;
    auto shared = lock_folder(readable, false, &err);
    if (!shared) {
      ::close(at);
      ::close(fd);
      if (err == EWOULDBLOCK)
        throw_in_use(named, flag, "it lies inside " + above + ", which another loom command is using");
      throw Error(above, flag, std::string("cannot lock the folder: ") + std::strerror(err));
    }
    lock->above_.push_back(std::move(shared));
  }
  int err = 0;
  const int probe = exclusive ? ::dup(fd) : -1;  // to tell "the folder" from "a folder below" on refusal
  lock->self_ = lock_folder(fd, exclusive, &err);
  if (!lock->self_) {
    if (err != EWOULDBLOCK) {
      if (probe >= 0) ::close(probe);
      throw Error(dir.string(), flag, std::string("cannot lock the output folder: ") + std::strerror(err));
    }
    // Exclusive refused: another command holds the folder itself, or only shared locks (a command using a
    // folder below it).
    const bool below = probe >= 0 && ::flock(probe, LOCK_SH | LOCK_NB) == 0;
    if (probe >= 0) ::close(probe);
    if (!below && !named_as.empty() && named_as != dir)
      throw_in_use(named, flag, "it lies inside " + self_path + ", which another loom command is using");
    if (!below) throw_in_use(named, flag, "it holds the folder's lock");
    const std::string inner = held_folder_below(self_path);
    throw_in_use(named, flag,
                 "it contains " + (inner.empty() ? std::string("a folder") : inner) +
                     ", which another loom command is using");
  }
  if (probe >= 0) ::close(probe);
  return lock;
}

std::uint64_t read_run_id(const fs::path& dir) {
  const fs::path file = dir / OutputFolder::kManifest;
  std::error_code ec;
  if (!fs::is_regular_file(fs::symlink_status(file, ec))) return 0;
  return read_manifest(file, "--resume").run_id;
}

namespace {

// Refuses (naming the path) a regular file at a path the run writes whose data another name shares (a hard
// link: st_nlink > 1): a write or an append in place there would change the other file too, which may lie
// outside the folder or be an input of the run.
void refuse_shared_file(const fs::path& at, const std::string& flag) {
  struct stat st;
  if (::lstat(at.c_str(), &st) == 0 && S_ISREG(st.st_mode) && st.st_nlink > 1)
    throw Error(at.string(), flag,
                "is a hard link (" + std::to_string(st.st_nlink) +
                    " names share this file) where Loom writes: writing it would change the other names' "
                    "file too; remove it");
}

bool matches(const std::string& name, const std::string& pattern);

// True when the folder-relative path `r` is one of `writes` (patterns as OutputFolder's constructor takes).
bool is_written(const std::string& r, const std::vector<std::string>& writes) {
  for (const std::string& w : writes) {
    const size_t slash = w.find_last_of('/', w.size() > 1 ? w.size() - 2 : 0);
    const std::string parent = slash == std::string::npos ? "" : w.substr(0, slash + 1);
    if (r.compare(0, parent.size(), parent) == 0 && matches(r.substr(parent.size()), w.substr(parent.size())))
      return true;
  }
  return false;
}

[[noreturn]] void throw_input_listed(const std::string& input, const fs::path& dir, const std::string& flag) {
  throw Error(input, flag,
              "is an input of this run and a file an earlier run listed in " +
                  (dir / OutputFolder::kManifest).string() +
                  ", which a new run deletes first: the run would delete its own input; copy it out of the "
                  "folder or choose another output folder");
}

// Refuses an input of the run (the scene, a mesh, a clip) that is, by identity (device and inode, so also
// through a hard link or another path to it), a file at a path the run writes in `dir` or one listed in
// `gone` (the earlier runs' manifest, deleted first).
void refuse_inputs_written(const fs::path& dir, const std::vector<std::string>& writes,
                           const std::vector<std::string>& inputs, const std::string& flag,
                           const std::set<std::string>& gone) {
  std::map<std::pair<dev_t, ino_t>, std::string> ids;
  for (const std::string& in : inputs) {
    struct stat st;
    if (::stat(in.c_str(), &st) == 0 && S_ISREG(st.st_mode))
      ids.emplace(std::make_pair(st.st_dev, st.st_ino), in);
  }
  if (ids.empty()) return;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    struct stat st;
    if (::lstat(it->path().c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
    const auto found = ids.find({st.st_dev, st.st_ino});
    if (found == ids.end()) continue;
    const std::string r = it->path().lexically_relative(dir).generic_string();
    if (gone.count(r)) throw_input_listed(found->second, dir, flag);
    if (is_written(r, writes))
      throw Error(found->second, flag,
                  "is an input of this run and the same file as " + it->path().string() +
                      ", which the run writes: the run would replace its own input; choose another output "
                      "folder");
  }
}

// Refuses (naming the path) what would make writing `rel` fail: a symbolic link on the way or at the end, a
// file where a folder is needed, a folder where a file is written. `rel` ending in '/' is a folder. Paths in
// `gone` (an earlier run's manifest, deleted before this run writes) are not checked further.
void check_writable(const fs::path& dir, const std::string& relative, const std::string& flag,
                    const std::set<std::string>& gone = {}) {
  const bool folder = !relative.empty() && relative.back() == '/';
  const std::string rel = folder ? relative.substr(0, relative.size() - 1) : relative;
  std::error_code ec;
  fs::path at = dir;
  std::string so_far;
  const fs::path rp(rel);
  for (auto it = rp.begin(); it != rp.end(); ++it) {
    at /= *it;
    so_far += (so_far.empty() ? "" : "/") + it->string();
    const fs::file_status st = fs::symlink_status(at, ec);
    // A listed file or link is deleted before the run writes (a listed folder only when left empty), when
    // its type is the listed one (deleted_as_listed); what is left alone is checked as any path.
    if (!fs::is_directory(st) && ((gone.count(so_far) && deleted_as_listed(so_far, st)) ||
                                  (gone.count(so_far + "/") && deleted_as_listed(so_far + "/", st))))
      return;
    if (fs::is_symlink(st))
      throw Error(at.string(), flag,
                  "is a symbolic link inside the output folder: Loom never writes through a link there");
    const bool last = std::next(it) == rp.end();
    if (fs::exists(st) && !fs::is_directory(st) && (!last || folder))
      throw Error(at.string(), flag, "is a file where Loom writes a folder");
    // A folder the command writes into that another run owns: the two manifests would list one file.
    if (fs::is_directory(st) && (!last || folder) &&
        fs::exists(fs::symlink_status(at / OutputFolder::kManifest, ec)))
      throw Error(at.string(), flag,
                  "is the output folder of another loom run (it holds " +
                      std::string(OutputFolder::kManifest) +
                      "), where this command writes: choose an output folder that does not contain it");
    if (last && !folder && fs::is_directory(st))
      throw Error(at.string(), flag, "is a folder where Loom writes a file");
    // A FIFO, socket or device: opening it to write would block (a FIFO without a reader) or reach
    // something that is not a file.
    if (last && !folder && fs::exists(st) && !fs::is_regular_file(st))
      throw Error(at.string(), flag,
                  "is not a regular file (a FIFO, socket or device) where Loom writes a file: remove it");
    if (last && !folder && fs::is_regular_file(st)) refuse_shared_file(at, flag);
    if (!fs::exists(st)) return;  // nothing below a missing component
  }
}

// Refuses `dir` (not yet made, or a folder) inside a folder above it that holds a Loom manifest listing
// `dir`'s path there, a folder on its way or a path below it: `dir` is (or lies in) what that run made, so
// its files would mix with the listed ones and the next run there would delete them. The folders above are
// locked (shared) by the caller, so no command rewrites those manifests meanwhile. A folder above with an
// unreadable or corrupt manifest is not Loom's and is passed over.
void refuse_inside_listed(const fs::path& dir, const std::string& flag) {
  std::error_code ec;
  const fs::path self = fs::weakly_canonical(fs::absolute(dir, ec), ec);
  if (ec) return;
  for (fs::path above = self.parent_path(); !above.empty(); above = above.parent_path()) {
    const fs::path file = above / OutputFolder::kManifest;
    if (fs::is_regular_file(fs::symlink_status(file, ec))) {
      Manifest m;
      try {
        m = read_manifest(file, flag);
      } catch (const Error&) {
        m.entries.clear();
      }
      const std::string rel = self.lexically_relative(above).generic_string();
      for (const std::string& entry : m.entries) {
        const std::string e = entry.back() == '/' ? entry.substr(0, entry.size() - 1) : entry;
        const bool on_the_way = rel == e || rel.compare(0, e.size() + 1, e + "/") == 0;
        const bool below = e.compare(0, rel.size() + 1, rel + "/") == 0;
        if (on_the_way || below)
          throw Error(dir.string(), flag,
                      "lies inside " + above.string() + ", the output folder of an earlier loom run, whose " +
                          OutputFolder::kManifest + " lists '" + entry +
                          "' there: its files and this command's would mix, and the next run into " +
                          above.string() + " deletes what it lists; choose a folder outside it");
      }
    }
    if (above == above.root_path()) break;
  }
}

// True when `name` matches `pattern`, in which one '#' stands for one or more decimal digits.
bool matches(const std::string& name, const std::string& pattern) {
  const size_t hash = pattern.find('#');
  if (hash == std::string::npos) return name == pattern;
  const std::string head = pattern.substr(0, hash), tail = pattern.substr(hash + 1);
  if (name.size() <= head.size() + tail.size() || name.compare(0, head.size(), head) != 0 ||
      name.compare(name.size() - tail.size(), tail.size(), tail) != 0)
    return false;
  const std::string digits = name.substr(head.size(), name.size() - head.size() - tail.size());
  return digits.find_first_not_of("0123456789") == std::string::npos;
}

// check_writable for every path of `writes` (a '#' in the last component: every existing file of that
// pattern in its folder).
void check_all_writable(const fs::path& dir, const std::vector<std::string>& writes, const std::string& flag,
                        const std::set<std::string>& gone) {
  std::error_code ec;
  for (const std::string& w : writes) {
    const size_t slash = w.find_last_of('/', w.size() > 1 ? w.size() - 2 : 0);
    const std::string parent = slash == std::string::npos ? "" : w.substr(0, slash + 1);
    const std::string last = w.substr(parent.size());
    if (last.find('#') == std::string::npos) {
      check_writable(dir, w, flag, gone);
      continue;
    }
    if (!parent.empty()) check_writable(dir, parent, flag, gone);
    const fs::path folder = parent.empty() ? dir : dir / parent;
    if (!fs::is_directory(fs::symlink_status(folder, ec))) continue;
    for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec))
      if (matches(it->path().filename().string(), last))
        check_writable(dir, parent + it->path().filename().string(), flag, gone);
  }
}

}  // namespace

OutputFolder::OutputFolder(const fs::path& dir, const std::string& flag, bool overwrite, bool resume,
                           const std::vector<std::string>& writes, const std::vector<std::string>& inputs)
    : dir_(dir), flag_(flag), writes_(writes) {
  if (dir.empty()) throw Error("", flag, "is empty: give the output folder");
  std::error_code ec;
  // The folder itself is never a link (with or without a trailing '/'): writing or deleting through it would
  // reach a folder the user never named.
  fs::path named = dir;
  while (!named.has_filename() && named.has_relative_path()) named = named.parent_path();
  // "LINK/." and "LINK/.." name a folder through the link before them; looking at the last component alone
  // would resolve it.
  if (named.filename() == "." || named.filename() == "..")
    throw Error(dir.string(), flag,
                "ends in '" + named.filename().string() +
                    "': name the output folder itself (Loom checks that it is not a symbolic link)");
  if (fs::is_symlink(fs::symlink_status(named, ec)))
    throw Error(dir.string(), flag,
                "is a symbolic link: Loom never writes through a link; give the folder it points to");
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw Error(dir.string(), flag, "cannot create output folder: a file of that name exists");
  // Everything that could refuse the folder is checked before anything in it changes: a refused run leaves
  // the folder as it found it (no manifest, no deleted file, no new folder).
  const bool existed = fs::is_directory(dir, ec);
  if (!existed && resume)
    throw Error(dir.string(), flag,
                "holds no " + std::string(kManifest) + ": not a folder written by loom run");
  // The folders above are locked (shared, FolderLock) before the folder is made or read: one inside a folder
  // another command uses is refused before anything changes, and no manifest above changes meanwhile.
  std::shared_ptr<FolderLock> above;
  {
    fs::path parent = named.parent_path();
    while (!parent.empty() && !fs::is_directory(parent, ec)) parent = parent.parent_path();
    above = FolderLock::acquire(parent.empty() ? fs::path(".") : parent, flag, false, dir);
  }
  refuse_inside_listed(dir, flag);
  // The folder is locked before anything in it is read: a new one is made first (empty, so nothing below
  // can refuse it, unless another command took it meanwhile).
  struct RemoveIfRefused {  // the folders this command made (deepest first), left empty by a refusal below
    std::vector<fs::path> dirs;
    bool armed;
    ~RemoveIfRefused() {
      if (armed)
        for (const fs::path& d : dirs) ::rmdir(d.c_str());
    }
  } made{{}, !existed};
  if (!existed) {
    for (fs::path p = named; !p.empty() && !fs::exists(fs::symlink_status(p, ec)); p = p.parent_path())
      made.dirs.push_back(p);
    fs::create_directories(dir, ec);
    if (ec || !fs::is_directory(dir))
      throw Error(dir.string(), flag, "cannot create output folder: " + ec.message());
  }
  lock_ = FolderLock::acquire(dir, flag);
  if (!lock_) throw Error(dir.string(), flag, "cannot open the output folder");
  const fs::path manifest = dir / kManifest;
  const fs::file_status ms = fs::symlink_status(manifest, ec);
  Manifest old;
  if (fs::exists(ms)) {
    if (!fs::is_regular_file(ms))
      throw Error(manifest.string(), flag,
                  "is not a regular file (it is " + type_name(ms) + "): not a folder Loom owns");
    if (resume) refuse_shared_file(manifest, flag);  // appended to: the other names would change too
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
  {
    std::set<std::string> gone;  // a new run deletes what the earlier runs listed (links themselves) first
    if (!resume) gone.insert(old.entries.begin(), old.entries.end());
    const fs::path folder = fs::weakly_canonical(dir, ec);
    for (const std::string& in : inputs) {
      const fs::path rel = fs::weakly_canonical(in, ec).lexically_relative(folder);
      if (rel.empty() || *rel.begin() == "..") continue;
      if (is_written(rel.generic_string(), writes))
        throw Error(in, flag,
                    "is an input of this run and a file it writes in " + dir.string() +
                        ": the run would replace its own input; choose another output folder");
      if (gone.count(rel.generic_string())) throw_input_listed(in, dir, flag);
    }
    refuse_inputs_written(dir, writes, inputs, flag, gone);
    check_all_writable(dir, writes, flag, gone);
    if (!resume) check_writable(dir, std::string(kManifest) + ".tmp", flag);  // the new manifest's way in
  }
  made.armed = false;
  // From here every path under DIR is reached from this descriptor (OutputFile.h): a folder inside DIR
  // replaced by a link while the command runs is never followed.
  try {
    root_ = std::make_unique<OutputRoot>(dir.string());
  } catch (const Error& e) {
    throw Error(std::string(e.what()) + " (" + flag + ")");
  }
  if (resume) {
    run_id_ = old.run_id;
    listed_.insert(old.entries.begin(), old.entries.end());
    manifest_.open(manifest.string(), OutputMode::kAppend);
    return;
  }
  // A new run: what the earlier runs listed goes (files, then folders that are left empty, deepest first).
  std::vector<std::string> entries = old.entries;
  std::sort(entries.begin(), entries.end(),
            [](const std::string& a, const std::string& b) { return a.size() > b.size(); });
  for (const std::string& entry : entries) {
    // A folder entry ("frames/") is looked at without its '/': with it, a link there would be followed.
    const bool folder = entry.back() == '/';
    const std::string rel = folder ? entry.substr(0, entry.size() - 1) : entry;
    // An entry whose type changed is not what the run made: left alone (deleted_as_listed).
    const fs::file_status st = fs::symlink_status(dir / rel, ec);
    if (fs::exists(st) && !deleted_as_listed(entry, st)) continue;
    // A file, a link itself (never its target) or an empty folder; nothing under a link on the way.
    remove_output((dir / rel).string());
  }
  std::random_device rd;
  run_id_ = (static_cast<std::uint64_t>(rd()) << 32) ^ rd() ^ 0x9e3779b97f4a7c15ull;
  if (run_id_ == 0) run_id_ = 1;
  const fs::path tmp = dir / (std::string(kManifest) + ".tmp");
  write_file_atomically(manifest.string(), tmp.string(), kHeader + hex(run_id_) + "\n");
  manifest_.open(manifest.string(), OutputMode::kAppend);
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
  // Only a path the pre-flight check saw may be written: one it did not check could be anything.
  if (!writes_.empty() && !is_written(relative, writes_))
    throw Error((dir_ / relative).string(), flag_,
                "is not among the paths this command checked before it started; Loom does not write it");
  check_writable(dir_, relative, flag_);
  if (!listed_.count(relative)) {
    append(relative);
    listed_.insert(relative);
  }
  if (folder) make_output_folder((dir_ / rel).string());
  return dir_ / rel;
}

void OutputFolder::remove_owned(const std::string& relative) {
  if (!listed_.count(relative) || under_a_link(dir_, relative)) return;
  std::error_code ec;
  const fs::path p = dir_ / relative;
  const fs::file_status st = fs::symlink_status(p, ec);
  if (fs::exists(st) && !fs::is_directory(st)) remove_output(p.string());
}

void refuse_linked_default(const fs::path& dir, const std::string& flag) {
  std::error_code ec;
  fs::path at;
  for (const fs::path& part : dir) {
    at /= part;
    if (fs::is_symlink(fs::symlink_status(at, ec)))
      throw Error(at.string(), flag,
                  "is a symbolic link on the way to the default output folder " + dir.string() +
                      ": Loom chose that path, so it does not write through the link; give " + flag + " DIR");
  }
}

fs::path OutputFolder::claim_private_folder(const std::string& stem, const std::vector<std::string>& files,
                                            int* fd) {
  std::random_device rd;
  for (int attempt = 0; attempt < 16; ++attempt) {
    const std::string name = stem + std::to_string(rd() % 1000000000u) + "/";
    if (!valid_entry(name.substr(0, name.size() - 1)))
      throw Error((dir_ / name).string(), flag_, "is not a path inside the output folder");
    if (listed_.count(name)) continue;
    append(name);  // listed first: deleted by the next run, empty or not, once its files are gone
    listed_.insert(name);
    for (const std::string& f : files) {
      append(name + f);
      listed_.insert(name + f);
    }
    const fs::path p = dir_ / name.substr(0, name.size() - 1);  // no trailing '/': filename() is the name
    const int made = make_private_output_folder(p.string());    // -1: the name exists
    if (made >= 0) {
      if (fd)
        *fd = made;
      else
        ::close(made);
      return p;
    }
  }
  throw Error((dir_ / stem).string(), flag_, "cannot find a fresh name for a private folder");
}

}  // namespace loom::eval
