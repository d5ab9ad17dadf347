#pragma once
// `loom bench accuracy|realtime [options]`: the benchmark first, then its options (BenchCommand.cpp).
#include <string>

namespace loom::app {

int bench_main(int argc, char** argv);  // argv[1] == "bench"

// A benchmark's simulated seconds as whole frames of 1/60 s: below one frame is refused naming `flag`
// (exit 2); another value is rounded to the nearest whole frames with a note on stderr. Returns frames / 60.
double whole_frames(const std::string& flag, double seconds);

}  // namespace loom::app
