// The render stage: a unidirectional path tracer with next-event estimation and BSDF sampling combined
// by multiple importance sampling (power heuristic), Russian roulette, and Mitsuba's depth convention.
// This is the baseline every guided technique is measured against, so it must itself be fast and exact.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "formats/exr.h"
#include "libcommon/scene.h"
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
    // Off, On, or Auto (where the pilot of --mode auto predicts a gain; otherwise off).
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
    // --bsdf-fraction, --min-gain): recorded in a part's "iris:settings" so that merge refuses parts
    // of different renders.
    std::string settings_extra;
};

// Per-path settings resolved from the options and the scene.
struct PathSettings {
    int max_depth = -1;
    int rr_depth = 5;
    // From rr_depth on, a path whose throughput t (largest component, refraction scaling undone) is
    // below rr_threshold survives with probability min(t / rr_threshold, 0.95) and is divided by it;
    // 1 is Mitsuba's rule (survival = t).
    float rr_threshold = 1.0f;
    const Guide* guide = nullptr;
    GuideMode mode = GuideMode::NeeBsdf;
    // Guide only the first this many non-specular vertices of a path (each guided vertex costs a
    // lookup; >= 2^29 = every vertex).
    int guide_vertices = 1 << 30;
    // The caustic class of caustics.h is light-traced: drop its paths (emitter hits after a Dirac chain
    // that began at the first vertex's non-Dirac event).
    bool light_traced_caustics = false;
    // Caustic connections (connections.h): every non-Dirac vertex joins a light vertex of its sample's
    // pool, and emitter hits after a Dirac chain from a later-bounce vertex take the path tracer's MIS
    // weight against them. paths_per_vertex: n of connections.h.
    bool connect = false;
    float paths_per_vertex = 1;
};

// The pilot's verdict for automatic guiding and caustic light tracing: measured noise and cost of each
// candidate setting on a sparse pixel grid, with and without the light tracer taking over the caustic
// class (caustics.h), and the combination expected to win at equal time.
struct GuideDecision {
    struct Candidate {
        PathSettings settings;
        double rel_variance = 0;        // mean over pilot pixels of sample variance / (mean^2 + 0.01)
        double rel_variance_rest = 0;   // the same without the caustic class (what remains when light-traced)
        double seconds_per_sample = 0;  // wall seconds per path sample, all threads working
    };
    std::vector<Candidate> candidates;  // [0]: the setting the others are measured against (unguided in --mode auto)
    int chosen = 0;
    double efficiency_ratio = 1;  // (noise x time) of candidate 0 without light tracing / the chosen combination's
    double pilot_seconds = 0;
    int pilot_spp = 0;            // samples per pilot pixel, each candidate
    bool guided_choice = true;    // the candidates differ in guiding (--mode auto), else only light tracing was weighed
    // The caustic light tracer, where it was weighed (light_weighed):
    bool light_weighed = false;
    bool light_trace = false;           // chosen
    double light_paths_per_pixel = 0;   // per camera sample, chosen (or given)
    double light_rel_variance = 0;      // its relative variance per camera sample at one light path per pixel
    double light_seconds_per_path = 0;  // wall seconds per light path, all threads working
    double light_share = 0;             // the caustic class's share of the mean pixel
    bool light_share_decides = false;   // light_share >= kMinCausticShare: light-traced whatever the prediction
    uint64_t light_pilot_paths = 0;
    bool guide() const { return candidates.at(size_t(chosen)).settings.guide != nullptr; }
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
    uint64_t light_paths = 0;    // caustic light paths traced (0: not light-traced)
    int refits = 0;              // hybrid caches: refits of the maps from path samples
    double refit_seconds = 0;    // their wall time (inside `seconds`)
    RefitSummary last_refit;
    int threads = 0;
};

