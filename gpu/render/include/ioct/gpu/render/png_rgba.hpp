// Rendered images as PNG files (8-bit RGB: the colour already composited over the background;
// the accumulated opacity is not written).
#pragma once

#include <filesystem>

#include "ioct/gpu/render/rgba_image.hpp"

namespace ioct::gpu::render {

// The file appears complete or not at all (AtomicFile). Throws std::runtime_error naming the
// path and the reason.
void write_png(const std::filesystem::path& path, const RgbaImage& image);

}  // namespace ioct::gpu::render
