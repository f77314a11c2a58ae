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
    // Guide the first this many non-specular vertices of a path; 0 = all. Measured at equal time on all
    // six seed scenes (docs/BENCHMARKS.md): one is as good as two or better everywhere -- the first
    // vertex carries most of the variance guiding removes, and each guided vertex costs a lookup.
    int guide_vertices = 1;
    // With a guide: measure unguided and guided sampling in a short pilot first and guide only if the
    // pilot predicts a win at equal time (decide_guiding); the pilot's time counts in the budget.
    bool auto_guide = false;
    // Progressive snapshots: when > 0 and `snapshot` is set, it is called with the image so far about
    // every `snapshot_interval` seconds (between passes, on the calling thread).
    double snapshot_interval = 0;
    std::function<void(const Image&)> snapshot;
};

// The pilot's verdict for automatic guiding: measured noise and cost of unguided and guided sampling on
// a sparse pixel grid, and whether guiding is expected to win at equal time.
struct GuideDecision {
    struct Measure {
        double rel_variance = 0;        // mean over pilot pixels of sample variance / (mean^2 + 0.01)
        double seconds_per_sample = 0;  // wall seconds per path sample, all threads working
    } unguided, guided;
    double efficiency_ratio = 1;  // (noise x time) unguided / guided; > 1: guiding wins
    double pilot_seconds = 0;
    int pilot_spp = 0;            // samples per pilot pixel, each technique set
    bool guide = false;
};
// One line for the user and the image's metadata.
std::string describe(const GuideDecision& d);

struct RenderStats {
    GuideDecision decision;      // when automatic guiding decided (decided = true)
    bool decided = false;
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
    // Guide only the first this many non-specular vertices of a path (deeper ones carry little of the
    // pixel's variance but cost the same lookup).
    int guide_vertices = 1 << 30;
};

// Counters kept per worker and summed at the end.
struct PathCounters {
    uint64_t rays = 0;
};

// Guide only when the pilot predicts a clear win: the pilot is noisy, and losing is worse than not
// winning (scenes guiding cannot help must not pay for it).
inline constexpr double kGuideMargin = 1.1;

// Runs the pilot (about budget_seconds, at least a minimum number of samples) for the guided settings
// and their unguided counterpart.
GuideDecision decide_guiding(const Scene& scene, const Camera& camera, int width, int height, uint64_t seed,
                             const PathSettings& guided, double budget_seconds);

class Rng;
// Radiance along the camera ray (one sample of the path-space integral). Never returns NaN/Inf
// unless the scene data are degenerate; callers still check.
RGB trace_path(const Scene& scene, const Ray& ray, Rng& rng, const PathSettings& ps, PathCounters& counters);

// Renders the image. Throws std::runtime_error on invalid options.
Image render_image(const Scene& scene, const RenderOptions& options, RenderStats* stats);

}  // namespace iris
