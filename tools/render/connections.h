// Caustic connections: light reflected off a caustic, by joining camera paths to light-traced caustic
// vertices (render's setting connect).
//
// Measured on the seed scenes (render at 64 spp, guided as `auto` chooses, the caustics seen directly
// light-traced; variance layers): after guiding, most of the remaining noise comes from paths whose
// last non-Dirac vertex y is lit only through a specular chain and is itself seen from a later-bounce
// vertex x: a wall lit by the floor's caustic (camera -> wall x -> floor y -> glass -> glass -> light).
// 91 % of the glass spheres' variance, 70 % of the mirror boxes', 61 % of the ring's. NEE cannot reach the
// light from y, and the path tracer must be guided from x to the caustic and then from y through the
// chain onto the light: the last step is a small target that a 6-degree map cell resolves only so well.
//
// The light tracer of caustics.h already follows light through its specular chains to such vertices
// y (light -> S+ -> y). Each pass keeps those vertices (a pool per sample index) and every non-Dirac
// vertex x of a camera path connects to one vertex of its sample's pool, chosen uniformly, with a shadow
// ray: Veach's bidirectional strategy with light subpath L S+ y and camera subpath ending at x.
//
// The two strategies that can make a path x -> y -> S+ -> light are combined by the power heuristic.
// Their density ratio needs only local quantities -- the chain's own (generalised) geometry term is in
// both and cancels:
//   p_connect / p_path = n * p_e * cos_y(chain) * d^2 / (p_x * p_y * cos_y(x))
// p_e: the light tracer's density of the light point per area and of the emitted direction per
// projected solid angle (p_select / (pi area) for a Lambertian area light; for the environment, the
// direction's density per steradian over the area of the disk its paths start on, light_emit_density);
// cos_y: geometric cosines at
// y towards the chain and towards x; d = |x - y|; p_x, p_y: the path tracer's densities (per
// steradian) of the directions x -> y and y -> chain (guided where the path tracer guides there);
// n = light paths per pool vertex, i.e. how many light paths one connection stands for. n is estimated
// once per render from light paths of their own (not the pool's), so that the weights do not depend
// on the pool a connection uses. The Fresnel choices along the chain are the same in both directions
// and cancel; Russian roulette is left out of the weights (any weights that sum to one keep the
// estimate unbiased).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <vector>

#include "libcommon/color.h"
#include "libcommon/scene.h"
#include "libguide/guide.h"

namespace iris {

// A light path's vertex after a specular chain, where a camera path may join it.
struct LightVertex {
    SurfaceHit hit;
    Vec3 w_light;            // unit, from y back along the light path (towards the chain)
    RGB beta;                // the light path's flux arriving at y, W (caustics.h's convention)
    float emit_density = 0;  // p_e of the light the path left (above)
    int depth = 0;           // edges from the light to y
    int cache = -1;          // the cache a path tracer vertex at y would look up (on w_light's side); -1 none
};

// The pools of a range of sample indices [first, first + count): vertex lists per sample index.
struct LightVertexPools {
    int first = 0;
    std::vector<LightVertex> vertices;    // grouped by sample index, in light path order
    std::vector<uint32_t> offsets;        // sample (s - first): vertices [offsets[i], offsets[i + 1])
    uint64_t paths_per_sample = 0;        // N: light paths each pool was traced from
    float paths_per_vertex = 1;           // n above: the render's estimate (not from these pools)
};

// What a camera path needs to connect: its sample's pool.
struct ConnectionPool {
    const LightVertex* vertices = nullptr;
    uint32_t count = 0;
    float weight = 0;  // count / N: the estimate's factor for choosing one vertex of the pool
};

// The power-heuristic weight of the path tracer's strategy for a path x -> y -> S+ -> light, from the
// density ratio above (the connection's weight is 1 minus it).
inline float connection_path_weight(float paths_per_vertex, float emit_density, float cos_y_chain, float cos_y_x,
                                    float dist2, float p_x, float p_y) {
    const float den = p_x * p_y * cos_y_x;
    if (!(den > 0)) return 0.0f;  // the path tracer cannot make this path: the connection takes it whole
    const float r = paths_per_vertex * emit_density * cos_y_chain * dist2 / den;
    return std::isfinite(r) ? 1.0f / (1.0f + r * r) : 0.0f;
}

class CausticTracer;
struct CausticSplat;
// n of connections.h: light paths per pool vertex, from light paths [first, first + count) of their own;
// 0 where none of them reaches a surface through a specular chain from an area light or the environment.
float estimate_paths_per_vertex(const CausticTracer& tracer, uint64_t seed, uint64_t first, uint64_t count);

// Traces `paths_per_sample` light paths for each sample index in [s0, s1) (the light paths of sample s are
// [first + s * paths_per_sample, ...)), splats them to `splat` where set, and fills `pools` with their
// vertices and, with a guide, each vertex's cache. Returns the paths whose splats were NaN/Inf.
uint64_t build_pools(const CausticTracer& tracer, const Guide* guide, uint64_t seed, uint64_t first, int s0, int s1,
                     uint64_t paths_per_sample, float paths_per_vertex, LightVertexPools* pools,
                     const std::function<void(const CausticSplat&)>& splat, std::atomic<uint64_t>& rays);
// The pool of sample s (within the pools' range).
ConnectionPool pool_of(const LightVertexPools& pools, int s);

// p_e of light `light` for the light tracer's emission sampling (emission.h): p_select / (pi area)
// for mesh and sphere area lights; for the environment, whose light arrives from w_from (world, unit,
// pointing to the sky), p_select p(w_from) / (pi R^2), p the emission's density of directions per
// steradian and pi R^2 the disk its paths start on (bounding_disk_area): the same ratio, because a
// specular chain conserves etendue, so that the generalised geometry terms of the two strategies still
// cancel (DESIGN 6.8). 0 for delta lights (whose chains are not connected).
float light_emit_density(const Scene& scene, uint32_t light, Vec3 w_from);

}  // namespace iris
