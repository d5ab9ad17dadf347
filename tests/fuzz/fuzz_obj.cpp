// libFuzzer target: the OBJ loader (loom::cloth::ClothMesh::from_obj). Any input must either load
// or throw loom::Error naming the file and line; anything else is a bug. The loader reads a path, so each
// input is written to a per-process temporary file first.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>

#include "loom/cloth/ClothMesh.h"
#include "loom/cloth/Error.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > 64 * 1024) return 0;  // bounded work per iteration
  static const std::string path = "/tmp/loom_fuzz_obj_" + std::to_string(getpid()) + ".obj";
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    auto mesh = loom::cloth::ClothMesh::from_obj(path, 1.0, loom::cloth::Vec3::Zero());
    (void)mesh;
  } catch (const loom::Error&) {
  }
  return 0;
}
