#pragma once
// The output folder of `loom run` (and of `loom fabric-test`, `loom compare`, `loom bench`), owned through
// its manifest DIR/.loom-manifest: the list of every file and folder the runs that used DIR wrote there, one
// path relative to DIR a line (no absolute path, no "..").
// Contract (docs/guarantees.md):
//   - a run writes only inside DIR, and only to paths it first adds to the manifest (claim());
//   - a run deletes only paths listed in the manifest (never follows a symbolic link to do so);
//   - DIR is used when it does not exist (it is created), is empty, or holds a manifest; a non-empty folder
//     without one is refused unless the user passes --overwrite (files of the same names are then replaced,
//     nothing else is deleted);
//   - DIR itself must not be a symbolic link nor end in "." or "..", and a path inside DIR that is one is
//     never written through (DIR is held open while the folder lives: OutputRoot, OutputFile.h);
//   - DIR inside or around a folder another command uses is refused (FolderLock), and so is DIR at or below
//     a path that the manifest of a folder above lists (what an earlier run made there), --overwrite or not;
//   - an entry of the old manifest is deleted only as the type it was listed as (a link: the link itself).
// The manifest's first line holds a run id that checkpoints record, so a checkpoint copied from another
// folder is refused on --resume.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "loom/cloth/OutputFile.h"

namespace loom::eval {

namespace detail {
struct Flock;
}

// Advisory locks (flock, LOCK_NB) held while a command uses a folder: an exclusive one on the folder itself
// and a shared one on every folder above it, up to the root (through "..": the folders the system reaches,
// whatever links the path went through; one the user cannot read is passed over). So two Loom commands
// never use one folder, nor one a folder inside the other's, at the same time: a command into a folder
// inside one in use fails its shared lock there, one into a folder that contains one in use fails its
// exclusive lock (the other holds a shared one on it), whichever comes first wins. acquire() refuses, by
// the folder's name, "DIR: in use by another loom command (it lies inside A / it contains B, which another
// loom command is using)" (loom::Error). A shared acquire (`loom body --image`'s folder, which it writes a
// file into but does not own) takes shared locks only: refused inside a folder in use, not beside one.
// Within one process a folder's lock is shared (acquire reuses the live one). The descriptors are
// close-on-exec, so a helper program (ffmpeg, gnuplot) never keeps them.
class FolderLock {
 public:
  // Locks the existing folder `dir` (never through a symbolic link). nullptr when `dir` does not exist or
  // is not a folder (the caller refuses it by its own rules). `flag` names the option in errors; `named`
  // (default `dir`) is the folder the messages name (the output folder, when `dir` is its nearest existing
  // parent, locked before the output folder is made).
  static std::shared_ptr<FolderLock> acquire(const std::filesystem::path& dir, const std::string& flag,
                                             bool exclusive = true, const std::filesystem::path& named = {});
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  FolderLock() = default;
  std::shared_ptr<detail::Flock> self_;
  std::vector<std::shared_ptr<detail::Flock>> above_;
};

class OutputFolder {
 public:
  // `flag` names the option the folder came from ("--out", "--resume") in error messages. `resume`: keep the
  // listed files (the run continues); otherwise the files listed by an earlier run are deleted first.
  // `writes`: every path the run will claim (a folder ends in '/'; one '#' in the last component stands for
  // digits, e.g. "frames/frame_#.obj"). They are checked as claim() checks them before the folder changes,
  // so a folder refused for any reason (a link planted where the run writes, a foreign folder) is left
  // exactly as it was: no manifest written, nothing deleted, no folder created.
  // `inputs`: every file the command reads (scene, meshes, motion clips, checkpoint); one that is, by
  // device and inode, a file at a path the command writes (a scene or mesh named `summary.json` or
  // `compare.json` in the folder) or one an earlier run listed (deleted first) is refused, --overwrite or
  // not: the command would destroy its own input. Every command passes its inputs (none: an empty list).
  // The folder is locked (FolderLock) before anything in it is read, deleted or written, and stays locked
  // while the OutputFolder lives.
  OutputFolder(const std::filesystem::path& dir, const std::string& flag, bool overwrite, bool resume,
               const std::vector<std::string>& writes, const std::vector<std::string>& inputs);
  const std::filesystem::path& dir() const { return dir_; }
  std::uint64_t run_id() const { return run_id_; }
  // Adds `relative` (a file or, ending in '/', a folder) to the manifest before it is written and returns
  // DIR/relative. Refuses a path that is a symbolic link or, for a file, a folder, and (when the
  // constructor was given `writes`) a path none of `writes` matches: every path a command writes is checked
  // before it starts.
  std::filesystem::path claim(const std::string& relative);
  bool owns(const std::string& relative) const { return listed_.count(relative) != 0; }
  // Makes a new private folder DIR/<stem><digits>/ (mode 0700, a name that did not exist: mkdirat on DIR's
  // descriptor, never an existing folder) for a helper program to write `files` into. The folder and
  // DIR/<stem><digits>/<file> are listed in the manifest before the folder exists, so a run killed while the
  // helper works leaves only listed paths, which the next run deletes. Returns the folder; `fd` (when not
  // null) receives a descriptor of it opened with O_DIRECTORY | O_NOFOLLOW, which the caller closes.
  std::filesystem::path claim_private_folder(const std::string& stem, const std::vector<std::string>& files,
                                             int* fd = nullptr);
  // Deletes a listed file (no-op for a path not listed or already gone).
  void remove_owned(const std::string& relative);

  static constexpr const char* kManifest = ".loom-manifest";

 private:
  void append(const std::string& line);
  std::shared_ptr<FolderLock> lock_;  // released last
  std::filesystem::path dir_;
  std::string flag_;
  std::vector<std::string> writes_;
  std::uint64_t run_id_ = 0;
  std::set<std::string> listed_;
  std::unique_ptr<OutputRoot> root_;  // DIR held open; every path below it is reached from it
  OutputFile manifest_;
};

// Refuses (naming it, exit 1 by the caller) a default output folder (`out/<name>`, chosen by Loom, not by
// the user) with a symbolic link on its way: the user never named the link. `flag` is the option that
// would have named a folder ("--out").
void refuse_linked_default(const std::filesystem::path& dir, const std::string& flag);

// Reads the run id of DIR/.loom-manifest (0 without a manifest).
std::uint64_t read_run_id(const std::filesystem::path& dir);

}  // namespace loom::eval
