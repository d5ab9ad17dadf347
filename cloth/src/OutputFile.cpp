#include "loom/cloth/OutputFile.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <vector>

#include "loom/cloth/Error.h"

namespace loom {

namespace {

// What a non-regular file at a path is, for error messages.
std::string kind_of(mode_t m) {
  if (S_ISLNK(m)) return "a symbolic link";
  if (S_ISDIR(m)) return "a folder";
  if (S_ISFIFO(m)) return "a FIFO";
  if (S_ISSOCK(m)) return "a socket";
  if (S_ISCHR(m) || S_ISBLK(m)) return "a device";
  return "not a regular file";
}

[[noreturn]] void refuse(const std::string& path, mode_t m) {
  throw Error(path, "",
              "is " + kind_of(m) +
                  ", not a regular file: Loom writes only regular files it creates; remove it and run again");
}

// The components of a path as written, without empty and "." ones; an absolute path starts with "/".
std::vector<std::string> components(const std::string& path) {
  std::vector<std::string> parts;
  if (!path.empty() && path[0] == '/') parts.push_back("/");
  size_t at = 0;
  while (at <= path.size()) {
    size_t end = path.find('/', at);
    if (end == std::string::npos) end = path.size();
    const std::string part = path.substr(at, end - at);
    if (!part.empty() && part != ".") parts.push_back(part);
    at = end + 1;
  }
  return parts;
}

struct RegisteredRoot {
  std::vector<std::string> parts;
  std::string text;  // as given, for messages
  int fd;
};

std::mutex& roots_mutex() {
  static std::mutex m;
  return m;
}

std::vector<RegisteredRoot>& roots() {
  static std::vector<RegisteredRoot> r;
  return r;
}

// Where a path is: the folder's descriptor (AT_FDCWD outside every registered root) and the last component.
class Located {
 public:
  Located() = default;
  Located(const Located&) = delete;
  Located& operator=(const Located&) = delete;
  ~Located() {
    if (fd_ >= 0) ::close(fd_);
  }
  int dir() const { return fd_ >= 0 ? fd_ : AT_FDCWD; }
  const std::string& name() const { return name_; }
  const std::string& shown() const { return shown_; }  // the path, for messages

