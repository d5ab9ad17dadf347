// `loom bench accuracy`: sizes, rows per system, the reference check, results and plots (AccuracyBench.h).
#include "loom/eval/AccuracyBench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "AccuracyBenchInternal.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/HiddenText.h"
#include "loom/cloth/InputFile.h"
#include "loom/cloth/OutputFile.h"
#include "loom/eval/AccuracyPlot.h"
#include "loom/eval/AccuracySweep.h"
#include "loom/eval/CsvNumber.h"
#include "loom/eval/OutputFolder.h"
#include "loom/scene/SceneLimits.h"

namespace loom::eval {

namespace {

using namespace accuracy;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

// The reference of one size and its dt-halving check (docs/benchmarks.md).
struct ReferenceRun {
  std::vector<Vec3s> x;     // m, positions at every frame
  int steps = 0;            // steps per frame of the reference; the check ran at half
  double change = 0.0;      // m, largest mass-weighted RMS change of halving the step, over the frames
  double max_strain = 0.0;  // the reference's own largest structural stretch over the run (the strain target)
};

ReferenceRun run_reference(const Scene& s) {
  ReferenceRun out;
  int ref_steps = kRefFactor * s.explicit_steps;  // the check; the reference itself runs at twice this
  const int threads_ref = 1;  // small meshes: OpenMP overhead exceeds the gain; results are identical
  auto t0 = Clock::now();
  const std::vector<Vec3s> coarse = reference(s, ref_steps, threads_ref);
  ref_steps *= 2;
  out.x = reference(s, ref_steps, threads_ref);
  out.steps = ref_steps;
  for (int f = 0; f < s.frames; ++f) out.change = std::max(out.change, rms(s.mass, coarse[f], out.x[f]));
  for (const Vec3s& x : out.x)
    for (int k : s.cloth.mesh->strain_springs()) {
      const SpringDef& d = s.cloth.mesh->springs()[k];
      out.max_strain = std::max(out.max_strain, (x[d.j] - x[d.i]).norm() / d.rest_length - 1.0);
    }
  std::printf("  reference: velocity verlet, %d steps/frame, check at %d (%.1f s): they differ by %.3g m\n",
              ref_steps, ref_steps / 2, std::chrono::duration<double>(Clock::now() - t0).count(), out.change);
  std::fflush(stdout);
  return out;
}

// One Loom configuration at every thread count. Each row runs `repeats` times, the thread counts interleaved
// so that a slow spell of the machine does not fall on one thread count only; the fastest run is kept.
// Results are bit-identical for any thread count and run (docs/architecture.md, "Numbers and threads"): a
// repeat or a thread count that differs is reported.
void run_loom_config(const AccuracyOptions& o, const Scene& s, const std::string& method,
                     const SweepConfig& c, const std::vector<Vec3s>& ref, std::vector<Row>& rows) {
  std::vector<std::optional<Row>> best(o.threads.size());
  std::optional<Row> diverged;
  bool skipped = false;
  for (int rep = 0; rep < o.repeats && !skipped; ++rep)
    for (size_t ti = 0; ti < o.threads.size() && !skipped; ++ti) {
      if (diverged) {
        // The run diverges again at any thread count; timing a state full of NaN means nothing. The
        // row stays, diverged, without a time.
        if (!best[ti]) {
          best[ti] = *diverged;
          best[ti]->threads = o.threads[ti];
          best[ti]->ms_per_frame = std::nan("");
        }
        continue;
      }
      try {
        const Row r = run_loom(s, method, c, o.threads[ti], ref);
        if (r.diverged) diverged = r;
        if (!best[ti]) {
          best[ti] = r;
        } else {
          if (!same_results(*best[ti], r))
            std::printf("  warning: %s %s on %d threads: results differ between repeats\n", method.c_str(),
                        c.label().c_str(), r.threads);
          best[ti]->ms_per_frame = std::min(best[ti]->ms_per_frame, r.ms_per_frame);
        }
      } catch (const loom::Error& e) {
        std::printf("  skipped %s %s: %s\n", method.c_str(), c.label().c_str(), e.what());
        skipped = true;
      }
    }
  for (size_t ti = 1; ti < best.size(); ++ti)
    if (best[0] && best[ti] && !same_results(*best[0], *best[ti]))
      std::printf("  warning: %s %s: results differ between %d and %d threads\n", method.c_str(),
                  c.label().c_str(), o.threads[0], o.threads[ti]);
  for (const std::optional<Row>& r : best)
    if (r) {
      rows.push_back(*r);
      print_row(rows.back());
    }
}

// Every registered dynamic solver over its sweep table (a default step sweep for a solver the table does not
// know yet).
void run_loom_rows(const AccuracyOptions& o, const Scene& s,
                   const std::map<std::string, std::vector<SweepConfig>>& table,
                   const std::vector<std::string>& registered, const std::vector<Vec3s>& ref,
                   std::vector<Row>& rows) {
  for (const std::string& method : registered) {
    if (!o.methods.empty() && !o.methods.count(method)) continue;
    if (static_only(method)) continue;  // static scenes only (the catenary table below)
    std::vector<SweepConfig> configs;
    auto it = table.find(method);
    if (it != table.end()) {
      configs = it->second;
    } else {
      // A solver this table does not know yet: a default step sweep.
      for (int st : {1, 4}) configs.push_back(SweepConfig{st, {}, ""});
      if (o.quick) configs.resize(1);
      std::printf("  note: no sweep table entry for '%s'; using substeps 1, 4\n", method.c_str());
    }
    for (const SweepConfig& c : configs) {
      if (!o.configs.empty() && c.label().find(o.configs) == std::string::npos) continue;
      run_loom_config(o, s, method, c, ref, rows);
    }
  }
}

// The hybrid (coarse simulation + curved-face detail) with backward Euler and IMEX, when the coarse grid
// has at least 3 nodes per side.
void run_hybrid_rows(const AccuracyOptions& o, const Scene& s, const std::vector<std::string>& registered,
                     const std::vector<Vec3s>& ref, std::vector<Row>& rows) {
  if (!((s.n - 1) / 4 + 1 >= 3)) return;
  for (const char* method : {"implicit_euler", "imex"}) {
    if (!o.methods.empty() && !o.methods.count(method) && !o.methods.count("hybrid")) continue;
    if (std::find(registered.begin(), registered.end(), method) == registered.end()) continue;
    for (int st : o.quick ? std::vector<int>{1} : std::vector<int>{1, 4}) {
      SweepConfig c;
      c.substeps = st;
      c.params["cg_tolerance"] = 1e-4;
      rows.push_back(run_hybrid(s, method, c, ref, o.duration, o.perturbation));
      print_row(rows.back());
    }
  }
}

// Rows the selection (--methods, --configs) asks for at this size, counted without running anything: the
// same filters as run_loom_rows, run_hybrid_rows and run_bullet_rows.
size_t selected_rows(const AccuracyOptions& o, const Scene& s,
                     const std::map<std::string, std::vector<SweepConfig>>& table,
                     const std::vector<std::string>& registered) {
  size_t count = 0;
  for (const std::string& method : registered) {
    if ((!o.methods.empty() && !o.methods.count(method)) || static_only(method)) continue;
    auto it = table.find(method);
    if (it == table.end()) {
      count += o.configs.empty() ? 1 : 0;  // the default sweep's labels are not known before it runs
      continue;
    }
    for (const SweepConfig& c : it->second)
      if (o.configs.empty() || c.label().find(o.configs) != std::string::npos) ++count;
  }
  // --configs names Loom configurations: a text that matches none of them selects nothing, whatever the
  // hybrid and Bullet rows beside them would add.
  if (!o.configs.empty()) return count;
  if ((s.n - 1) / 4 + 1 >= 3)
    for (const char* method : {"implicit_euler", "imex"})
      if ((o.methods.empty() || o.methods.count(method) || o.methods.count("hybrid")) &&
          std::find(registered.begin(), registered.end(), method) != registered.end())
        ++count;
  for (const auto& kv : bullet_sweep_table(o.quick))
    if (o.methods.empty() || o.methods.count(kv.first)) count += kv.second.size();
  return count;
}

// Both Bullet twins over their sweep.
void run_bullet_rows(const AccuracyOptions& o, const Scene& s, const std::vector<Vec3s>& ref,
                     std::vector<Row>& rows) {
  for (const auto& kv : bullet_sweep_table(o.quick)) {
    if (!o.methods.empty() && !o.methods.count(kv.first)) continue;
    const auto kind =
        kv.first == "bullet_classic" ? bullet::TwinKind::kClassic : bullet::TwinKind::kDeformable;
    for (const SweepConfig& c : kv.second) {
      rows.push_back(run_bullet(s, kind, c, ref));
      print_row(rows.back());
    }
  }
}

// Reference check against the smallest error reported at this size (rows from `first` on): passed when
// halving the reference step changes it by less than 1 % of that error. Appends a line to `refs`.
void check_reference(int n, const ReferenceRun& ref, const std::vector<Row>& rows, size_t first,
                     std::ostringstream& refs) {
  double smallest = 1e300;
  for (size_t k = first; k < rows.size(); ++k)
    for (double e : {rows[k].rms_error_max, rows[k].rms_error_end})
      if (std::isfinite(e) && e > 0.0) smallest = std::min(smallest, e);
  const double ratio = ref.change / smallest;
  const bool passed = smallest < 1e300 && ratio < 0.01;  // no finite error reported: nothing passes
  std::printf(
      "reference check N=%d: halving the reference step (%d -> %d steps/frame) changes it by %.3g m "
      "(max over frames, mass-weighted RMS); smallest reported error %.3g m; ratio %.3g%% -> %s; "
      "reference max strain %.4g\n",
      n, ref.steps / 2, ref.steps, ref.change, smallest, 100.0 * ratio,
      passed ? "PASSED (< 1%)" : "FAILED (>= 1%)", ref.max_strain);
  const std::string none;  // no finite error reported: the smallest error and the ratio are left empty
  refs << n << ',' << ref.steps << ',' << ref.steps / 2 << ',' << csv_number(ref.change) << ','
       << (smallest < 1e300 ? csv_number(smallest) : none) << ','
       << (smallest < 1e300 ? csv_number(ratio) : none) << ',' << (passed ? 1 : 0) << ','
       << csv_number(ref.max_strain) << "\n";
}

// The time-vs-error points of one size's single-thread rows that did not diverge.
std::vector<PlotPoint> plot_points(const std::vector<Row>& rows, size_t first) {
  std::vector<PlotPoint> pts;
  for (size_t k = first; k < rows.size(); ++k) {
    const Row& r = rows[k];
    if (r.threads != 1 || r.diverged || !(r.rms_error_max > 0.0)) continue;
    std::string label = r.system == "loom" ? "loom:" + r.method : r.system;
    const size_t model_at = r.config.find(" model=");
    if (model_at != std::string::npos) label += "+" + r.config.substr(model_at + 7);  // e.g. +corotated_fem
    if (r.config.find(" detail=") != std::string::npos) label += "+detail";
    pts.push_back({label, r.ms_per_frame, r.rms_error_max});
  }
  return pts;
}

// DIR/accuracy.csv and DIR/reference_check.csv, rewritten after every size so a long run keeps what it
// measured. False (and a message) when they cannot be written.
bool write_results(const AccuracyOptions& o, OutputFolder& folder, const std::vector<Row>& rows,
                   const std::ostringstream& refs) {
  OutputFile csv(folder.claim("accuracy.csv"));
  csv << "system,method,size,config,threads,ms_per_frame,rms_error_max,rms_error_end,max_strain,mean_strain,"
         "energy_drift,diverged\n";
  for (const Row& r : rows)
    csv << r.system << ',' << r.method << ',' << r.size << ',' << r.config << ',' << r.threads << ','
        << csv_number(r.ms_per_frame) << ',' << csv_number(r.rms_error_max) << ','
        << csv_number(r.rms_error_end) << ',' << csv_number(r.max_strain) << ',' << csv_number(r.mean_strain)
        << ',' << csv_number(r.energy_drift) << ',' << (r.diverged ? 1 : 0) << "\n";
  OutputFile rf(folder.claim("reference_check.csv"));
  rf << refs.str();
  if (!csv || !rf) {
    std::cerr << "loom: error: " << show_hidden(o.out) << ": cannot write the results\n";
    return false;
  }
  return true;
}

}  // namespace

int bench_accuracy(const AccuracyOptions& o) {
  std::error_code ec;
  const std::vector<std::string> registered = solver_names();
  // Memory before anything is allocated (a 4096x4096 grid is 16.8 million vertices): the simulation's
  // kBytesPerVertex (SceneLimits.h) plus the two reference runs' frames kept for the comparison (three
  // doubles per vertex and frame each); refused naming --sizes with the estimate and the budget.
  for (int n : o.sizes) {
    const double frames = std::max(1.0, std::round(o.duration * 60.0)) + 1.0;
    const double bytes =
        static_cast<double>(n) * n * (static_cast<double>(scene::kBytesPerVertex) + 2.0 * 24.0 * frames);
    scene::check_memory("", "--sizes", bytes,
                        "N=" + std::to_string(n) + " (" + std::to_string(static_cast<long long>(n) * n) +
                            " vertices, " + scene::show_count(frames) + " frames) needs",
                        "give a smaller size");
  }
  // A selection that runs nothing is refused before the folder or any (expensive) reference run.
  for (int n : o.sizes) {
    const Scene s = make_scene(n, o.duration, o.perturbation);
    if (selected_rows(o, s, loom_sweep_table(s.explicit_steps, o.quick), registered) == 0)
      throw loom::Error(
          "", o.configs.empty() ? "--methods" : "--methods/--configs",
          "selects no configuration at N=" + std::to_string(n) +
              (o.configs.empty() ? "" : " (no label contains '" + show_value(o.configs) + "')") +
              ": nothing would be measured");
  }
  if (!o.out_given) refuse_linked_default(o.out, "--out");
  OutputFolder folder(
      o.out, "--out", o.overwrite, false,
      {"accuracy.csv", "reference_check.csv", "accuracy.png", "accuracy.png.tmp", "accuracy_#.dat",
       "accuracy_#.gp", "accuracy_#.png"},
      {});  // refuses a folder Loom did not write; the benchmark's scenes are built in code (no input file)
  std::vector<Row> rows;
  std::ostringstream refs;
  refs << "size,ref_substeps,check_substeps,ref_change,smallest_error,ratio,passed,ref_max_strain\n";
  for (int n : o.sizes) {
    const Scene s = make_scene(n, o.duration, o.perturbation);
    const auto table = loom_sweep_table(s.explicit_steps, o.quick);
    std::printf(
        "loom bench accuracy: N=%d (%d vertices, %zu springs), %d frames of 1/60 s, explicit bound h=%.3g s "
        "(%d steps/frame)\n",
        n, s.cloth.mesh->num_vertices(), s.springs.size(), s.frames, s.h_bound, s.explicit_steps);
    const ReferenceRun ref = run_reference(s);

    const size_t first = rows.size();
    std::vector<std::string> skipped_methods;
    for (const auto& kv : table)
      if (std::find(registered.begin(), registered.end(), kv.first) == registered.end())
        skipped_methods.push_back(kv.first);
    run_loom_rows(o, s, table, registered, ref.x, rows);
    run_hybrid_rows(o, s, registered, ref.x, rows);
    run_bullet_rows(o, s, ref.x, rows);
    // A selection that runs nothing would write an empty table and pass its reference check.
    if (rows.size() == first)
      throw loom::Error(
          "", o.configs.empty() ? "--methods" : "--methods/--configs",
          "selects no configuration at N=" + std::to_string(n) +
              (o.configs.empty() ? "" : " (no label contains '" + show_value(o.configs) + "')") +
              ": nothing would be measured");
    if (!skipped_methods.empty()) {
      std::printf("  skipped (not registered in this build):");
      for (const auto& m : skipped_methods) std::printf(" %s", m.c_str());
      std::printf("\n");
    }
    check_reference(n, ref, rows, first, refs);
    const std::vector<PlotPoint> pts = plot_points(rows, first);
    const std::string stem = "accuracy_" + std::to_string(n);
    const std::string png = (folder.dir() / (stem + ".png")).string();
    const std::string title = "hanging cloth " + std::to_string(n) + "x" + std::to_string(n) +
                              ", cotton, 1 m, 0.2 kg, " + num(o.duration) + " s, damping off";
    if (!write_results(o, folder, rows, refs)) return 1;
    if (plot_accuracy(folder, pts, title, stem) && n == o.sizes.back())
      write_file_atomically(folder.claim("accuracy.png").string(), folder.claim("accuracy.png.tmp").string(),
                            read_input_file(png));
  }
  run_static_scenes(o, registered, rows);
  if (!write_results(o, folder, rows, refs)) return 1;
  const std::string shown = show_hidden(o.out);  // the user's path, control characters as \xNN
  std::printf("wrote %s/accuracy.csv, %s/reference_check.csv, %s/accuracy.png\n", shown.c_str(),
              shown.c_str(), shown.c_str());
  return 0;
}

}  // namespace loom::eval
