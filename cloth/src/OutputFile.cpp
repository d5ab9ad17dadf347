#include "loom/cloth/OutputFile.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

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

int open_checked(const std::string& path, OutputMode mode) {
  if (path.empty()) throw Error(path, "", "cannot write a file of an empty name");
  constexpr int kCommon = O_WRONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC;
  int fd = -1;
  if (mode == OutputMode::kReplace) {
    struct stat st;
    if (::lstat(path.c_str(), &st) == 0) {
      if (!S_ISREG(st.st_mode)) refuse(path, st.st_mode);
      if (::unlink(path.c_str()) != 0 && errno != ENOENT)
        throw Error(path, "", std::string("cannot replace: ") + std::strerror(errno));
    }
    fd = ::open(path.c_str(), kCommon | O_CREAT | O_EXCL, 0666);
    if (fd < 0 && errno == EEXIST)
      throw Error(path, "",
                  "appeared while Loom was creating it: something else writes into the output folder");
  } else {
    fd = ::open(path.c_str(), kCommon | O_APPEND);
  }
  if (fd < 0) {
    const int e = errno;
    struct stat st;
    // O_NOFOLLOW on a link fails with ELOOP; O_NONBLOCK on a FIFO without a reader with ENXIO.
    if ((e == ELOOP || e == ENXIO || e == EISDIR) && ::lstat(path.c_str(), &st) == 0)
      refuse(path, st.st_mode);
    throw Error(path, "", std::string("cannot write: ") + std::strerror(e));
  }
  struct stat st;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    const mode_t m = st.st_mode;
    ::close(fd);
    refuse(path, m);
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
    if (n <= 0) return false;
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
    if (w <= 0) break;
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

void OutputFile::truncate(std::uint64_t bytes) {
  if (!open_ || !buf_->truncate(bytes))
    throw Error(path_, "", std::string("cannot truncate: ") + std::strerror(errno));
}

void write_file_atomically(const std::string& path, const std::string& tmp, const std::string& data) {
  {
    OutputFile out(tmp);
    out << data;
    out.close();
    if (!out) throw Error(tmp, "", "write failed");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw Error(path, "", std::string("cannot move into place: ") + std::strerror(errno));
}

}  // namespace loom
