// PNG writing through Debian's stb (libstb-dev): stb_image_write.
#include <stb_image_write.h>

#include <string>

#include "loom/cloth/Error.h"
#include "loom/cloth/OutputFile.h"
#include "loom/render/Renderer.h"

namespace loom::render {

namespace {

void append_bytes(void* context, void* data, int size) {
  static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<size_t>(size));
}

}  // namespace

std::string encode_png(const Image& image) {
  std::string out;
  if (!stbi_write_png_to_func(append_bytes, &out, image.width, image.height, 3, image.rgb.data(),
                              3 * image.width))
    throw Error("", "", "cannot encode PNG");
  return out;
}

// Encoded in memory, then written through OutputFile (never through a link or into a FIFO at the path).
void write_png(const std::string& path, const Image& image) {
  std::string png;
  if (!stbi_write_png_to_func(append_bytes, &png, image.width, image.height, 3, image.rgb.data(),
                              3 * image.width))
    throw Error(path, "", "cannot encode PNG");
  OutputFile out(path);
  out << png;
  out.close();
  if (!out) throw Error(path, "", out.write_failure());
}

}  // namespace loom::render
