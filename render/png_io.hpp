// PNG files through libpng.
#pragma once

#include <string>

#include "image.hpp"

namespace cosserat::render {

// Writes an 8-bit RGB PNG (the directory must exist). Throws std::runtime_error with the reason.
void write_png(const std::string& path, const Image& image);
// Reads a PNG of any colour type and depth as 8-bit RGB (alpha dropped). Throws std::runtime_error.
Image read_png(const std::string& path);

}  // namespace cosserat::render