// The default roulette threshold. Mitsuba's rule (1) lets a path with throughput 0.1 live with
// probability 0.1 and multiplies it by 10: where a rare deep path finds a bright light through glass
// or a mirror, that multiplies the rare contribution too. Measured at equal spp on the seed scenes
// (relMSE against the 2048-spp references, reference noise removed, x sampling time, two seeds):
// 0.3 is 6-16 % more efficient than 1 on the plain box, the mirror boxes and the glass spheres, equal on
// the plates, 0.1 slightly below 0.3 for unguided rendering (docs/BENCHMARKS.md).
inline constexpr float kRouletteThreshold = 0.3f;
// The deep guided candidate's threshold: with every vertex guided, deep paths find the caustics often,
// and keeping them pays (spheres: 1.89 vs 1.44 efficiency at 0.3, mirror boxes 19.9 vs 15.0).
inline constexpr float kDeepRouletteThreshold = 0.1f;

// Counters kept per worker and summed at the end.
struct PathCounters {
    uint64_t rays = 0;     // closest-hit and shadow rays
    uint64_t lookups = 0;  // vertices at which a cache was looked up (guided rendering)
    // Light samples that reached a guided vertex's shadow test, and those unoccluded: whether the
    // density of a light sample's direction is worth preparing before its shadow ray (trace_path).
    uint64_t guided_shadow_tests = 0, guided_unoccluded = 0;
    bool mostly_unoccluded() const { return 2 * guided_unoccluded >= guided_shadow_tests; }
};

// Guide only when the pilot predicts a clear win: the pilot is noisy, and losing is worse than not
// winning (scenes guiding cannot help must not pay for it).
inline constexpr double kGuideMargin = 1.1;
// Light-trace the caustic class only where the pilot predicts this much gain (every pass pays for the
// light paths), with between these many light paths per pixel and pass.
inline constexpr double kLightMargin = 1.05;
inline constexpr double kMinLightPathsPerPixel = 1.0 / 16, kMaxLightPathsPerPixel = 4;
// Guide fewer vertices than another candidate does only where the pilot predicts this much gain over it.
// The pilot's variance estimates of guided candidates scatter by tens of percent between seeds at ~30
// pilot samples, and where guiding fewer vertices loses it loses big, where it wins it wins little:
// measured at equal time (docs/benchmarks/guide-depth.md, `make -f pipelines/bench.mk guide-depth`)
// every vertex was 1.73x the efficiency of the first vertex alone on the glass spheres, 0.92x on the
// metal ring, and 0.85x on the window room (there the pilot predicts the first vertex 1.6x ahead and
// still takes it), while a 30-s pilot on the spheres once predicted the first vertex 5 % ahead
// (BENCHMARKS.md, issue 25's targets).
inline constexpr double kShallowMargin = 1.25;
// Caustic connections, weighed against the same setting without them (take_connections).
inline constexpr double kConnectMargin = 1.05;
inline constexpr double kConnectTolerance = 1.25;
// The caustic class's share of the image above which it is light-traced whatever the pilot predicts.
inline constexpr double kMinCausticShare = 0.001;

// The guided settings the automatic mode weighs against unguided sampling, from the resolved settings
// `guided`: those themselves, and where `expand` (the user fixed none of --guide-vertices, --rr-depth,
// --rr-threshold) also every non-specular vertex guided with the roulette threshold
// kDeepRouletteThreshold. In closed scenes with caustics (the glass spheres, the mirror boxes) most of
// the unguided variance comes from deep paths that find a light through glass or a mirror: guided at
// every vertex and not cut short by roulette they become frequent instead of rare, and that setting
// wins there at equal time although each guided vertex costs a lookup; elsewhere the first vertex
// alone is cheaper.
std::vector<PathSettings> guided_candidates(const PathSettings& guided, bool expand);
// One line naming a candidate's settings, e.g. "every vertex, roulette below 0.1 from depth 5".
std::string describe(const PathSettings& s);

