// 2D textures for BSDF parameters: Mitsuba's `bitmap` and `checkerboard` (plus constants, which need no
// texture at all). One tagged struct, switch dispatch, texels stored as linear RGB floats decoded once
// at load time, so a lookup in the hot loop is a few multiplies and up to four loads: no virtual call,
// no allocation, no colour decoding.
//
// Texture coordinates follow Mitsuba 0.5/0.6: (u, v) with v = 0 at the FIRST row of the image file
// (its top), u = 0 at the left column; the texture's own transform u' = u * uscale + uoffset,
// v' = v * vscale + voffset is applied before the lookup (Mitsuba's Texture2D).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "libcommon/color.h"
#include "libcommon/math.h"
#include "libcommon/spectrum.h"

namespace iris {

enum class TextureType : uint8_t { Bitmap, Checkerboard };
// What a texel index outside [0, size) reads (Mitsuba's wrapMode): the index modulo the size; the
// index reflected at each edge (period 2 * size); the nearest edge texel; black; white.
enum class WrapMode : uint8_t { Repeat, Mirror, Clamp, Zero, One };
// Nearest texel, or bilinear interpolation between the four texel centres around (u, v).
enum class TextureFilter : uint8_t { Nearest, Bilinear };

struct Texture {
    TextureType type = TextureType::Bitmap;
    float uscale = 1, vscale = 1, uoffset = 0, voffset = 0;

    // Bitmap: width * height linear RGB texels, row-major, row 0 = top of the image.
    int width = 0, height = 0;
    std::vector<RGB> texels;
    WrapMode wrap_u = WrapMode::Repeat, wrap_v = WrapMode::Repeat;
    TextureFilter filter = TextureFilter::Bilinear;

    // Checkerboard: Mitsuba's defaults.
    RGB color0{0.4f}, color1{0.2f};
};

// The texture's value at surface coordinates uv (before the texture's own scale and offset).
RGB texture_eval(const Texture& t, Vec2 uv);
// Its derivatives along the surface's u and v (per unit of uv, the texture's uscale/vscale included), as
// Mitsuba 0.5 takes them for bump maps: the bilinear interpolant's exact derivative (on the finest level,
// unfiltered); zero for nearest lookups and for the checkerboard (piecewise constant: Mitsuba's finite
// difference is non-zero only within 1e-4 of a square's edge).
void texture_gradient(const Texture& t, Vec2 uv, RGB* d_du, RGB* d_dv);

// Mitsuba's decoding of stored values to linear ones: the sRGB curve is srgb_to_linear (spectrum.h);
// a `gamma` parameter means a power law.
inline float gamma_to_linear(float v, float gamma) { return v <= 0.0f ? 0.0f : std::pow(v, gamma); }

}  // namespace iris
