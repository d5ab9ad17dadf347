// PNG writing through Debian's stb (libstb-dev): stb_image_write.
#include <stb_image_write.h>

#include "loom/cloth/Error.h"
#include "loom/render/Renderer.h"

namespace loom::render {

std::string encode_png(const Image& image) {
  std::string out;
  auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<size_t>(size));
  };
  if (!stbi_write_png_to_func(append, &out, image.width, image.height, 3, image.rgb.data(), 3 * image.width))
    throw Error("", "", "cannot encode PNG");
  return out;
}

void write_png(const std::string& path, const Image& image) {
  if (!stbi_write_png(path.c_str(), image.width, image.height, 3, image.rgb.data(), 3 * image.width))
    throw Error(path, "", "cannot write PNG");
}

}  // namespace loom::render
