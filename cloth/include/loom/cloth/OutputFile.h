#pragma once
// The one way Loom writes a file (run outputs, temporary *.partial/*.tmp files, checkpoints, the output
// folder's manifest, images): an std::ostream over a file descriptor opened so that nothing planted at the
// path is ever written through or waited on.
//   - kReplace: an existing regular file at the path is unlinked (its other hard links, if any, keep their
//     contents) and a new file is created with O_CREAT | O_EXCL | O_NOFOLLOW | O_NONBLOCK, so a symbolic
//     link, a FIFO, a socket, a device or a folder at the path is refused instead of followed, opened or
//     blocked on (a FIFO without a reader would block a plain open forever).
//   - kAppend: the path must already be a regular file with one name (O_NOFOLLOW | O_NONBLOCK, then fstat:
//     a hard link is refused, an append there would change the other name's file).
// A path inside a registered output folder (OutputRoot) is reached from the folder's descriptor, one
// folder at a time, so no folder on the way is followed if it became a link (see OutputRoot).
// After the open, fstat must report a regular file and O_NONBLOCK is cleared. Every refusal is a loom::Error
// naming the path and what is there. Write errors set badbit as std::ofstream does.
#include <cerrno>
#include <cstdint>
#include <memory>
#include <ostream>
#include <streambuf>
#include <string>

namespace loom {

enum class OutputMode { kReplace, kAppend };

// An output folder held open while a command writes into it. Every path given to OutputFile,
// write_file_atomically, make_output_folder, rename_output and remove_output whose components begin with
// the folder's (as written: "out/run" holds "out/run/frames/frame_00001.obj" and "out/run/./x") is reached
// from the descriptor opened here (O_DIRECTORY | O_NOFOLLOW), each folder below it opened with
// openat(O_DIRECTORY | O_NOFOLLOW) and the file itself created, renamed or unlinked by the *at call on the
// last folder's descriptor. A folder on the way replaced by a symbolic link while the command runs is
// refused (loom::Error naming it), never followed, so nothing is written outside the folder; the folder
// itself renamed away and replaced by a link is not followed either (the descriptor keeps the folder it
// opened). A ".." below the folder is refused. The innermost registered folder holding a path is used;
// paths outside every registered folder are opened as given. Registration lasts as long as the object.
class OutputRoot {
 public:
  // Opens `dir`, which must exist and be a folder, not a symbolic link (throws loom::Error naming it).
  explicit OutputRoot(const std::string& dir);
  ~OutputRoot();
  OutputRoot(const OutputRoot&) = delete;
  OutputRoot& operator=(const OutputRoot&) = delete;

 private:
  int fd_ = -1;
};

// Makes the folder `path` and its missing parents (inside a registered output folder by mkdirat on each
// folder's descriptor, never through a link). Throws loom::Error naming the path on failure.
void make_output_folder(const std::string& path);
// Creates the folder `path` (mode 0700; a name that exists is not reused) by mkdirat on its parent's
// descriptor (reached as make_output_folder reaches it) and opens it (O_DIRECTORY | O_NOFOLLOW |
// O_CLOEXEC). Returns the descriptor, which the caller closes, or -1 when the name exists (errno EEXIST).
// Throws loom::Error naming the path on any other failure.
int make_private_output_folder(const std::string& path);
// Renames the file `from` to `to` (renameat on their folders' descriptors). Throws loom::Error naming `to`.
void rename_output(const std::string& from, const std::string& to);
// Removes the file or symbolic link (itself) at `path`, or the folder there when it is empty; never follows
// a link on the way. False when it could not (a link on the way, not empty, gone counts as done).
bool remove_output(const std::string& path);

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
  // errno of the first write or close that failed (ENOSPC: the disk is full), 0 when none did.
  int error() const { return error_; }

 protected:
  int_type overflow(int_type ch) override;
  std::streamsize xsputn(const char* s, std::streamsize n) override;
  int sync() override;
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode which) override;
  pos_type seekpos(pos_type pos, std::ios_base::openmode which) override;

 private:
  bool flush_buffer();
  void failed(int e) {
    if (error_ == 0) error_ = e == 0 ? EIO : e;
  }
  int fd_;
  int error_ = 0;
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
  // "write failed: No space left on device": what a failed write or close gives as the reason.
  std::string write_failure() const;

 private:
  std::string path_;
  std::unique_ptr<FdStreamBuf> buf_;
  bool open_ = false;
};

// Writes `data` to the temporary file `tmp` (kReplace) and renames it to `path`, so a reader never sees half
// a file. Throws loom::Error naming the file on failure.
void write_file_atomically(const std::string& path, const std::string& tmp, const std::string& data);

}  // namespace loom
