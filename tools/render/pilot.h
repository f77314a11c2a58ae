// The pilot of automatic guiding and caustic light tracing: a short render of each candidate setting on a
// sparse pixel grid measures its noise and cost, and the combination predicted to win at equal time is
// chosen (decide_guiding).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "libcommon/camera.h"
#include "libcommon/scene.h"
#include "tools/render/path.h"

namespace iris {

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
    std::vector<Candidate> candidates;  // [0]: the setting the others are measured against (unguided where guiding is weighed)
    int chosen = 0;
    double efficiency_ratio = 1;  // (noise x time) of candidate 0 without light tracing / the chosen combination's
    double pilot_seconds = 0;
    int pilot_spp = 0;            // samples per pilot pixel, each candidate
    bool guided_choice = true;    // the candidates differ in guiding (pilot=on), else only light tracing was weighed
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
// `guided`: those themselves, and where `expand` (the user set none of guide-vertices, rr-depth,
// rr-threshold) also every non-specular vertex guided with the roulette threshold
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
// (candidates[0] is the one the others are measured against: unguided where guiding is weighed) and, where
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

}  // namespace iris
