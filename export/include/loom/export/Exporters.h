#pragma once
// The run's extra geometry outputs (scene `output.formats`), fed once per written frame by `loom run`:
//   "pc2"  -> DIR/pc2/<cloth>.pc2 (PC2 point cache, every written frame) + DIR/pc2/<cloth>.obj (frame 0
//             mesh, same vertex order: import it with "keep vertex order", add a Mesh Cache modifier)
//   "gltf" -> DIR/animation.gltf + DIR/animation.bin (GltfWriter.h: base mesh + morph-target animation)
// "obj" (DIR/frames/frame_NNNNN.obj) stays in RunCommand.cpp.
#include <memory>
#include <string>
#include <vector>

#include "loom/cloth/Cloth.h"
#include "loom/export/GltfWriter.h"
#include "loom/export/Pc2.h"

namespace loom::exporter {

class Exporters {
 public:
  // Opens the writers of `formats` in `out` (unknown names and "obj" are ignored); deletes nothing: files
  // of an earlier run are the folder owner's to remove. Writes pc2/<file_names()[i]>.obj (the mesh at the
  // first frame given to frame(), not at construction: a resumed run replays its frame 0) and .pc2,
  // animation.gltf (through animation.gltf.tmp) and animation.bin. `every`: frames between samples.
  Exporters(const std::string& out, const std::vector<std::string>& formats,
            const std::vector<std::unique_ptr<cloth::Cloth>>& cloths, int every);
  // Call for every written frame (frame 0 first); `time` in s.
  void frame(double time, const std::vector<std::unique_ptr<cloth::Cloth>>& cloths);
  void finish();
  // Paths written (for messages).
  std::vector<std::string> files() const;

  // File-safe, unique names per cloth ("sheet", "sheet_1", ...).
  static std::vector<std::string> file_names(const std::vector<std::unique_ptr<cloth::Cloth>>& cloths);

 private:
  std::vector<std::unique_ptr<Pc2Writer>> pc2_;
  std::vector<std::string> pc2_mesh_;  // pc2/<name>.obj, written with the first frame
  std::unique_ptr<GltfWriter> gltf_;
  std::vector<std::string> files_;
};

}  // namespace loom::exporter
