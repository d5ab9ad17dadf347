#pragma once
// `loom body MESH CLIP.bvh [--seconds S] [--image FILE.png]`: fits a static human body mesh to the clip's
// skeleton (loom::characters::fit_body), puts a skinned cape on its back (make_back_cape, GarmentInstance),
// plays the clip and prints one line of figures; --image renders the last frame.
namespace loom::app {

int body_main(int argc, char** argv);  // argv[1] == "body"; returns the process exit code

}  // namespace loom::app
