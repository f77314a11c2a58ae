// The render stage: a unidirectional path tracer with next-event estimation and BSDF sampling combined
// by multiple importance sampling (power heuristic), Russian roulette, and Mitsuba's depth convention.
// This is the baseline every guided technique is measured against, so it must itself be fast and exact.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "formats/exr.h"
#include "libcommon/scene.h"
#include "tools/render/guide.h"

namespace iris {

struct RenderOptions {
    int spp = 0;             // samples per pixel; 0 = the scene's <sampler> sampleCount
    double time = 0;         // seconds; > 0: render passes until this budget is spent (spp then caps it if set)
    int width = 0, height = 0;  // 0 = the scene's film
    int threads = 0;         // 0 = all cores
    uint64_t seed = 0;
    int max_depth = -2;      // -2 = the scene's <integrator> maxDepth; -1 = unlimited (Mitsuba meaning)
    int rr_depth = -2;       // -2 = the scene's rrDepth
    bool variance_layer = false;  // add "variance.R/G/B": variance of each pixel's estimate
    bool samples_layer = false;   // add "samples": samples taken per pixel
    bool quiet = false;
    std::string command_line;     // recorded in the output's metadata
    const Guide* guide = nullptr; // cache atlas to guide with (null = unguided)
    GuideMode mode = GuideMode::NeeBsdfCache;  // how techniques combine when guided
    // Progressive snapshots: when > 0 and `snapshot` is set, it is called with the image so far about
    // every `snapshot_interval` seconds (between passes, on the calling thread).
    double snapshot_interval = 0;
    std::function<void(const Image&)> snapshot;
};

struct RenderStats {
    int spp = 0;                 // samples per pixel taken
    double seconds = 0;          // wall time of the sampling passes
    uint64_t paths = 0;          // camera paths traced
    uint64_t rays = 0;           // rays cast (closest-hit and shadow)
    uint64_t nonfinite = 0;      // samples discarded because they were NaN or Inf
    int threads = 0;
};

// Per-path settings resolved from the options and the scene.
struct PathSettings {
    int max_depth = -1;
    int rr_depth = 5;
    const Guide* guide = nullptr;
    GuideMode mode = GuideMode::NeeBsdf;
};

// Counters kept per worker and summed at the end.
struct PathCounters {
    uint64_t rays = 0;
};

class Rng;
// Radiance along the camera ray (one sample of the path-space integral). Never returns NaN/Inf
// unless the scene data are degenerate; callers still check.
RGB trace_path(const Scene& scene, const Ray& ray, Rng& rng, const PathSettings& ps, PathCounters& counters);

// Renders the image. Throws std::runtime_error on invalid options.
Image render_image(const Scene& scene, const RenderOptions& options, RenderStats* stats);

}  // namespace iris
