// The place-caches stage: where the radiance caches go. One cache per camera block (a primary ray that
// hits a specular surface follows the specular chain to the first non-specular hit), the rest spread
// evenly over the surfaces the photons reached. No cache lands on a purely specular surface.
#pragma once

#include <cstdint>
#include <vector>

#include "libcommon/math.h"
#include "libcommon/scene.h"

namespace iris {

struct PlacementOptions {
    uint32_t count = 20000;     // total caches wanted (camera caches count towards it)
    int camera_stride = 8;      // one camera cache per stride x stride pixel block; 0 = none
    int max_specular = 16;      // longest specular chain followed from the camera
    int width = 0, height = 0;  // image size the blocks refer to (0 = the scene's film)
    int threads = 0;
    uint64_t seed = 0;
    bool quiet = false;
};

enum class CacheOrigin : uint8_t { Camera = 0, Photon = 1 };

struct CachePoint {
    Vec3 position;
    Vec3 normal;  // unit, on the side of the surface the cache serves
    CacheOrigin origin;
};

struct PlacementStats {
    uint32_t camera = 0, photon = 0;
    double cell_size = 0;  // spacing of the photon-cache grid, world units
    double seconds = 0;
};

// `photon_positions`/`photon_normals`: the photon map (normals oriented towards the incident side).
std::vector<CachePoint> place_caches(const Scene& scene, const std::vector<Vec3>& photon_positions,
                                     const std::vector<Vec3>& photon_normals, const PlacementOptions& opts,
                                     PlacementStats* stats);

}  // namespace iris
