// The place-caches stage: where the radiance caches go. One cache per camera block (a primary ray that
// hits a specular surface follows the specular chain to the first non-specular hit), the rest spread
// evenly over the surfaces the photons reached (with reach-paths: only those camera paths reach). No cache
// lands on a purely specular surface.
#pragma once

#include <cstdint>
#include <vector>

#include "libcommon/math.h"
#include "formats/cache_points.h"
#include "formats/photon_map.h"
#include "libcommon/scene.h"

namespace iris {

struct PlacementOptions {
    uint32_t count = 20000;     // total caches wanted (camera caches count towards it)
    int camera_stride = 8;      // one camera cache per stride x stride pixel block; 0 = none
    int max_specular = 16;      // longest specular chain followed from the camera
    // Camera paths traced per camera block to find the surfaces a render can reach; only photons on those
    // (same grid cell and facing side) become photon caches. 0 = every photon is a candidate. Off by
    // default: on the window room it kept every cache inside (usable caches 1803 -> 3894) but showed no
    // gain at equal time within the noise of 6 repeats (docs/benchmarks/window_room.md); 4 is the value measured.
    int reach_paths = 0;
    int width = 0, height = 0;  // image size the blocks refer to (0 = the scene's film)
    int threads = 0;
    uint64_t seed = 0;
    bool quiet = false;
};

struct PlacementStats {
    uint32_t camera = 0, photon = 0;
    uint64_t eligible = 0;  // photons that were candidates for photon caches (all of them if reach_paths = 0)
    uint64_t reach_cells = 0;  // (cell, side) pairs camera paths marked
    double cell_size = 0;  // spacing of the photon-cache grid, world units
    double seconds = 0;
};

CachePoints place_caches(const Scene& scene, const PhotonMap& photons, const PlacementOptions& opts,
                         PlacementStats* stats);

}  // namespace iris
