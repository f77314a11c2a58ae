// atlas.h5, the output of fill-caches: per cache, a directional distribution of incident radiance on
// an equal-area octahedral map, as a PDF over solid angle and a CDF for sampling.
// Layout, units, the exact mapping and texel order: formats/README.md, "iris-cache-atlas".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "formats/hdf5_util.h"
#include "libcommon/math.h"

namespace iris {

inline constexpr const char* kCacheAtlasFormat = "iris-cache-atlas";
inline constexpr int kCacheAtlasVersion = 1;
inline constexpr const char* kCacheAtlasMapping = "equal-area-octahedral";
// Largest accepted map resolution: the renderer packs each map as 16-bit cumulative counts, whose
// rounding bound holds up to 256 x 256 texels (libguide/packed_map.h), and fill-caches writes no more.
inline constexpr int kCacheAtlasMaxResolution = 256;

// Caches as parallel arrays of size(); pdf and cdf hold size() rows of texels() values each.
//
// Each map is R x R texels (R = resolution) of Clarberg's equal-area octahedral map of the full
// sphere (libcommon/spheremap.h: square_to_sphere), in the cache's local frame Frame(normal)
// (libcommon/math.h: local +z = normal). Texel (i, j) covers [i/R, (i+1)/R) x [j/R, (j+1)/R) of the
// unit square, i along u, j along v; its number is j * R + i, and it covers exactly 4*pi/N sr, N = R^2.
struct CacheAtlas {
    int resolution = 0;          // R
    std::vector<Vec3> position;  // world units
    std::vector<Vec3> normal;    // unit; the local +z axis of the map, on the side the cache serves
    // Density per steradian of the directions the cache proposes, constant inside a texel, >= 0;
    // sum over a row of pdf * 4*pi/N = 1.
    std::vector<float> pdf;
    // Running sum of texel probabilities pdf * 4*pi/N along a row: non-decreasing, last value 1.
    std::vector<float> cdf;
    std::vector<uint32_t> photon_count;  // photons that filled the map
    std::vector<float> radius;           // gather radius that held them, world units
    // 1 = the renderer may guide with this cache; 0 = too few photons (its pdf/cdf row is either a
    // valid distribution or all zeros, and must not be sampled).
    std::vector<uint8_t> usable;
    // Share of the power the map was filled with that passed a specular bounce on its way from the
    // light (photon `caustic` flag), in [0, 1]: light next-event estimation cannot reach. Optional (empty when the
    // photon map had no flags); the renderer guides only where it is significant.
    std::vector<float> caustic_share;
    int k = 0;                   // photons gathered per cache (k nearest)
    std::string filter;          // smoothing filter applied to the maps: "none" or "gaussian"
    // The Gaussian's standard deviation in texel widths of the R x R map (0 with "none"); it is applied
    // as an angle on the sphere, filter_sigma * sqrt(4*pi/N) radians (one texel's angular size).
    double filter_sigma = 0;
    // Weight f in [0, 1] of the uniform density mixed into every map (DESIGN.md section 4.4): texel
    // probability = (1 - f) * map / sum(map) + f / N, so the density is >= f / (4*pi) per steradian.
    double floor = 0;

    size_t size() const { return position.size(); }
    size_t texels() const { return size_t(resolution) * size_t(resolution); }
    const float* pdf_row(size_t i) const { return pdf.data() + i * texels(); }
    const float* cdf_row(size_t i) const { return cdf.data() + i * texels(); }
};

struct CacheAtlasFile {
    StageHeader header;
    CacheAtlas atlas;
};

// Which maps a reader loads. The renderer samples from its own packed form of the pdf
// (libguide/packed_map.h), so it skips the cdf: half the maps' bytes to decompress and check.
enum class AtlasMaps { PdfAndCdf, PdfOnly };

// "" if `atlas` satisfies the contract, else what is wrong (naming the dataset, cache and texel):
// shapes against resolution, finite values, pdf >= 0, cdf non-decreasing, matching the running sum of
// pdf * 4*pi/N within 1e-3 and ending at 1 within 1e-4 (rows of unusable caches may be all zeros).
// With PdfOnly an empty cdf is accepted, and each pdf row must then itself sum to 1 (times 4*pi/N)
// within 1.1e-3, as the cdf checks imply.
std::string validate_cache_atlas(const CacheAtlas& atlas, AtlasMaps maps = AtlasMaps::PdfAndCdf);

// Writes atomically; the numeric stage parameters go in provenance.parameters.
void write_cache_atlas(const std::string& path, const CacheAtlas& atlas, const std::string& scene_fingerprint,
                       const Provenance& provenance);

// Reads and validates the file (with PdfOnly all but the cdf, left empty); expected_fingerprint ""
// skips the scene check.
CacheAtlasFile read_cache_atlas(const std::string& path, const std::string& expected_fingerprint = {},
                                AtlasMaps maps = AtlasMaps::PdfAndCdf);

// Only the root attributes: no map is loaded.
StageHeader read_cache_atlas_header(const std::string& path, const std::string& expected_fingerprint = {});

}  // namespace iris
