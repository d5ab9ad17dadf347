// PNG writing through Debian's stb (libstb-dev): stb_image_write.
#include <stb_image_write.h>

#include "loom/cloth/Error.h"
#include "loom/render/Renderer.h"

namespace loom::render {

void write_png(const std::string& path, const Image& image) {
  if (!stbi_write_png(path.c_str(), image.width, image.height, 3, image.rgb.data(), 3 * image.width))
    throw Error(path, "", "cannot write PNG");
}

}  // namespace loom::render
