// A partial render's accumulators in its EXR (render --sample-range A:B), so that tools/merge can add
// the parts of one image into exactly the sums a single run of all samples accumulates.
//
// The film's sums are doubles; EXR stores 32-bit floats. Each double is stored exactly, as its 64-bit
// pattern cut into three 22-bit pieces, each an integer-valued float (exact below 2^24, finite, never
// NaN), in channels "part.<sum>[.<RGB>].b0/b1/b2" (b0 = the low bits). Rounding the doubles to floats
// would not do: a squared radiance of 1e20 is beyond float's range, and the merged image must be the
// single run's to the last bit wherever the double sums agree.
#pragma once

#include <string>

#include "formats/exr.h"
#include "libcommon/film.h"

namespace iris {

// Samples per pixel a part may hold: the count layer is an integer-valued float (exact below 2^24).
inline constexpr int kMaxPartSpp = 1 << 24;

// The image of a film as render writes it: R, G, B, with `variance` the layers variance.R/G/B, with
// `samples` the layer "samples" (render and merge-images both build their image with this).
void add_film_layers(Image& image, const Film& film, bool variance, bool samples);

// Adds the film's accumulators (sums of w L, (w L)^2, w, the sample count, and the light tracer's sums
// where it is enabled) as "part.*" channels.
void add_film_parts(Image& image, const Film& film);
// Whether the image carries them.
bool has_film_parts(const Image& image);
// Adds the image's accumulators to `film` (same resolution; film.enable_light already called where the
// image has light sums). Throws ImageError naming `path` where a channel is missing or a piece is not a
// 22-bit integer (a damaged or foreign file).
void accumulate_film_parts(const Image& image, const std::string& path, Film& film);
// Removes the "part.*" channels.
void strip_film_parts(Image& image);

}  // namespace iris
