#include "loom/eval/HelperProgram.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <thread>

#include "loom/cloth/Error.h"
#include "loom/cloth/OutputFile.h"

namespace loom::eval {

namespace fs = std::filesystem;

bool program_on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path || name.empty() || name.find('/') != std::string::npos) return false;
  std::stringstream dirs(path);
  for (std::string dir; std::getline(dirs, dir, ':');) {
    if (dir.empty()) continue;
    const std::string p = dir + "/" + name;
    struct stat st;
    if (::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(p.c_str(), X_OK) == 0) return true;
  }
  return false;
}

namespace {

// run_program in `cwd` (a path) or, when `cwd` is null, in the folder open as `cwd_fd`.
int run_in(const std::vector<std::string>& argv, const char* cwd, int cwd_fd, std::string* output) {
  if (argv.empty()) return -1;
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  int pipe_fd[2] = {-1, -1};
  if (output && ::pipe2(pipe_fd, O_CLOEXEC) != 0) return -1;
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    if (output) {
      ::close(pipe_fd[0]);
      ::close(pipe_fd[1]);
    }
    return -1;
  }
  if (pid == 0) {  // the child: only async-signal-safe calls until exec
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);  // the parent died before prctl took effect
    const int null = ::open("/dev/null", O_RDWR);
    if (null < 0 || ::dup2(null, 0) < 0) ::_exit(127);
    const int out = output ? pipe_fd[1] : null;
    if (::dup2(out, 1) < 0 || ::dup2(out, 2) < 0) ::_exit(127);
    if (cwd ? ::chdir(cwd) != 0 : ::fchdir(cwd_fd) != 0) ::_exit(127);
    ::execvp(args[0], args.data());
    ::_exit(127);
  }
  if (output) {
    ::close(pipe_fd[1]);
    char buf[4096];
    for (;;) {
      const ssize_t n = ::read(pipe_fd[0], buf, sizeof buf);
      if (n > 0) {
        if (output->size() < (1u << 20)) output->append(buf, static_cast<size_t>(n));  // at most 1 MB kept
      } else if (n == 0 || errno != EINTR) {
        break;
      }
    }
    ::close(pipe_fd[0]);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

int run_program(const std::vector<std::string>& argv, const fs::path& cwd, std::string* output) {
  return run_in(argv, cwd.c_str(), -1, output);
}

int run_program(const std::vector<std::string>& argv, int cwd_fd, std::string* output) {
  return run_in(argv, nullptr, cwd_fd, output);
}

std::string gnuplot_quote(const std::string& s) {
  std::string q = "'";
  for (const char c : s) {
    if (c == '\'')
      q += "''";
    else if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      q += '?';
    else
      q += c;
  }
  return q + "'";
}

namespace {

// Runs `argv` in a private folder of DIR (its descriptor the child's working folder) where it makes its
// output `file`: "@STAGED@" in an argument stands for `file` itself, relative to that folder, and "@DIR@"
// for DIR seen from it (".."); `script` is written to DIR/<script_name> when that is not empty. The file
// made there is renamed to DIR/<file>. Returns "" or why it failed.
std::string run_staged(OutputFolder& folder, std::vector<std::string> argv, const std::string& file,
                       const std::string& script_name, const std::string& script) {
  const fs::path target = folder.claim(file);
  int fd = -1;
  const fs::path staging = folder.claim_private_folder(".loom-helper-", {file}, &fd);
  auto fill = [&](std::string& s) {
    for (size_t p; (p = s.find("@STAGED@")) != std::string::npos;) s.replace(p, 8, file);
    for (size_t p; (p = s.find("@DIR@")) != std::string::npos;) s.replace(p, 5, "..");
  };
  if (!script_name.empty()) OutputFile(folder.claim(script_name)) << script;
  for (std::string& a : argv) fill(a);
  std::string log;
  const int status = run_program(argv, fd, &log);
  ::close(fd);
  std::error_code ec;
  const fs::path made = staging / file;
  const bool regular = fs::is_regular_file(fs::symlink_status(made, ec));
  bool moved = false;
  if (status == 0 && regular) {
    try {
      rename_output(made.string(), target.string());  // never through a folder replaced by a link
      moved = true;
    } catch (const Error& e) {
      log = e.what();
    }
  }
  remove_output(made.string());
  remove_output(staging.string());
  if (moved) return "";
  while (!log.empty() && (log.back() == '\n' || log.back() == '\r')) log.pop_back();
  return argv[0] + (status == 0 ? " made no file" : " failed (exit " + std::to_string(status) + ")") +
         (log.empty() ? "" : ": " + log.substr(0, 500));
}

}  // namespace

std::string gnuplot_png(OutputFolder& folder, const std::string& name, const std::string& terminal,
                        const std::string& body) {
  if (!program_on_path("gnuplot")) return "gnuplot is not installed (Debian package: gnuplot-nox)";
  // The output is opened (`set output`) in the private folder, then gnuplot moves to DIR, where the body
  // reads its data.
  const std::string script = terminal + "\nset output " + gnuplot_quote(name + ".png") + "\ncd '..'\n" + body;
  return run_staged(folder, {"gnuplot", "@DIR@/" + name + ".gp"}, name + ".png", name + ".gp", script);
}

int ffmpeg_threads() { return static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 4u)); }

double ffmpeg_memory_bytes(int width, int height) {
  const double threads = ffmpeg_threads();
  const double pixels = double(width + 1) * double(height + 1);  // padded to even sizes
  return 440e6 + 40e6 * threads + pixels * (24.0 + 10.0 * threads);
}

void ffmpeg_video(OutputFolder& folder, const std::string& frames, double fps,
                  const std::vector<std::string>& format_args, const std::string& file,
                  const std::string& field, int count) {
  if (!program_on_path("ffmpeg"))
    throw Error("ffmpeg", field,
                "ffmpeg not found (Debian package: ffmpeg); the PNG frames are in " +
                    (folder.dir() / frames).string());
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.6g", fps);
  // The frames are read by a pattern relative to DIR: `frames` is a name of Loom's, without '%' or '@'.
  std::vector<std::string> argv = {"ffmpeg", "-hide_banner", "-loglevel",
                                   "error",  "-n",           "-framerate",
                                   rate,     "-i",           "@DIR@/" + frames + "/frame_%05d.png"};
  argv.insert(argv.end(), {"-frames:v", std::to_string(count), "-threads", std::to_string(ffmpeg_threads())});
  argv.insert(argv.end(), format_args.begin(), format_args.end());
  argv.push_back("@STAGED@");
  const std::string why = run_staged(folder, argv, file, "", "");
  if (!why.empty()) throw Error((folder.dir() / file).string(), field, why);
}

}  // namespace loom::eval
