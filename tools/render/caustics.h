// Caustics seen directly by the camera, by light tracing.
//
// A path tracer finds light that reaches a directly visible surface through a chain of specular
// bounces (light -> glass -> glass -> wall -> camera, "L S+ D E") only when its continuation from the
// wall happens to hit the light through the chain: for a small bright light behind glass that is a rare
// event of huge weight, the fireflies that dominate the glass egg's error. Traced from the light, the
// same paths are frequent and of small weight: follow the light through its specular bounces and
// connect the first surface with a non-Dirac lobe to the camera (Veach's light tracing strategy).
//
// The two estimators split path space instead of being mixed by MIS, so that neither needs the
// other's densities. The caustic class C is every path x0 (camera) -> x1 -> ... -> xk (an area light)
// with k >= 3 whose event at x1 is a non-Dirac one and whose events at x2 .. x(k-1) are all Dirac; xk may
// also be the environment (constant or envmap: a path that escapes after such a chain, traced from a
// disk covering the scene, emission.h).
// The path tracer drops exactly those contributions (PathSettings::light_traced_caustics: they are
// emitter hits with MIS weight 1, after a delta chain that began at the first vertex), the light tracer
// adds exactly those, and together they estimate the same image (unbiased; tests/pipeline test it
// against the plain path tracer per pixel). Delta lights (point, spot, directional) are left out on both
// sides: the camera cannot hit them (the path tracer has no delta-light caustics, as Mitsuba's).
//
// Each pass of one camera sample per pixel traces a number of light paths for the whole image (by default
// as many as it has pixels; render's pilot chooses the number where it decides, integrator.h); their
// contributions are splatted through the film's reconstruction filter (Film::add_light).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <vector>

#include "libcommon/camera.h"
#include "libcommon/film.h"
#include "libcommon/scene.h"
#include "tools/render/connections.h"
#include "tools/render/path.h"

namespace iris {

struct CausticSplat {
    uint32_t pixel;  // y * width + x
    RGB value;       // radiance x filter density (pixels^-2), for one light path
};

class CausticTracer {
public:
    CausticTracer(const Scene& scene, const Camera& camera, int width, int height, const FilterSampler& filter,
                  int max_depth, int rr_depth);
    // Whether class C can hold any path: an area light and a surface with a Dirac lobe.
    static bool possible(const Scene& scene);
    // Traces light path `index` of the render seeded `seed` and appends its splats to `out` (if given)
    // and its vertices after a specular chain from an area light or the environment to `pool` (if given;
    // connections.h).
    // Returns false if a contribution was NaN or Inf (it is dropped; the caller counts it).
    bool trace(uint64_t seed, uint64_t index, std::vector<CausticSplat>* out, PathCounters& counters,
               std::vector<LightVertex>* pool = nullptr) const;

private:
    // bsdf: the hit's BSDF as scene_bsdf_at resolved it (textures evaluated at the hit).
    void splat(const SurfaceHit& hit, const Bsdf& bsdf, Vec3 w_light, RGB beta, std::vector<CausticSplat>& out,
               PathCounters& counters, bool* bad) const;
    const Scene& scene_;
    const Camera& camera_;
    int width_, height_;
    const FilterSampler& filter_;
    int max_depth_, rr_depth_;
    float pixels_per_plane_area_;  // (W / 2 tan_x)(H / 2 tan_y): film pixels per unit area at distance 1
};

// Traces light paths [first, first + count) and hands their splats to `sink` (if set) and, where `pool`
// is set, their vertices after specular chains (with the index of the path) to `pool`, in path order,
// whatever the thread count (so that sums are reproducible). Returns the paths whose contribution was
// NaN/Inf (dropped).
uint64_t trace_light_paths(const CausticTracer& tracer, uint64_t seed, uint64_t first, uint64_t count,
                           const std::function<void(const CausticSplat&)>& sink, std::atomic<uint64_t>& rays,
                           const std::function<void(uint64_t, const LightVertex&)>& pool = nullptr);

}  // namespace iris
