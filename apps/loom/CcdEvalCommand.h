#pragma once
// `loom ccd-eval FILE.csv... [options]`: runs the conservative CCD (loom::collision) on CCD sample-query
// files and prints one line: queries=N positives=P false_negatives=F false_positives=Q us_per_query=T.
namespace loom::app {

int ccd_eval_main(int argc, char** argv);  // argv[1] == "ccd-eval"; returns the process exit code

}  // namespace loom::app
