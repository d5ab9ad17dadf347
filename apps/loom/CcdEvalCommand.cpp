// `loom ccd-eval`: evaluation of loom::collision's CCD against exact ground truth (CcdEvalCommand.h).
#include "CcdEvalCommand.h"

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "CliValue.h"
#include "loom/eval/CcdSampleQueries.h"

namespace loom::app {
namespace {

const char* kCcdEvalUsage =
    "Usage: loom ccd-eval FILE.csv... [--scale-exp K] [--translate D] [--min-separation S] [--tolerance T]\n"
    "\n"
    "Reads CCD sample-query files (8 rows per query: x_num,x_den,y_num,y_den,z_num,z_den,truth; exact\n"
    "rationals; the path must contain 'vertex-face' or 'edge-edge'), runs the conservative vertex-face /\n"
    "edge-edge CCD on every query and prints one line:\n"
    "  queries=N positives=P false_negatives=F false_positives=Q us_per_query=T\n"
    "\n"
    "Options:\n"
    "  --scale-exp K        multiply every coordinate by 2^K first (exact; default 0)\n"
    "  --translate D        then translate each query by a pseudo-random offset in [-D, D]^3 * 2^K (m),\n"
    "                       rounded so every coordinate stays exact (the ground truth is unchanged)\n"
    "  --min-separation S   report pairs that come within S (m; default 0)\n"
    "  --tolerance T        relative image tolerance of the inclusion test (default 1e-6)\n"
    "  -h, --help           this text\n";

}  // namespace

int ccd_eval_main(int argc, char** argv) {
  std::vector<std::string> files;
  int scale_exp = 0;
  double translate = 0;
  collision::CcdOptions options;
  CliArgs args(argc, argv, 2, "ccd-eval");
  while (args.next()) {
    const std::string a = args.arg();
    if (args.operand()) {
      files.push_back(cli_path("FILE.csv", a));
    } else if (a == "-h" || a == "--help") {
      std::cout << kCcdEvalUsage;
      return 0;
    } else if (a == "--scale-exp") {
      scale_exp = static_cast<int>(cli_integer(a, args.value(), -200, 200));
    } else if (a == "--translate") {
      translate = cli_number(a, args.value(), 0.0, 1e6);
    } else if (a == "--min-separation") {
      options.min_separation = cli_number(a, args.value(), 0.0, 1e6);
    } else if (a == "--tolerance") {
      options.tolerance = cli_number(a, args.value(), 0.0, 1.0);
    } else {
      args.unknown();
    }
  }
  if (files.empty()) {
    std::fprintf(stderr, "loom: error: ccd-eval needs at least one FILE.csv (see loom ccd-eval --help)\n");
    return 2;
  }
  std::vector<eval::CcdQuery> queries;
  for (const std::string& f : files) {
    auto q = eval::read_ccd_queries(f);  // throws loom::Error naming the file and line
    queries.insert(queries.end(), q.begin(), q.end());
  }
  std::mt19937_64 rng(20211);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (auto& q : queries) {
    const collision::Vec3 offset(unit(rng), unit(rng), unit(rng));
    eval::scale_translate_exactly(q, scale_exp, offset * translate * std::ldexp(1.0, scale_exp));
  }
  const eval::CcdEvalStats s = eval::evaluate_ccd(queries, options);
  std::printf("queries=%ld positives=%ld false_negatives=%ld false_positives=%ld us_per_query=%.3f\n",
              s.queries, s.positives, s.false_negatives, s.false_positives,
              s.queries ? 1e6 * s.seconds / static_cast<double>(s.queries) : 0.0);
  return 0;
}

}  // namespace loom::app
