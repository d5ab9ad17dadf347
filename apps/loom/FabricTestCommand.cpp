#include "FabricTestCommand.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <string>

#include "CliValue.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/Model.h"
#include "loom/cloth/OutputFile.h"
#include "loom/eval/CsvNumber.h"
#include "loom/eval/FabricTests.h"
#include "loom/eval/HelperProgram.h"
#include "loom/eval/OutputFolder.h"

namespace fs = std::filesystem;

namespace loom::app {

namespace {

const char* kFabricUsageRest =
    "\n"
    "Runs a standard textile test in simulation and prints measured against theory:\n"
    "  cantilever  ASTM D1388 / FAST-2: tip chord angle against the exact elastica; bending length and "
    "rigidity\n"
    "  tensile     FAST-3: extension at 5, 20, 100 gf/cm; stretch modulus recovered at 5 gf/cm\n"
    "  shear       bias extension: shear modulus from the 45° strip's modulus\n"
    "  catenary    a 1 m strip hung at a span: sag against the analytic catenary\n"
    "  drape       Cusick: a 30 cm disc on an 18 cm support; drape coefficient (%) and node count (no "
    "published\n"
    "              value for these fabrics: theory and error are null; --resolution = rings, default 20)\n"
    "\n"
    "Options:\n"
    "  --material NAME       material preset (default: cotton)\n"
    "  --model M             springs | choi_ko | baraff_witkin ... (default: springs; choi_ko for the\n"
    "                        cantilever, where the springs model's bending is not validated)\n"
    "  --resolution N        nodes along the strip (default: the test's own)\n"
    "  --overhang-ratio X    cantilever: overhang l over bending length c (default 2)\n"
    "  --span D              catenary: span in metres for a 1 m strip (default 0.8)\n"
    "  --solver S            static (default) or a dynamic solver that settles the strip\n"
    "  --settle-frames N     dynamic solvers: at most N frames of 0.01 s per settling, each tensile pull\n"
    "                        its own (default 400); the static solver\n"
    "                        reports its static solves and whether they converged (no settling)\n"
    "  --settle-speed V      dynamic solvers: settled after 3 frames in a row below V m/s (default 1e-6)\n"
    "  --json                print one JSON object (test, material, model, resolution, measured, theory, "
    "error,\n"
    "                        and the test's own fields) instead of text\n"
    "  --overwrite           write into a non-empty --out folder that Loom did not write\n"
    "  --out DIR             report folder (default: out/fabric-test/<test>): report.md, curve.csv, "
    "plot.png\n";

std::string fabric_usage() {
  std::string braced = eval::fabric_test_list();
  for (std::size_t p; (p = braced.find(", ")) != std::string::npos;) braced.replace(p, 2, ",");
  return "Usage: loom fabric-test {" + braced + "} [options]\n" + kFabricUsageRest;
}

// A figure of the report: "-" for one the test has not (no theory value, a run that measured nothing),
// never nan or inf.
std::string shown(double v, const std::string& unit) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << v << (unit.empty() ? "" : " " + unit);
  return s.str();
}

// "static solves | K (converged)" or "settle frames | K (not settled)": the static solver does not settle,
// it solves for the rest shape one frame at a time until the largest move meets the test's tolerance.
std::string settling(const eval::FabricTestResult& r) {
  const bool fixed = r.solver == "static";
  return std::string(fixed ? "static solves | " : "settle frames | ") + std::to_string(r.settle_frames) +
         (fixed ? (r.settled ? " (converged)" : " (NOT converged)")
                : (r.settled ? " (settled)" : " (not settled)"));
}

// The report folder is owned as `loom run` owns its output folder (OutputFolder.h): a foreign non-empty
// folder is refused without --overwrite, and only the report's own files are written.
void write_report(eval::OutputFolder& folder, const eval::FabricTestResult& r) {
  const fs::path& dir = folder.dir();
  for (const char* f : {"curve.csv", "report.md", "plot.gp", "plot.png"}) folder.claim(f);
  {
    OutputFile csv(dir / "curve.csv");
    csv << "series,x,y\n";
    for (const auto& [x, y] : r.curve)
      csv << "simulated," << eval::csv_number(x) << ',' << eval::csv_number(y) << "\n";
    for (const auto& [x, y] : r.theory_curve)
      csv << "theory," << eval::csv_number(x) << ',' << eval::csv_number(y) << "\n";
    if (!csv) throw Error((dir / "curve.csv").string(), "", "write failed");
  }
  OutputFile md(dir / "report.md");
  md << "# Fabric test: " << r.test << "\n\n"
     << "| | |\n|---|---|\n"
     << "| material | " << r.material << " |\n| model | " << r.model << " |\n| resolution | " << r.resolution
     << " |\n"
     << "| " << r.quantity << " measured | " << shown(r.measured, r.unit) << " |\n"
     << "| theory | " << shown(r.theory, r.unit) << " |\n| error | " << shown(r.error, r.unit) << " |\n";
  for (const auto& [k, v] : r.fields) md << "| " << k << " | " << shown(v, "") << " |\n";
  md << "| solver | " << r.solver << " |\n| " << settling(r) << " |\n";
  if (!r.failure.empty()) md << "| failed | " << r.failure << " (no measurement, no simulated curve) |\n";
  md << "| wall time | " << r.seconds << " s |\n| CPU time | " << r.cpu_seconds << " s |\n\n";
  // The plot, through gnuplot when it is installed; column 1 is a string: compared with strcol.
  const bool shape = r.test == "cantilever" || r.test == "catenary" || r.test == "drape";
  std::ostringstream g;
  g << "set datafile separator ','\nset key bottom left\nset grid\n"
    << "set title " << eval::gnuplot_quote(r.test + ": " + r.material + ", " + r.model) << "\n"
    << (shape ? "set size ratio -1\nset xlabel 'x'\nset ylabel 'y'\n"
              : "set xlabel 'extension (%)'\nset ylabel 'load (gf/cm)'\n")
    << "plot 'curve.csv' using (strcol(1) eq 'simulated' ? $2 : 1/0):3 with linespoints title 'simulated', "
       "\\\n"
    << "     '' using (strcol(1) eq 'theory' ? $2 : 1/0):3 with lines lw 2 title 'theory'\n";
  const std::string why =
      eval::gnuplot_png(folder, "plot", "set terminal pngcairo size 640,480 noenhanced", g.str());
  if (why.empty())
    md << "![plot](plot.png)\n";
  else
    md << "(no plot: " << why << "; the data is in curve.csv)\n";
}

}  // namespace

