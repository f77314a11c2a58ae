// 8-bit PNG output, for looking at images (difference images, cache maps, plots' inputs).
#pragma once

#include <string>
#include <vector>

namespace iris {

// Writes width*height RGB values already in display encoding (0..1, clipped) as an 8-bit sRGB PNG,
// atomically (temporary file, then rename). Throws ImageError naming the path.
void write_png(const std::string& path, int width, int height, const std::vector<float>& rgb01);

}  // namespace iris
