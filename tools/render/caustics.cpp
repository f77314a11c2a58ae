#include "tools/render/caustics.h"
#include "libcommon/mutation.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>

#include "libcommon/emission.h"
#include "libcommon/rng.h"

namespace iris {

CausticTracer::CausticTracer(const Scene& scene, const Camera& camera, int width, int height,
                             const FilterSampler& filter, int max_depth, int rr_depth)
    : scene_(scene), camera_(camera), width_(width), height_(height), filter_(filter), max_depth_(max_depth),
      rr_depth_(rr_depth) {
    pixels_per_plane_area_ = float(width) / (2 * camera.tan_half_x) * (float(height) / (2 * camera.tan_half_y));
}

bool CausticTracer::possible(const Scene& scene) {
    bool area_light = false;
    for (const Light& l : scene.lights)
        area_light = area_light || l.type == LightType::AreaMesh || l.type == LightType::AreaSphere ||
                     l.type == LightType::Constant || l.type == LightType::Envmap;
    return area_light && has_specular_surfaces(scene);
}

// Connects the light path's vertex `hit` (reached from direction w_light, pointing back along the
// light path; beta = its flux, W) to the camera. The camera path's estimator at the same vertex is
// bsdf_eval(wi = towards the camera, wo = towards the light) x incident radiance; the light path's
// beta is flux through the geometric surface, i.e. radiance x |cos_g(wo)| dA dw. Film position u (in
// pixels) and surface area relate as du = pixels_per_plane_area |cos_g(wi)| / (d^2 cos^3 theta) dA, theta
// the angle to the view axis. So the splat is beta f / |cos_g(wo)| x that factor x the filter density.
void CausticTracer::splat(const SurfaceHit& hit, const Bsdf& bsdf, Vec3 w_light, RGB beta,
                          std::vector<CausticSplat>& out, PathCounters& counters, bool* bad) const {
    const Vec3 wo = hit.frame.to_local(w_light);
    if (!(dot(w_light, hit.ng) * wo.z > 0)) return;  // the camera path's consistent_side for its continuation
    const Vec3 to_cam = camera_.origin - hit.p;
    const float dist = length(to_cam);
    if (!(dist > 0)) return;
    const Vec3 w_cam = to_cam / dist;
    const Vec3 wi = hit.frame.to_local(w_cam);
    if (wi.z == 0) return;
    float fx, fy, cos_fwd;
    if (!camera_film_position(camera_, -w_cam, width_, height_, &fx, &fy, &cos_fwd)) return;
    const float depth_along_axis = dist * cos_fwd;
    if (depth_along_axis < camera_.near_clip || depth_along_axis > camera_.far_clip) return;
    const float r = filter_.radius();
    // Pixels whose filter reaches u: centres x + 0.5 within r of fx.
    const int x0 = std::max(0, int(std::ceil(fx - r - 0.5f))), x1 = std::min(width_ - 1, int(std::floor(fx + r - 0.5f)));
    const int y0 = std::max(0, int(std::ceil(fy - r - 0.5f))), y1 = std::min(height_ - 1, int(std::floor(fy + r - 0.5f)));
    if (x0 > x1 || y0 > y1) return;
    const RGB f = bsdf_eval(bsdf, wi, wo);
    if (is_black(f)) return;
    // Visible from the camera: the camera ray starts at the near plane, so the segment ends there.
    ++counters.rays;
    Ray shadow;
    shadow.o = offset_ray_origin(hit.p, hit.ng, w_cam, hit.magnitude);
    shadow.d = w_cam;
    shadow.tmax = length(camera_.origin - shadow.o) - camera_.near_clip / cos_fwd;
    if (shadow.tmax > 0 && scene_.occluded(shadow)) return;
    const float geometry = std::abs(dot(w_cam, hit.ng)) / std::abs(dot(w_light, hit.ng)) * pixels_per_plane_area_ /
                           (dist * dist * cos_fwd * cos_fwd * cos_fwd);
    RGB c = beta * f * geometry;
    if (IRIS_MUTANT(caustic_bias)) c *= 1.05f;
    if (!is_finite(c)) {
        *bad = true;
        return;
    }
    for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
            const float w = filter_.density({fx - (float(x) + 0.5f), fy - (float(y) + 0.5f)});
            if (w > 0) out.push_back({uint32_t(y) * uint32_t(width_) + uint32_t(x), c * w});
        }
}

