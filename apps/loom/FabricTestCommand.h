#pragma once
// `loom fabric-test TEST [options]`: the virtual fabric tests (loom/eval/FabricTests.h) from the command
// line, with a small report (report.md, curve.csv, plot.png through gnuplot when installed).
namespace loom::app {

int fabric_test_main(int argc, char** argv);  // argv[1] == "fabric-test"

}  // namespace loom::app
