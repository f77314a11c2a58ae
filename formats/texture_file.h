// Mitsuba `bitmap` textures from image files: decoding (read_image_file) and the conversion of stored
// values to the linear texels libcommon/texture.h looks up. The scene reader fills BitmapOptions from
// the plugin's parameters.
#pragma once

#include <string>

#include "libcommon/texture.h"

namespace iris {

struct BitmapOptions {
    // Mitsuba's `gamma`: 0 = automatic (the sRGB curve for 8/16-bit PNG/JPEG, linear for EXR/HDR),
    // -1 = the sRGB curve, > 0 = stored value ^ gamma.
    float gamma = 0;
    // Mitsuba 0.6's `channel`: "" = RGB; "r", "g", "b" or "a" = that channel on all three (alpha is
    // never gamma-decoded: it is a coverage, not a colour).
    std::string channel;
    TextureFilter filter = TextureFilter::Bilinear;
    WrapMode wrap_u = WrapMode::Repeat, wrap_v = WrapMode::Repeat;
    float uscale = 1, vscale = 1, uoffset = 0, voffset = 0;
};

// Copies the options that say how texels are sampled (filter, wrap modes, uv scale and offset) into t,
// leaving its texels alone: one decoded file serves textures that sample it differently.
void set_bitmap_sampling(const BitmapOptions& options, Texture* t);

// Throws ImageError naming the path (missing/corrupt file, an absent channel, a non-positive gamma
// other than -1 or 0).
Texture load_bitmap_texture(const std::string& path, const BitmapOptions& options);

}  // namespace iris
