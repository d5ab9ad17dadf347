#include "loom/eval/AccuracyPlot.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <numeric>
#include <sstream>

#include "loom/cloth/HiddenText.h"
#include "loom/cloth/OutputFile.h"
#include "loom/eval/HelperProgram.h"

namespace loom::eval {

std::vector<size_t> pareto_front(const std::vector<PlotPoint>& points) {
  std::vector<size_t> order(points.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return points[a].ms != points[b].ms ? points[a].ms < points[b].ms : points[a].error < points[b].error;
  });
  std::vector<size_t> front;
  double best = 1e300;
  for (size_t i : order)
    if (points[i].error < best) {
      best = points[i].error;
      front.push_back(i);
    }
  return front;
}

bool plot_accuracy(OutputFolder& folder, const std::vector<PlotPoint>& points, const std::string& title,
                   const std::string& stem) {
  const std::string dat = stem + ".dat";
  std::map<std::string, std::vector<size_t>> series;
  for (size_t i = 0; i < points.size(); ++i) series[points[i].series].push_back(i);
  OutputFile d(folder.claim(dat));
  std::vector<std::string> names;
  for (const auto& kv : series) {
    d << "# " << kv.first << "\n";
    for (size_t i : kv.second) d << points[i].ms << ' ' << points[i].error << "\n";
    d << "\n\n";
    names.push_back(kv.first);
  }
  d << "# pareto front\n";
  const std::vector<size_t> front = pareto_front(points);
  for (size_t i : front) d << points[i].ms << ' ' << points[i].error << "\n";
  d.close();
  if (!d) {
    std::cerr << "loom: error: cannot write " << show_hidden((folder.dir() / dat).string()) << "\n";
    return false;
  }
  std::ostringstream g;
  g << "set title " << gnuplot_quote(title) << "\n"
    << "set logscale xy\nset grid\nset format y '%g'\n"
    << "set xlabel 'wall ms per 60 Hz frame (1 thread)'\n"
    << "set ylabel 'max over the run of mass-weighted RMS position error (m)'\n"
    << "set key outside right top\n"
    << "plot ";
  const int kTypes[] = {7, 5, 9, 11, 13, 4, 6, 8, 10, 12};
  const std::string q = gnuplot_quote(dat);
  for (size_t s = 0; s < names.size(); ++s)
    g << q << " index " << s << " using 1:2 with points pt " << kTypes[s % 10] << " ps 1.2 title "
      << gnuplot_quote(names[s]) << ", ";
  g << q << " index " << names.size() << " using 1:2 with steps lw 2 lc rgb 'black' title 'Pareto front', "
    << q << " index " << names.size() << " using 1:2 with points pt 6 ps 2.2 lc rgb 'black' notitle\n";
  const std::string why =
      gnuplot_png(folder, stem, "set terminal pngcairo size 900,600 font ',10' noenhanced", g.str());
  if (!why.empty()) {
    std::cerr << "loom: warning: " << show_hidden(why) << "; "
              << show_hidden((folder.dir() / (stem + ".png")).string()) << " not written\n";
    return false;
  }
  return true;
}

}  // namespace loom::eval
