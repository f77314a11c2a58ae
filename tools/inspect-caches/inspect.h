// inspect-caches as a library: statistics of the stage files (photon map, cache points, atlas) and
// pictures of what a cache learnt, so a person can check what guiding will do before rendering.
#pragma once

#include <string>

#include "formats/cache_atlas.h"
#include "formats/cache_points.h"
#include "formats/exr.h"
#include "formats/photon_map.h"
#include "libcommon/scene.h"

namespace iris {

// Multi-line human-readable summaries (each line "name  value"), ending with a newline.
std::string describe_header(const StageHeader& h);
std::string describe_photon_map(const PhotonMap& m);
std::string describe_cache_points(const CachePoints& c);
std::string describe_cache_atlas(const CacheAtlas& a);
std::string describe_cache(const CacheAtlas& a, size_t cache);

// How a cache's density is drawn.
enum class PdfLayout {
    LatLong,     // the sphere around the cache's normal: theta 0..pi down the image (top half = the
                 // hemisphere the cache serves), phi 0..2pi across; width = 2 * height
    Octahedral,  // the map's own texels (texel (i, j) at column i, row j), each `scale` pixels wide
};

// The density per steradian of cache `cache` as an image with channels R = G = B = pdf (and Y = pdf,
// so viewers show it in grey); metadata names the cache. LatLong: `size` rows; Octahedral: `size`
// pixels per texel. Throws std::runtime_error for a cache index out of range.
Image cache_pdf_image(const CacheAtlas& a, size_t cache, PdfLayout layout, int size);

// The cache that serves pixel (x, y) of the scene's camera at resolution width x height: the one the
// renderer's lookup finds at the first non-specular surface along the pixel centre's ray (through
// specular surfaces the ray follows refraction where it exists, else reflection). Returns -1 (and
// *why says why) when the ray escapes or no cache serves that point.
int cache_for_pixel(const Scene& scene, const CacheAtlas& a, int x, int y, int width, int height, std::string* why);

}  // namespace iris
