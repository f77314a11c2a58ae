#include "tools/render/connections.h"

#include <tbb/parallel_for.h>

#include <algorithm>

#include "libcommon/lights.h"
#include "tools/render/caustics.h"

namespace iris {

float light_emit_density(const Scene& scene, uint32_t light, Vec3 w_from) {
    const Light& l = scene.lights[light];
    if (scene.light_selection.empty()) return 0.0f;
    const float p_select = scene.light_selection.pmf(light);
    switch (l.type) {
        case LightType::AreaMesh:
        case LightType::AreaSphere:
            // sample_emission: the light by power, a point uniform in area, a cosine-distributed direction.
            return l.area > 0 ? p_select / (kPi * l.area) : 0.0f;
        case LightType::Envmap:
        case LightType::Constant: {
            // The direction by the map's density (uniform for the constant sky), an origin uniform on
            // the disk of area pi R^2.
            const double disk = bounding_disk_area(scene);
            const float p_dir = l.type == LightType::Envmap ? envmap_pdf(*l.envmap, w_from) : 1.0f / (4 * kPi);
            return disk > 0 ? float(p_select * p_dir / disk) : 0.0f;
        }
        default:
            return 0.0f;  // delta lights: their chains are not connected
    }
}

float estimate_paths_per_vertex(const CausticTracer& tracer, uint64_t seed, uint64_t first, uint64_t count) {
    std::atomic<uint64_t> rays{0};
    uint64_t vertices = 0;
    trace_light_paths(tracer, seed, first, count, nullptr, rays, [&](uint64_t, const LightVertex&) { ++vertices; });
    return vertices > 0 ? float(double(count) / double(vertices)) : 0.0f;
}

uint64_t build_pools(const CausticTracer& tracer, const Guide* guide, uint64_t seed, uint64_t first, int s0, int s1,
                     uint64_t paths_per_sample, float paths_per_vertex, LightVertexPools* pools,
                     const std::function<void(const CausticSplat&)>& splat, std::atomic<uint64_t>& rays) {
    pools->first = s0;
    pools->paths_per_sample = paths_per_sample;
    pools->paths_per_vertex = paths_per_vertex;
    pools->vertices.clear();
    pools->offsets.assign(size_t(s1 - s0) + 1, 0);
    const uint64_t base = first + uint64_t(s0) * paths_per_sample;
    const uint64_t bad = trace_light_paths(
        tracer, seed, base, uint64_t(s1 - s0) * paths_per_sample, splat, rays, [&](uint64_t index, const LightVertex& v) {
            pools->vertices.push_back(v);
            ++pools->offsets[size_t((index - base) / paths_per_sample) + 1];
        });
    for (size_t i = 1; i < pools->offsets.size(); ++i) pools->offsets[i] += pools->offsets[i - 1];
    // The cache a path tracer vertex at each y would look up (on the side its light arrives from).
    if (guide)
        tbb::parallel_for(size_t(0), pools->vertices.size(), [&](size_t i) {
            LightVertex& v = pools->vertices[i];
            v.cache = guide->lookup(v.hit.p, dot(v.hit.ng, v.w_light) >= 0 ? v.hit.ng : -v.hit.ng);
        });
    return bad;
}

ConnectionPool pool_of(const LightVertexPools& pools, int s) {
    const size_t i = size_t(s - pools.first);
    ConnectionPool c;
    c.vertices = pools.vertices.data() + pools.offsets[i];
    c.count = pools.offsets[i + 1] - pools.offsets[i];
    c.weight = float(double(c.count) / double(pools.paths_per_sample));
    return c;
}

}  // namespace iris
