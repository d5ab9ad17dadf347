#pragma once
// `loom bench realtime`: every quality tier (SceneQuality.h) of the character scene and of the hanging sheet,
// and Bullet classic's twin of the character, as points of time per frame against the error from a
// converged reference run of the same scene (RMS vertex distance over all frames, deepest penetration, max
// strain). Writes DIR/character_realtime.csv, DIR/sheet_realtime.csv and a gnuplot PNG of each.
namespace loom::app {

int bench_realtime(int argc, char** argv);

}  // namespace loom::app