bool CausticTracer::trace(uint64_t seed, uint64_t index, std::vector<CausticSplat>* out, PathCounters& counters,
                          std::vector<LightVertex>* pool) const {
    Rng rng = Rng::for_index(seed, Stream::LightPaths, index);
    const float u_sel = rng.next_float();
    const Vec2 u_pos{rng.next_float(), rng.next_float()}, u_dir{rng.next_float(), rng.next_float()};
    EmissionSample e;
    if (!sample_emission(scene_, u_sel, u_pos, u_dir, &e)) return true;
    // Delta lights (point, spot, directional) are outside class C (caustics.h); the environment's light
    // paths start outside the scene (emission.h), with no surface to offset from.
    const LightType type = scene_.lights[e.light].type;
    const bool env = type == LightType::Constant || type == LightType::Envmap;
    if (!env && e.n.x == 0 && e.n.y == 0 && e.n.z == 0) return true;
    // Connections join the chains from area lights and the environment (connections.h).
    const float emit_density = pool ? light_emit_density(scene_, e.light, -e.d) : 0.0f;
    RGB beta = e.flux;
    Ray ray;
    ray.o = env ? e.p : offset_ray_origin(e.p, e.n, e.d, scene_.scale());
    ray.d = e.d;
    SurfaceHit hit;
    BsdfScratch bsdf_at_hit;  // textured BSDFs evaluated at the current vertex (scene_bsdf_at)
    bool bad = false;
    // depth = edges from the light to the current vertex; a splat there makes a path of depth + 1 edges.
    for (int depth = 1; max_depth_ < 0 || depth + 1 <= max_depth_; ++depth) {
        ++counters.rays;
        if (!scene_.intersect(ray, &hit)) break;
        const Bsdf& bsdf = scene_bsdf_at(scene_, hit, &bsdf_at_hit);
        const Vec3 w_light = -ray.d;
        const Vec3 wi = hit.frame.to_local(w_light);
        if (wi.z == 0) break;
        if (depth >= 2 && !bsdf_is_delta(bsdf)) {
            if (out) splat(hit, bsdf, w_light, beta, *out, counters, &bad);
            // A pool vertex where the camera path's continuation could leave y along w_light (its
            // consistent_side) and the path tracer would have a density for it.
            if (emit_density > 0 && dot(w_light, hit.ng) * wi.z > 0 && is_finite(beta))
                pool->push_back({hit, w_light, beta, emit_density, depth, -1});
        }
        // Only a Dirac event continues the chain: any other makes x1 a later vertex of a path that is not
        // in class C (the path tracer's).
        if (!bsdf_has_delta_lobe(bsdf)) break;
        Vec3 wo_world;
        bool delta;
        if (!scatter_light_path(hit, bsdf, w_light, depth, rr_depth_, rng, &beta, &wo_world, &delta) || !delta) break;
        if (is_black(beta)) break;
        ray = spawn_ray(hit, wo_world);
    }
    return !bad;
}

uint64_t trace_light_paths(const CausticTracer& tracer, uint64_t seed, uint64_t first, uint64_t count,
                           const std::function<void(const CausticSplat&)>& sink, std::atomic<uint64_t>& rays,
                           const std::function<void(uint64_t, const LightVertex&)>& pool) {
    constexpr uint64_t kChunk = 4096, kChunksPerBatch = 64;  // bounded memory for any number of paths
    const uint64_t chunks = (count + kChunk - 1) / kChunk;
    std::vector<std::vector<CausticSplat>> parts(std::min(chunks, kChunksPerBatch));
    // Pool vertices per chunk, each with the index of its path.
    std::vector<std::vector<LightVertex>> vertices(pool ? parts.size() : 0);
    std::vector<std::vector<uint64_t>> owners(vertices.size());
    uint64_t bad_total = 0;
    for (uint64_t b0 = 0; b0 < chunks; b0 += kChunksPerBatch) {
        const uint64_t b1 = std::min(chunks, b0 + kChunksPerBatch);
        std::atomic<uint64_t> bad{0};
        tbb::parallel_for(b0, b1, [&](uint64_t c) {
            PathCounters counters;
            std::vector<CausticSplat>& out = parts[c - b0];
            out.clear();
            std::vector<LightVertex>* verts = pool ? &vertices[c - b0] : nullptr;
            if (verts) verts->clear(), owners[c - b0].clear();
            uint64_t nb = 0;
            for (uint64_t i = c * kChunk; i < std::min(count, (c + 1) * kChunk); ++i) {
                nb += tracer.trace(seed, first + i, sink ? &out : nullptr, counters, verts) ? 0 : 1;
                if (verts) owners[c - b0].resize(verts->size(), first + i);
            }
            rays += counters.rays;
            bad += nb;
        });
        for (uint64_t c = b0; c < b1; ++c) {
            if (sink)
                for (const CausticSplat& s : parts[c - b0]) sink(s);
            if (pool)
                for (size_t v = 0; v < vertices[c - b0].size(); ++v) pool(owners[c - b0][v], vertices[c - b0][v]);
        }
        bad_total += bad;
    }
    return bad_total;
}

}  // namespace iris