// A finite number in [lo, hi] (nan, inf, 1e999 or trailing text is an error naming the option).
double parse_number(const std::string& flag, const std::string& text, double lo, double hi) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end || !std::isfinite(v) || v < lo || v > hi)
    throw Error("", flag,
                "expects a finite number in [" + cli_show(lo) + ", " + cli_show(hi) + "], got '" +
                    show_value(text) + "'");
  return v;
}

// A whole number in [lo, hi] (5.9 or 0 is an error, never truncated).
int parse_count(const std::string& flag, const std::string& text, long lo, long hi) {
  char* end = nullptr;
  errno = 0;
  const long v = cli_whole_text(text, lo < 0) ? std::strtol(text.c_str(), &end, 10) : 0;
  if (!cli_whole_text(text, lo < 0) || *end || errno == ERANGE || v < lo || v > hi)
    throw Error("", flag,
                "expects a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" +
                    show_value(text) + "'");
  return static_cast<int>(v);
}

int fabric_test_main(int argc, char** argv) {
  eval::FabricTestOptions o;
  std::string material = "cotton", out;
  bool json = false, have_test = false, model_given = false, overwrite = false;
  bool span_given = false, overhang_given = false;
  CliArgs args(argc, argv, 2, "fabric-test");
  while (args.next()) {
    const std::string a = args.arg();
    if (args.operand()) {
      if (have_test) args.fail(a, "a second test (give one of " + eval::fabric_test_list() + ")");
      o.test = a;
      have_test = true;
    } else if (a == "-h" || a == "--help") {
      std::cout << fabric_usage();
      return 0;
    } else if (a == "--material") {
      material = args.value();
    } else if (a == "--model") {
      o.model = args.value();
      model_given = true;
    } else if (a == "--resolution") {
      o.resolution = parse_count(a, args.value(), eval::kMinFabricResolution, eval::kMaxFabricResolution);
    } else if (a == "--overhang-ratio") {
      o.overhang_ratio = parse_number(a, args.value(), 0.1, 100.0);
      overhang_given = true;
    } else if (a == "--span") {
      o.span = parse_number(a, args.value(), 0.01, 0.999);  // below the strip's 1 m length
      span_given = true;
    } else if (a == "--solver") {
      o.solver = args.value();
    } else if (a == "--settle-frames") {
      o.settle_frames = parse_count(a, args.value(), 1, 10000000);
    } else if (a == "--settle-speed") {
      o.settle_speed = parse_number(a, args.value(), 1e-12, 1e3);
    } else if (a == "--json") {
      json = true;
    } else if (a == "--overwrite") {
      overwrite = true;
    } else if (a == "--out") {
      out = cli_path(a, args.value());
    } else {
      args.unknown();
    }
  }
  if (!have_test) {
    std::cerr << fabric_usage();
    return 2;
  }
  // The cantilever is validated against the elastica with choi_ko and baraff_witkin; the springs model's
  // bending springs do not follow it (README, "Fabric tests"), so it is not the default there.
  if (o.test == "cantilever" && !model_given) o.model = "choi_ko";
  o.model_is_default = !model_given;
  if (o.test == "cantilever" && o.model == "springs")
    std::fprintf(
        stderr,
        "loom: warning: --model springs: the springs model's bending does not follow the elastica and its "
        "cantilever angle is far off (use choi_ko or baraff_witkin for a validated result)\n");
  try {
    o.material = cloth::material_preset(material);
  } catch (const Error& e) {
    throw Error("", "--material", e.what());  // the option that named it
  }
  // Every option is checked before the report folder is claimed (a refused command leaves no folder): the
  // options alone, then the scene the test builds from them (a solver that cannot take the model, a specimen
  // it cannot hang: refused naming --solver). The folder is claimed after that and before the test runs, so
  // a refused folder costs nothing.
  eval::check_fabric_test_options(o);
  // An option of another test would have no effect on this one.
  if (span_given && o.test != "catenary")
    throw Error("", "--span", "belongs to the catenary test; the " + o.test + " test does not use it");
  if (overhang_given && o.test != "cantilever")
    throw Error("", "--overhang-ratio",
                "belongs to the cantilever test; the " + o.test + " test does not use it");
  const fs::path dir = out.empty() ? fs::path("out") / "fabric-test" / o.test : fs::path(out);
  if (out.empty()) eval::refuse_linked_default(dir, "--out");
  std::optional<eval::OutputFolder> claimed;
  o.on_ready = [&]() {
    claimed.emplace(dir, "--out", overwrite, false,
                    std::vector<std::string>{"curve.csv", "report.md", "plot.gp", "plot.png"},
                    std::vector<std::string>{});  // no input file
  };
  const eval::FabricTestResult r = eval::run_fabric_test(o);
  eval::OutputFolder& folder = *claimed;
  write_report(folder, r);
  if (!r.failure.empty()) {  // a failed frame or an unconverged static solve: more frames do not help
    std::fprintf(stderr,
                 "loom: error: %s: measured no finite %s (solver %s, stopped after %d frames): %s; the "
                 "report in %s holds no measurement\n",
                 r.test.c_str(), r.quantity.c_str(), r.solver.c_str(), r.settle_frames, r.failure.c_str(),
                 printable(folder.dir().string()).c_str());
    return 3;
  }
  if (!std::isfinite(r.measured)) {  // the report says "-"; the run is not passed off as a measurement
    std::fprintf(
        stderr,
        "loom: error: %s: measured no finite %s (solver %s, %s%s after %d frames%s): try --solver static "
        "(the default) or more --settle-frames; the report in %s holds no measurement\n",
        r.test.c_str(), r.quantity.c_str(), r.solver.c_str(), r.unsettled_in.c_str(),
        r.unsettled_in.empty() ? (r.settled ? "settled" : "not settled") : " not settled", r.settle_frames,
        r.unsettled_in.empty() ? "" : " (--settle-frames counts each pull)",
        printable(folder.dir().string()).c_str());
    return 3;
  }
  if (json) {
    nlohmann::ordered_json j;
    j["test"] = r.test;
    j["material"] = r.material;
    j["model"] = r.model;
    j["resolution"] = r.resolution;
    j["quantity"] = r.quantity;
    j["unit"] = r.unit;
    j["measured"] = r.measured;
    j["theory"] = r.theory;
    j["error"] = r.error;
    for (const auto& [k, v] : r.fields) j[k] = v;
    j["seconds"] = r.seconds;
    j["cpu_seconds"] = r.cpu_seconds;
    j["solver"] = r.solver;
    // The static solver does not settle: its solves and whether they converged; null for the other pair.
    const bool fixed = r.solver == "static";
    j["settle_frames"] = fixed ? nlohmann::ordered_json() : nlohmann::ordered_json(r.settle_frames);
    j["settled"] = fixed ? nlohmann::ordered_json() : nlohmann::ordered_json(r.settled);
    j["static_solves"] = fixed ? nlohmann::ordered_json(r.settle_frames) : nlohmann::ordered_json();
    j["converged"] = fixed ? nlohmann::ordered_json(r.settled) : nlohmann::ordered_json();
    std::cout << j.dump() << "\n";
  } else {
    if (std::isfinite(r.theory))
      std::printf("%s (%s, %s, resolution %d)\n  %s: measured %.6g %s, theory %.6g %s, error %+.4g %s\n",
                  r.test.c_str(), r.material.c_str(), r.model.c_str(), r.resolution, r.quantity.c_str(),
                  r.measured, r.unit.c_str(), r.theory, r.unit.c_str(), r.error, r.unit.c_str());
    else
      std::printf("%s (%s, %s, resolution %d)\n  %s: measured %.6g %s (no theory value)\n", r.test.c_str(),
                  r.material.c_str(), r.model.c_str(), r.resolution, r.quantity.c_str(), r.measured,
                  r.unit.c_str());
    for (const auto& [k, v] : r.fields) std::printf("  %s = %.6g\n", k.c_str(), v);
    if (r.solver == "static")
      std::printf("  solver static: %s in %d static solves (no settling)\n",
                  r.settled ? "converged" : "NOT converged", r.settle_frames);
    else
      std::printf("  solver %s: %d frames, %s\n", r.solver.c_str(), r.settle_frames,
                  r.settled ? "settled" : "NOT settled");
    std::printf("  wall time %.2f s, CPU time %.2f s\n", r.seconds, r.cpu_seconds);
  }
  return 0;
}

}  // namespace loom::app
