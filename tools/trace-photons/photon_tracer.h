// The trace-photons stage: photons leave the lights (chosen in proportion to power), bounce through the
// scene with Russian roulette, and are recorded at every non-specular hit, the first included.
#pragma once

#include <cstdint>
#include <vector>

#include "libcommon/color.h"
#include "libcommon/math.h"
#include "formats/photon_map.h"
#include "libcommon/scene.h"

namespace iris {

struct PhotonOptions {
    uint64_t paths = 250000;  // emitted photon paths N
    int max_depth = 30;       // longest photon path in segments (light -> first hit = 1); -1 = unlimited
    int rr_depth = 3;         // Russian roulette from this many bounces on
    float cutoff = 1e-4f;     // stop a path whose power fell below this fraction of its emitted power
    int threads = 0;          // 0 = all cores
    uint64_t seed = 0;
    bool quiet = false;
    // A part of a photon map split across processes (trace-photons --path-range A:B, merged by
    // merge-photons): only paths [path_begin, path_end) of the `paths` in all, each seeded by its index
    // and carrying flux normalised by the TOTAL path count, so that the parts' photons in range order are
    // the single run's. path_end = 0: all paths.
    uint64_t path_begin = 0, path_end = 0;
};

struct PhotonStats {
    uint64_t paths = 0, photons = 0, nonfinite = 0;
    double seconds = 0;
    RGB emitted_power;  // sum of the lights' power, W
};

// Traces opts.paths photon paths. Deterministic for a seed, whatever the thread count.
PhotonMap trace_photons(const Scene& scene, const PhotonOptions& opts, PhotonStats* stats);

// The paths to emit so that about `photons` photons are stored, from photons per path measured on a probe
// of the first kProbePaths paths (the run then traces them again, as its own first paths), at most
// kMaxPathsForPhotons. Deterministic for a seed, whatever the thread count. Photons per path vary by
// orders of magnitude between scenes (a closed box keeps each photon for many bounces, an open scene
// loses most at once), while what the caches need is photons near them.
constexpr uint64_t kProbePaths = 32768;
constexpr uint64_t kMaxPathsForPhotons = uint64_t(1) << 26;
uint64_t paths_for_photons(const Scene& scene, const PhotonOptions& opts, uint64_t photons);

// (has_specular_surfaces, libcommon/scene.h: without such a surface no photon is ever flagged caustic,
// and the caustic share is 0 whatever the photons.)

}  // namespace iris
