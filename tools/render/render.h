// The render loop (render_image): resolves the options into path settings, runs the pilot where it
// decides, then renders passes of samples over tiles into the film (with the caustic light tracer's
// splats, connection pools, hybrid caches' refits), within a time budget or to a fixed sample count,
// writing snapshots and the image's metadata.
#pragma once

#include <cstdint>

#include "formats/exr.h"
#include "libcommon/scene.h"
#include "tools/render/pilot.h"
#include "tools/render/render_options.h"

namespace iris {

struct RenderStats {
    GuideDecision decision;      // when automatic guiding decided (decided = true)
    bool decided = false;
    int spp = 0;                 // samples per pixel taken
    double seconds = 0;          // wall time of the sampling passes
    uint64_t paths = 0;          // camera paths traced
    uint64_t rays = 0;           // rays cast (closest-hit and shadow)
    uint64_t nonfinite = 0;      // samples discarded because they were NaN or Inf
    uint64_t light_paths = 0;    // caustic light paths traced (0: not light-traced)
    int refits = 0;              // hybrid caches: refits of the maps from path samples
    double refit_seconds = 0;    // their wall time (inside `seconds`)
    RefitSummary last_refit;
    int threads = 0;
};

// Renders the image. Throws std::runtime_error on invalid options.
Image render_image(const Scene& scene, const RenderOptions& options, RenderStats* stats);

}  // namespace iris
