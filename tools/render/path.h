// The camera path: a unidirectional path tracer with next-event estimation and BSDF sampling combined
// by multiple importance sampling (power heuristic), Russian roulette, and Mitsuba's depth convention;
// guided by a cache atlas where PathSettings say so, and joined to light paths by caustic connections
// (connections.h). This is the baseline every guided technique is measured against, so it must itself
// be fast and exact.
#pragma once

#include <cstdint>

#include "libcommon/scene.h"
#include "libguide/guide.h"

namespace iris {

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


}  // namespace iris