// decide_guiding's choice from each candidate's predicted efficiency over candidate 0 (`ratio`, 0 =
// ruled out) and the vertices it guides: among candidates 1.., the best, where one that guides fewer
// vertices than the deepest counts its ratio over kShallowMargin; that one if its plain ratio beats
// candidate 0 by kGuideMargin, else 0.
size_t pick_candidate(const std::vector<double>& ratio, const std::vector<int>& guide_vertices);
// Whether a guided candidate takes caustic connections, from the pilot's predicted efficiency over
// candidate 0 with them (`with`, always with the light tracer) and without them (`without`, light-traced
// or not: `without_traced`). Where the light tracer runs either way, connections add a shadow ray per
// vertex, and they lose little where they lose and win big where they win: measured at equal time
// (docs/benchmarks/connect-choice.md, `make -f pipelines/bench.mk connect-choice`, 30 s, 4 seeds) 1.43x on
// the mirror boxes, 2.12x on the glass spheres, 1.10x on the egg and 0.93x on the ring; on the egg what they
// take out is fireflies (lamps seen through glass after a diffuse bounce), which ~30 pilot samples per
// pixel rarely see, and a 60-s render without them had 2x the relMSE of one with them. So there they
// are taken unless the pilot predicts them kConnectTolerance behind. Where the light tracer would not run
// without them, they must pay for it too, and are taken only kConnectMargin ahead.
bool take_connections(double with, double without, bool without_traced);
// Runs the pilot (about budget_seconds, at least a minimum number of samples) for each candidate
// (candidates[0] is the one the others are measured against: unguided in --mode auto) and, where
// `light` is given, a light-tracing pilot of the caustic class; picks the combination predicted to be
// most efficient. With light tracing, the number of light paths per pixel and pass F trades the light
// tracer's noise v_l / F against its cost F t_l: the pilot takes F = sqrt(v_l t / (v t_l)) (v, t: the
// camera paths' remaining noise and cost), within [1/16, 4], unless `light_paths_per_pixel` > 0 fixes it.
// Where `paths_per_vertex` > 0 (n of connections.h) and guiding and light tracing are weighed, each guided
// candidate is also measured with caustic connections (always with the light tracer, whose paths fill
// the pools), and is chosen with them as take_connections says.
class CausticTracer;
GuideDecision decide_guiding(const Scene& scene, const Camera& camera, int width, int height, uint64_t seed,
                             const std::vector<PathSettings>& candidates, double budget_seconds,
                             const CausticTracer* light = nullptr, double light_paths_per_pixel = 0,
                             float paths_per_vertex = 0);

// The lobe the product technique stands in for (Guide::product) where a cache guides a vertex whose BSDF
// is one glossy lobe (a rough conductor, a Ward without a diffuse part): a spherical Gaussian about the
// mirror direction of wi about the shading normal, of this sharpness; 0 elsewhere (a diffuse lobe, whose
// integrand the map already is). A microfacet lobe of roughness a is near exp(-theta_h^2 / a^2) in the
// half-vector angle, and the mirror direction turns twice as fast: exp(-theta^2 / (4 a^2)) =
// exp(k (cos theta - 1)) to second order for k = 1 / (2 a^2). Taken half as sharp: the lobe widens
// towards grazing angles, and a weight too wide costs less than one too narrow (DESIGN.md 6.7).
float glossy_lobe_sharpness(const Bsdf& b);
inline Vec3 mirror_direction(Vec3 wi, Vec3 n) { return 2 * dot(wi, n) * n - wi; }

class Rng;
// Radiance along the camera ray (one sample of the path-space integral). Never returns NaN/Inf
// unless the scene data are degenerate; callers still check. Where `caustic` is given it receives the
// sample's part in the caustic class (caustics.h), which the result leaves out when
// ps.light_traced_caustics.
// Where `samples` is given (hybrid caches: ps.guide learning), each vertex a cache serves adds the
// radiance its continuation received to that cache's texel (PathSamples); the path itself is the same.
// With ps.connect, `pool` is the sample's pool of light vertices (an empty one still weighs the path
// tracer's own contributions, as the strategies' weights must not depend on it).
// Where `first` is given, the first vertex takes its continuation's and its light sample's 2D numbers
// from it (render_image's Sobol sampler) instead of from rng.
struct ConnectionPool;
struct FirstVertexSamples {
    Vec2 u_continue, u_light;
};
RGB trace_path(const Scene& scene, const Ray& ray, Rng& rng, const PathSettings& ps, PathCounters& counters,
               RGB* caustic = nullptr, PathSamples* samples = nullptr, const ConnectionPool* pool = nullptr,
               const FirstVertexSamples* first = nullptr);

// Renders the image. Throws std::runtime_error on invalid options.
Image render_image(const Scene& scene, const RenderOptions& options, RenderStats* stats);

}  // namespace iris
