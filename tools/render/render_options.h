// What the render stage is asked to do (render_image's options), in one small header: the command line
// fills it, the render loop reads it.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "formats/exr.h"
#include "libguide/guide.h"

namespace iris {

struct RenderOptions {
    int spp = 0;             // samples per pixel; 0 = the scene's <sampler> sampleCount
    double time = 0;         // seconds; > 0: render passes until this budget is spent (spp then caps it if set)
    int width = 0, height = 0;  // 0 = the scene's film
    int threads = 0;         // 0 = all cores
    uint64_t seed = 0;
    int max_depth = -2;      // -2 = the scene's <integrator> maxDepth; -1 = unlimited (Mitsuba meaning)
    int rr_depth = -2;       // -2 = the scene's rrDepth
    float rr_threshold = -1; // throughput below which roulette plays (PathSettings); -1 = kRouletteThreshold
    bool variance_layer = false;  // add "variance.R/G/B": variance of each pixel's estimate
    bool samples_layer = false;   // add "samples": samples taken per pixel
    bool quiet = false;
    std::string command_line;     // recorded in the output's metadata
    const Guide* guide = nullptr; // cache atlas to guide with (null = unguided)
    GuideMode mode = GuideMode::NeeBsdfCache;  // how techniques combine when guided
    // Guide the first this many non-specular vertices of a path; 0 = all; -1 = not given: the first one
    // (measured at equal time on all six seed scenes, docs/BENCHMARKS.md: as good as two or better
    // everywhere -- each guided vertex costs a lookup), and with auto_guide also every vertex as a
    // second guided candidate.
    int guide_vertices = -1;
    // With a guide: measure unguided and guided sampling in a short pilot first and guide only if the
    // pilot predicts a win at equal time (decide_guiding); the pilot's time counts in the budget.
    bool auto_guide = false;
    // Light tracing of caustics seen directly by the camera (caustics.h): Off, On (wherever possible),
    // or Auto (where the pilot predicts a win at equal time; it then also picks the light paths per pixel).
    enum class Caustics : uint8_t { Off, On, Auto } caustics = Caustics::Off;
    double light_paths_per_pixel = 0;  // light paths per pixel and pass; 0 = 1 (On) or the pilot's choice (Auto)
    // Caustic connections (connections.h): camera paths join light-traced vertices after specular chains
    // (with the light tracer's paths where caustics are light-traced, else one light path per pixel):
    // Off, On, or Auto (where the pilot (pilot=on) predicts a gain; otherwise off).
    enum class Connect : uint8_t { Off, On, Auto } connect = Connect::Off;
    // How a pixel's samples draw the camera's dimensions: Sobol (each pixel's samples stratify the
    // pixel filter's 2D sample and the first vertex's continuation and light samples: owen_sobol_2d) or
    // Independent (every number from the sample's own generator).
    enum class Sampler : uint8_t { Sobol, Independent } sampler = Sampler::Sobol;
    // Progressive snapshots: when > 0 and `snapshot` is set, it is called with the image so far about
    // every `snapshot_interval` seconds (between passes, on the calling thread).
    // Hybrid caches: where set (the same object as `guide`, built with GuideOptions::learn), the render
    // adds the radiance its guided vertices receive to their caches and refits the caches' maps from
    // photons and path samples after the passes that end at 1, 2, 4, 8, ... samples per pixel (passes are
    // cut there). The maps a pass samples depend only on the passes before it, so the estimator stays
    // unbiased, and the image depends on the seed and the samples per pixel only.
    Guide* learn = nullptr;
    double snapshot_interval = 0;
    std::function<void(const Image&)> snapshot;
    // A part of a render split across processes (render --sample-range A:B, merged by tools/merge):
    // only samples [sample_begin, sample_end) of each pixel (of spp in all), seeded as in one run, and
    // the film's sums in "part.*" channels (film_parts.h). sample_end = 0: the whole render. A part must
    // be a fixed-spp render whose sampling does not depend on a measurement (no time budget, no pilot).
    int sample_begin = 0, sample_end = 0;
    // Settings that change the samples and that render_image does not see (the atlas's fingerprint,
    // settings bsdf-fraction, min-gain): recorded in a part's "iris:settings" so that merge refuses parts
    // of different renders.
    std::string settings_extra;
};

}  // namespace iris