  // Finds `path`; with `make`, creates the folders on the way that do not exist (and, `make_last`, the
  // last component as a folder too).
  void locate(const std::string& path, bool make, bool make_last = false) {
    shown_ = path;
    const std::vector<std::string> parts = components(path);
    std::lock_guard<std::mutex> lock(roots_mutex());
    const RegisteredRoot* best = nullptr;
    for (const RegisteredRoot& r : roots())
      if (r.parts.size() < parts.size() && std::equal(r.parts.begin(), r.parts.end(), parts.begin()) &&
          (!best || r.parts.size() > best->parts.size()))
        best = &r;
    if (!best) {
      name_ = path;
      return;
    }
    fd_ = ::fcntl(best->fd, F_DUPFD_CLOEXEC, 0);
    if (fd_ < 0) throw Error(path, "", std::string("cannot write: ") + std::strerror(errno));
    std::string so_far = best->text;
    const size_t last = parts.size() - 1;
    for (size_t k = best->parts.size(); k < parts.size(); ++k) {
      const std::string& part = parts[k];
      so_far += (so_far.empty() || so_far.back() == '/' ? "" : "/") + part;
      if (part == "..") throw Error(so_far, "", "leaves the output folder: Loom writes only inside it");
      if (k == last && !make_last) {
        name_ = part;
        return;
      }
      if (make && ::mkdirat(fd_, part.c_str(), 0777) != 0 && errno != EEXIST)
        throw Error(so_far, "", std::string("cannot create folder: ") + std::strerror(errno));
      const int next = ::openat(fd_, part.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
      if (next < 0) {
        const int e = errno;
        struct stat st;
        if (::fstatat(fd_, part.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISLNK(st.st_mode))
          throw Error(so_far, "",
                      "is a symbolic link inside the output folder: Loom never writes through a link there");
        if (e == ENOTDIR) throw Error(so_far, "", "is a file where Loom writes a folder");
        throw Error(so_far, "", std::string("cannot open folder: ") + std::strerror(e));
      }
      ::close(fd_);
      fd_ = next;
    }
    name_ = ".";
  }

 private:
  int fd_ = -1;
  std::string name_, shown_;
};

int open_checked(const std::string& path, OutputMode mode) {
  if (path.empty()) throw Error(path, "", "cannot write a file of an empty name");
  Located at;
  at.locate(path, false);
  const int dir = at.dir();
  const char* name = at.name().c_str();
  constexpr int kCommon = O_WRONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC;
  int fd = -1;
  if (mode == OutputMode::kReplace) {
    struct stat st;
    if (::fstatat(dir, name, &st, AT_SYMLINK_NOFOLLOW) == 0) {
      if (!S_ISREG(st.st_mode)) refuse(path, st.st_mode);
      if (::unlinkat(dir, name, 0) != 0 && errno != ENOENT)
        throw Error(path, "", std::string("cannot replace: ") + std::strerror(errno));
    }
    fd = ::openat(dir, name, kCommon | O_CREAT | O_EXCL, 0666);
    if (fd < 0 && errno == EEXIST)
      throw Error(path, "",
                  "appeared while Loom was creating it: something else writes into the output folder");
  } else {
    fd = ::openat(dir, name, kCommon | O_APPEND);
  }
  if (fd < 0) {
    const int e = errno;
    struct stat st;
    // O_NOFOLLOW on a link fails with ELOOP; O_NONBLOCK on a FIFO without a reader with ENXIO.
    if ((e == ELOOP || e == ENXIO || e == EISDIR) && ::fstatat(dir, name, &st, AT_SYMLINK_NOFOLLOW) == 0)
      refuse(path, st.st_mode);
    throw Error(path, "", std::string("cannot write: ") + std::strerror(e));
  }
  struct stat st;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    const mode_t m = st.st_mode;
    ::close(fd);
    refuse(path, m);
  }
  if (mode == OutputMode::kAppend && st.st_nlink > 1) {
    ::close(fd);
    throw Error(path, "",
                "is a hard link (" + std::to_string(st.st_nlink) +
                    " names share this file): appending to it would change the other names' file too; "
                    "remove it");
  }
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  return fd;
}

}  // namespace

FdStreamBuf::FdStreamBuf(int fd) : fd_(fd) { setp(buffer_, buffer_ + sizeof(buffer_)); }

FdStreamBuf::~FdStreamBuf() { close(); }

bool FdStreamBuf::flush_buffer() {
  const char* p = pbase();
  std::size_t left = static_cast<std::size_t>(pptr() - pbase());
  while (left > 0) {
    const ssize_t n = ::write(fd_, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      failed(n < 0 ? errno : ENOSPC);  // a write of 0 bytes: no room left
      return false;
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  setp(buffer_, buffer_ + sizeof(buffer_));
  return true;
}

FdStreamBuf::int_type FdStreamBuf::overflow(int_type ch) {
  if (fd_ < 0 || !flush_buffer()) return traits_type::eof();
  if (!traits_type::eq_int_type(ch, traits_type::eof())) {
    *pptr() = traits_type::to_char_type(ch);
    pbump(1);
  }
  return traits_type::not_eof(ch);
}

std::streamsize FdStreamBuf::xsputn(const char* s, std::streamsize n) {
  if (fd_ < 0) return 0;
  if (n <= epptr() - pptr()) {
    std::memcpy(pptr(), s, static_cast<std::size_t>(n));
    pbump(static_cast<int>(n));
    return n;
  }
  if (!flush_buffer()) return 0;
  std::streamsize done = 0;
  while (done < n) {
    const ssize_t w = ::write(fd_, s + done, static_cast<std::size_t>(n - done));
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      failed(w < 0 ? errno : ENOSPC);
      break;
    }
    done += w;
  }
  return done;
}

int FdStreamBuf::sync() { return fd_ >= 0 && flush_buffer() ? 0 : -1; }

FdStreamBuf::pos_type FdStreamBuf::seekoff(off_type off, std::ios_base::seekdir dir,
                                           std::ios_base::openmode) {
  if (fd_ < 0 || !flush_buffer()) return pos_type(off_type(-1));
  const int whence = dir == std::ios_base::beg ? SEEK_SET : dir == std::ios_base::cur ? SEEK_CUR : SEEK_END;
  const off_t at = ::lseek(fd_, static_cast<off_t>(off), whence);
  return at < 0 ? pos_type(off_type(-1)) : pos_type(static_cast<off_type>(at));
}

FdStreamBuf::pos_type FdStreamBuf::seekpos(pos_type pos, std::ios_base::openmode which) {
  return seekoff(off_type(pos), std::ios_base::beg, which);
}

bool FdStreamBuf::close() {
  if (fd_ < 0) return true;
  const bool flushed = flush_buffer();
  const bool closed = ::close(fd_) == 0;
  if (!closed) failed(errno);
  fd_ = -1;
  return flushed && closed;
}

bool FdStreamBuf::truncate(std::uint64_t bytes) {
  return fd_ >= 0 && flush_buffer() && ::ftruncate(fd_, static_cast<off_t>(bytes)) == 0;
}

OutputFile::OutputFile() : std::ostream(nullptr) {}

OutputFile::OutputFile(const std::string& path, std::ios::openmode mode) : OutputFile() { open(path, mode); }

OutputFile::OutputFile(const std::string& path, OutputMode mode) : OutputFile() { open(path, mode); }

OutputFile::~OutputFile() {
  if (buf_) buf_->close();
}

void OutputFile::open(const std::string& path, std::ios::openmode mode) {
  open(path, (mode & std::ios::app) ? OutputMode::kAppend : OutputMode::kReplace);
}

void OutputFile::open(const std::string& path, OutputMode mode) {
  close();
  path_ = path;
  buf_ = std::make_unique<FdStreamBuf>(open_checked(path, mode));
  rdbuf(buf_.get());
  clear();
  open_ = true;
}

void OutputFile::close() {
  if (!open_) return;
  open_ = false;
  if (!buf_->close()) setstate(std::ios::badbit);
}

std::string OutputFile::write_failure() const {
  const int e = buf_ ? buf_->error() : 0;
  return e ? std::string("write failed: ") + std::strerror(e) : std::string("write failed");
}

void OutputFile::truncate(std::uint64_t bytes) {
  if (!open_ || !buf_->truncate(bytes))
    throw Error(path_, "", std::string("cannot truncate: ") + std::strerror(errno));
}

void write_file_atomically(const std::string& path, const std::string& tmp, const std::string& data) {
  {
    OutputFile out(tmp);
    out << data;
    out.close();
    if (!out) throw Error(tmp, "", out.write_failure());
  }
  rename_output(tmp, path);
}

OutputRoot::OutputRoot(const std::string& dir) {
  std::string trimmed = dir;
  while (trimmed.size() > 1 && trimmed.back() == '/') trimmed.pop_back();
  fd_ = ::open(trimmed.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd_ < 0) {
    const int e = errno;
    struct stat st;
    if (::lstat(trimmed.c_str(), &st) == 0 && S_ISLNK(st.st_mode))
      throw Error(dir, "",
                  "is a symbolic link: Loom never writes through a link; give the folder it points to");
    throw Error(dir, "", std::string("cannot open the output folder: ") + std::strerror(e));
  }
  std::lock_guard<std::mutex> lock(roots_mutex());
  roots().push_back({components(dir), dir, fd_});
}

OutputRoot::~OutputRoot() {
  std::lock_guard<std::mutex> lock(roots_mutex());
  auto& r = roots();
  r.erase(std::remove_if(r.begin(), r.end(), [&](const RegisteredRoot& x) { return x.fd == fd_; }), r.end());
  ::close(fd_);
}

void make_output_folder(const std::string& path) {
  Located at;
  at.locate(path, true, true);
  if (at.dir() == AT_FDCWD) {  // outside every registered folder: as given
    std::string so_far;
    for (const std::string& part : components(path)) {
      so_far += (so_far.empty() || so_far.back() == '/' ? "" : "/") + part;
      if (::mkdir(so_far.c_str(), 0777) != 0 && errno != EEXIST)
        throw Error(so_far, "", std::string("cannot create folder: ") + std::strerror(errno));
    }
    struct stat st;
    if (::stat(path.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
      throw Error(path, "", "cannot create folder: a file of that name exists");
  }
}

int make_private_output_folder(const std::string& path) {
  Located at;
  at.locate(path, false);
  if (::mkdirat(at.dir(), at.name().c_str(), 0700) != 0) {
    if (errno == EEXIST) return -1;
    throw Error(path, "", std::string("cannot create folder: ") + std::strerror(errno));
  }
  const int fd = ::openat(at.dir(), at.name().c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) throw Error(path, "", std::string("cannot open folder: ") + std::strerror(errno));
  return fd;
}

void rename_output(const std::string& from, const std::string& to) {
  Located a, b;
  a.locate(from, false);
  b.locate(to, false);
  if (::renameat(a.dir(), a.name().c_str(), b.dir(), b.name().c_str()) != 0)
    throw Error(to, "", std::string("cannot move into place: ") + std::strerror(errno));
}

bool remove_output(const std::string& path) {
  try {
    Located at;
    at.locate(path, false);
    struct stat st;
    if (::fstatat(at.dir(), at.name().c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0) return errno == ENOENT;
    return ::unlinkat(at.dir(), at.name().c_str(), S_ISDIR(st.st_mode) ? AT_REMOVEDIR : 0) == 0;
  } catch (const Error&) {
    return false;
  }
}

}  // namespace loom
