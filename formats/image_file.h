// Image files as inputs (textures, environment maps): PNG, JPEG, OpenEXR and Radiance HDR, decoded by
// libpng, libjpeg, OpenEXR and stb_image respectively; the format is told by the file's first bytes,
// not by its name.
#pragma once

#include <string>

#include "formats/exr.h"

namespace iris {

// What read_image_file returns: an Image with channels "R","G","B" (grey files are expanded to three
// equal channels), plus "A" when the file stores alpha (PNG, EXR). Values are as stored in the file:
//  - PNG and JPEG: integers scaled to 0..1 (8-bit / 255, 16-bit / 65535), NOT linearised;
//    display_encoded is true, since such files are by convention sRGB-encoded (Mitsuba decodes them
//    with the sRGB curve unless the scene gives a gamma).
//  - EXR and HDR: floats as stored (linear radiance by convention); display_encoded is false.
//    EXR files keep their other channels too; a luminance-only EXR ("Y") is expanded to R,G,B.
struct ImageFile {
    Image image;
    bool display_encoded = false;  // true for 8/16-bit integer formats (sRGB-ish), false for float formats
    int bits_per_sample = 32;      // 8 or 16 for PNG/JPEG, 16 or 32 for EXR (as stored; values are float here), 32 for HDR
};

// Decodes the file. Throws ImageError with a one-line message starting with the path for a missing,
// unreadable, truncated, corrupt or unsupported file, or one holding non-finite values.
ImageFile read_image_file(const std::string& path);

}  // namespace iris
