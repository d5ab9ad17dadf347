#pragma once
// The one way Loom writes a file (run outputs, temporary *.partial/*.tmp files, checkpoints, the output
// folder's manifest, images): an std::ostream over a file descriptor opened so that nothing planted at the
// path is ever written through or waited on.
//   - kReplace: an existing regular file at the path is unlinked (its other hard links, if any, keep their
//     contents) and a new file is created with O_CREAT | O_EXCL | O_NOFOLLOW | O_NONBLOCK, so a symbolic
//     link, a FIFO, a socket, a device or a folder at the path is refused instead of followed, opened or
//     blocked on (a FIFO without a reader would block a plain open forever).
//   - kAppend: the path must already be a regular file (O_NOFOLLOW | O_NONBLOCK, then fstat).
// After the open, fstat must report a regular file and O_NONBLOCK is cleared. Every refusal is a loom::Error
// naming the path and what is there. Write errors set badbit as std::ofstream does.
#include <cstdint>
#include <memory>
#include <ostream>
#include <streambuf>
#include <string>

namespace loom {

enum class OutputMode { kReplace, kAppend };

// The buffered stream buffer over a POSIX file descriptor that OutputFile writes through (seekable, so a
// header can be patched at the end).
class FdStreamBuf : public std::streambuf {
 public:
  explicit FdStreamBuf(int fd);
  ~FdStreamBuf() override;
  FdStreamBuf(const FdStreamBuf&) = delete;
  FdStreamBuf& operator=(const FdStreamBuf&) = delete;
  // Flushes and closes the descriptor; false when a write or the close failed.
  bool close();
  // Flushes and cuts the file to `bytes`; false on failure.
  bool truncate(std::uint64_t bytes);

 protected:
  int_type overflow(int_type ch) override;
  std::streamsize xsputn(const char* s, std::streamsize n) override;
  int sync() override;
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode which) override;
  pos_type seekpos(pos_type pos, std::ios_base::openmode which) override;

 private:
  bool flush_buffer();
  int fd_;
  char buffer_[1 << 16];
};

class OutputFile : public std::ostream {
 public:
  OutputFile();
  // Opens `path` (throws loom::Error naming it when refused). `mode` as std::ofstream's: std::ios::app
  // appends to an existing regular file, anything else replaces.
  explicit OutputFile(const std::string& path, std::ios::openmode mode = std::ios::out);
  OutputFile(const std::string& path, OutputMode mode);
  ~OutputFile() override;
  void open(const std::string& path, std::ios::openmode mode = std::ios::out);
  void open(const std::string& path, OutputMode mode);
  bool is_open() const { return open_; }
  // Flushes and closes; sets badbit when a write or the close failed.
  void close();
  // Cuts the open file to `bytes` (an appended log kept up to a checkpoint); throws loom::Error on failure.
  void truncate(std::uint64_t bytes);
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::unique_ptr<FdStreamBuf> buf_;
  bool open_ = false;
};

// Writes `data` to the temporary file `tmp` (kReplace) and renames it to `path`, so a reader never sees half
// a file. Throws loom::Error naming the file on failure.
void write_file_atomically(const std::string& path, const std::string& tmp, const std::string& data);

}  // namespace loom
