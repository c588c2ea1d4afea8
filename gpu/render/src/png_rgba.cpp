#include "ioct/gpu/render/png_rgba.hpp"

#include "ioct/gpu/volume/png_file.hpp"

namespace ioct::gpu::render {

void write_png(const std::filesystem::path& path, const RgbaImage& image) {
  write_png8(path, image.width, image.height, 4, image.rgba);
}

}  // namespace ioct::gpu::render
