#pragma once
// `loom compare SCENE [--out DIR] [--set k=v]... [--frames N]`: the scene in Loom (a BulletCloth in
// a Bullet world with the scene's rigid bodies), in Bullet's classic soft body and, where it can, in the
// deformable world; writes DIR/compare.csv and DIR/compare.json.
namespace loom::app {

int compare_main(int argc, char** argv);  // argv[1] == "compare"

}  // namespace loom::app
