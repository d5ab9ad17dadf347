#pragma once
// Plot of `loom bench accuracy`: error against wall time per frame, log-log, one series per method, the
// Pareto front marked. Drawn with gnuplot (Debian gnuplot-nox) from a data file written next to the PNG.
#include <string>
#include <vector>

#include "loom/eval/OutputFolder.h"

namespace loom::eval {

struct PlotPoint {
  std::string series;  // "loom:verlet", "bullet_classic", ...
  double ms = 0.0;     // wall ms per frame
  double error = 0.0;  // m
};

// Indices into `points` of the Pareto front (no other point is both faster and more accurate), by
// increasing time.
std::vector<size_t> pareto_front(const std::vector<PlotPoint>& points);

// Writes DIR/<stem>.dat and .gp and, through gnuplot, DIR/<stem>.png (each claimed in `folder`; gnuplot
// runs as HelperProgram.h runs helpers). Returns false with a message on stderr if gnuplot is missing or
// fails; the CSV stays the result.
bool plot_accuracy(OutputFolder& folder, const std::vector<PlotPoint>& points, const std::string& title,
                   const std::string& stem);

}  // namespace loom::eval
