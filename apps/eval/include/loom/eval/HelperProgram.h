#pragma once
// The helper programs Loom's tools run (gnuplot for plots, ffmpeg for videos), run so that no path, name or
// title can become a command: no shell, arguments passed to execvp as they are, and the programs' outputs
// staged in a private folder of the output folder (OutputFolder::claim_private_folder) from which they are
// renamed into place, so a helper never opens a path where something could have been planted. A helper runs
// in the private folder itself (its descriptor, opened when the folder was made, is the child's working
// folder by fchdir) and names its output relative to it: the folder renamed away and replaced by a
// symbolic link while the helper runs is not followed. Its inputs in DIR are named through "..".
#include <filesystem>
#include <string>
#include <vector>

#include "loom/eval/OutputFolder.h"

namespace loom::eval {

// True when `name` is an executable file in a folder of PATH.
bool program_on_path(const std::string& name);

// Runs argv[0] (looked up on PATH) with argv[1..] in the working folder `cwd`: no shell, stdin from
// /dev/null, stdout and stderr into `output` (when not null; else /dev/null). The child gets SIGKILL when
// this process dies (PR_SET_PDEATHSIG, kept across exec): a loom killed by a signal leaves no helper running.
// Returns the exit status; -1 when the program could not run or died by a signal.
int run_program(const std::vector<std::string>& argv, const std::filesystem::path& cwd, std::string* output);
// The same in the folder open as `cwd_fd` (fchdir in the child between fork and exec).
int run_program(const std::vector<std::string>& argv, int cwd_fd, std::string* output);

// `s` as a gnuplot single-quoted string: no substitution happens inside single quotes, a quote is doubled
// (gnuplot reads '' inside '...' as one '), and control characters (which would end the command) become '?'.
std::string gnuplot_quote(const std::string& s);

// Writes DIR/<name>.gp, `terminal` (a `set terminal ...` line) then `body` (which reads its data by names
// relative to DIR, quoted with gnuplot_quote), and runs gnuplot in DIR; the image goes to a private folder
// and is renamed to DIR/<name>.png. Returns "" on success, else why there is no plot (gnuplot missing or
// failed). Claims <name>.gp and <name>.png in `folder`.
std::string gnuplot_png(OutputFolder& folder, const std::string& name, const std::string& terminal,
                        const std::string& body);

// Encodes DIR/<frames>/frame_%05d.png at `fps` into DIR/<file> with ffmpeg: `format_args` are ffmpeg's
// output options (filters, codec, ending with `-f <format>`), one argument each. Throws loom::Error naming
// `field` when ffmpeg is missing or fails. Claims <file> in `folder`. `count`: the frames to read,
// frame_00000.png to frame_<count - 1>.png (`-frames:v`): files of higher numbers in the folder are not
// this run's and never reach the video.
void ffmpeg_video(OutputFolder& folder, const std::string& frames, double fps,
                  const std::vector<std::string>& format_args, const std::string& file,
                  const std::string& field, int count);

// The encoder threads ffmpeg_video gives ffmpeg (`-threads`): a bound, so that its memory does not grow
// with the machine's cores (x264 starts 1.5 threads per core by default, each with its frame buffers).
int ffmpeg_threads();

// Address space (bytes) ffmpeg takes at most to encode `width` x `height` frames with ffmpeg_threads()
// threads: 440 MB of libraries and heap, 40 MB per thread (stack and lookahead) and (24 + 10 per thread)
// bytes per pixel. The figures are the least `ulimit -v` under which Debian 12's ffmpeg 5.1 (libx264
// 164) encoded 512^2 to 4096^2 PNG frames with 1 to 16 threads, each rounded up (docs/cli.md).
double ffmpeg_memory_bytes(int width, int height);

}  // namespace loom::eval
