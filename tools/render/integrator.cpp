#include "tools/render/integrator.h"

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <thread>

#include "libcommon/film.h"
#include "libcommon/progress.h"
#include "libcommon/rng.h"
#include "libcommon/sampling.h"
#include "tools/render/caustics.h"
#include "tools/render/connections.h"
#include "formats/film_parts.h"

namespace iris {

namespace {

// Is wo (world) on the side of the geometric normal that its local z says it is on? Shading normals
// can disagree with the true surface; a direction they send "through" the surface is discarded
// (Mitsuba's check), which prevents light leaks at silhouettes of smooth-shaded meshes.
inline bool consistent_side(Vec3 w_world, Vec3 ng, float local_z) { return dot(w_world, ng) * local_z > 0; }

// Whether cache guiding may help at a vertex with this BSDF. Near-specular lobes are sampled far better
// by the BSDF than by a cache map (a 16x16 texel spans ~13 degrees), so there the vertex stays unguided
// and pays nothing for the lookup; smooth plastic keeps guiding for its diffuse base.
inline bool guidable(const Bsdf& b) {
    switch (b.type) {
        case BsdfType::Diffuse:
        case BsdfType::RoughDiffuse:
        case BsdfType::Plastic:
        case BsdfType::RoughPlastic: return true;
        case BsdfType::RoughConductor: return std::min(b.alpha_u, b.alpha_v) >= 0.2f;
        case BsdfType::Ward: return !is_black(b.diffuse) || std::min(b.alpha_u, b.alpha_v) >= 0.2f;
        default: return false;
    }
}

}  // namespace

float glossy_lobe_sharpness(const Bsdf& b) {
    if (b.type != BsdfType::RoughConductor && !(b.type == BsdfType::Ward && is_black(b.diffuse))) return 0.0f;
    const float a2 = std::max(b.alpha_u * b.alpha_v, 1e-4f);
    return 0.25f / a2;
}

namespace {

// The density (per steradian) with which trace_path continues from a vertex that cache `cache` guides
// (with BSDF b, local wi towards where the path came from, and shading normal ns) in direction wo
// (local; world wo_world): the mixture trace_path samples, written out once more for the vertices it
// does not visit itself (a connection's light vertex).
float guided_density(const Guide& guide, int cache, GuideMode mode, const Bsdf& b, Vec3 wi, Vec3 wo, Vec3 wi_world,
                     Vec3 wo_world, Vec3 ns) {
    const float alpha = mode == GuideMode::NeeCache ? 0.0f : guide.bsdf_fraction(cache);
    const float g = bsdf_guidable_share(b, wi);
    const float p_bsdf = bsdf_pdf(b, wi, wo);
    const float sharpness = glossy_lobe_sharpness(b);
    Guide::Product product;
    const Guide::Texel t = guide.texel(cache, wo_world);
    const float p_cache = sharpness > 0 && guide.product(cache, mirror_direction(wi_world, ns), sharpness, &product)
                              ? guide.product_pdf(product, t)
                              : guide.texel_pdf(cache, t);
    const float q = g < 1 ? bsdf_guidable_pdf(b, wi, wo) : p_bsdf;
    return std::max(0.0f, p_bsdf + (1 - alpha) * (g * p_cache - q));
}

}  // namespace

RGB trace_path(const Scene& scene, const Ray& camera_ray, Rng& rng, const PathSettings& ps, PathCounters& counters,
               RGB* caustic, PathSamples* samples, const ConnectionPool* pool, const FirstVertexSamples* first) {
    const Guide* guide = ps.guide;
    const bool use_nee = ps.mode != GuideMode::BsdfCache;
    RGB L(0.0f), beta(1.0f);
    Ray ray = camera_ray;
    float prev_pdf = 0;        // density of the technique mix that created `ray` (per steradian)
    bool prev_delta = true;    // camera rays and delta bounces: emitters hit are counted fully
    Vec3 prev_p = ray.o;
    float eta_scale = 1.0f;    // product of relative IORs^2 crossed, for Russian roulette (Mitsuba)
    SurfaceHit hit;
    Bsdf bsdf_at_hit;          // textured BSDFs evaluated at the current vertex (scene_bsdf_at)
    int guided_vertices = 0;   // vertices at which a cache was looked up so far
    bool caustic_chain = false;  // so far: a non-Dirac event at the first vertex, Dirac ones after it
    // Caustic connections: the path's last non-Dirac vertex y, where the connection strategy could also
    // have made the path so far (y reached from a non-Dirac vertex x, left on the side x is on), and the
    // quantities of connections.h's density ratio.
    struct {
        bool joinable = false;
        float p_x = 0, p_y = 0, cos_x = 0, cos_chain = 0, dist2 = 0;
    } last_y;
    Vec3 prev_hit_p = ray.o;  // the previous vertex (the camera's position for the first)
    // The pixel's stratified numbers (if any) serve the first vertex that samples a non-Dirac lobe: behind
    // a mirror or glass seen by the camera, that is the vertex whose direction decides the pixel's noise.
    const FirstVertexSamples* stratified_numbers = first;
    // Hybrid caches: the vertices a cache served, each with what it needs to turn the radiance the path
    // gathers after it into the radiance its continuation received: L before the continuation's
    // contributions, the throughput after the vertex (luminance), and cos(theta_c) / p of the
    // continuation direction (its texel in the cache's map).
    struct Recorded {
        int cache, texel;
        float cos_over_pdf, beta_after;
        RGB L_before;
    };
    PathSamples::Writer writer = samples ? samples->writer() : PathSamples::Writer{};
    constexpr int kMaxRecorded = 16;
    Recorded recorded[kMaxRecorded];
    int n_recorded = 0;
    // (texel: wo_world's in cache c's map, Guide::texel_index.)
    auto record = [&](int c, int texel, Vec3 wo_world, float p) {
        if (n_recorded == kMaxRecorded || !guide->records(c)) return;
        const float cos_c = guide->cos_normal(c, wo_world);
        const float b = luminance(beta);
        if (!(cos_c > 0) || !(p > 0) || !(b > 0)) {
            // A direction below the cache's horizon, or a path carrying nothing: counts as a zero sample.
            writer.add(c, texel, 0.0f);
            return;
        }
        writer.prefetch(c, texel);
        recorded[n_recorded++] = {c, texel, cos_c / p, b, L};
    };
    // Emission le that the path reached at its depth-th vertex from light `light_index` (p, n, prim: the
    // point, normal and triangle on an emitter; zero for the environment). Paths do not end at lights (an emitter may also
    // reflect, DESIGN 4.8).
    auto add_emission = [&](RGB le, int depth, int light_index, Vec3 p, Vec3 n, uint32_t prim) {
        if (caustic_chain && depth >= 3) {
            // The caustic class of caustics.h (at least one Dirac vertex; MIS weight 1): the light
            // tracer's where it runs.
            if (caustic) *caustic += beta * le;
            if (!ps.light_traced_caustics) L += beta * le;
        } else {
            float w = 1.0f;
            if (!prev_delta && use_nee)
                w = power_heuristic(prev_pdf, light_pdf(scene, uint32_t(light_index), prim, prev_p, p, n, ray.d));
            else if (prev_delta && ps.connect && last_y.joinable)
                w = connection_path_weight(ps.paths_per_vertex, light_emit_density(scene, uint32_t(light_index), ray.d),
                                           last_y.cos_chain, last_y.cos_x, last_y.dist2, last_y.p_x, last_y.p_y);
            L += beta * le * w;
        }
    };
    for (int depth = 1;; ++depth) {
        ++counters.rays;
        if (!scene.intersect(ray, &hit)) {
            if (scene.environment_light >= 0) {
                const Light& env = scene.lights[scene.environment_light];
                add_emission(light_emitted(env, Vec3(0), -ray.d), depth, scene.environment_light, Vec3(0), Vec3(0), 0);
            }
            break;
        }
        Vec3 wi_world = -ray.d;
        const Bsdf& bsdf = scene_bsdf_at(scene, hit, &bsdf_at_hit);
        const bool delta_only = bsdf_is_delta(bsdf);
        const bool guided_here = guide && !delta_only && guided_vertices < ps.guide_vertices && guidable(bsdf);
        // A guided vertex's first load, its grid slot, starts here (its emission and light sample run
        // meanwhile).
        Guide::Probe probe;
        if (guided_here) probe = guide->probe(hit.p);
        // The light vertex a connection joins (below), chosen now so that it loads meanwhile (the pool is
        // larger than the CPU's caches).
        const LightVertex* join = nullptr;
        if (pool && pool->count > 0 && !delta_only) {
            join = pool->vertices + std::min(pool->count - 1, uint32_t(rng.next_float() * float(pool->count)));
            for (size_t b = 0; b < sizeof(LightVertex); b += 64) __builtin_prefetch(reinterpret_cast<const char*>(join) + b);
        }
        if (hit.light >= 0) {
            const RGB le = light_emitted(scene.lights[hit.light], hit.ng, wi_world);
            if (!is_black(le)) add_emission(le, depth, hit.light, hit.p, hit.ng, hit.prim);
        }
        if (ps.max_depth >= 0 && depth >= ps.max_depth) break;

        Vec3 wi = hit.frame.to_local(wi_world);
        if (wi.z == 0) break;
        // Light sampling and its MIS density are evaluated from a point moved off the surface to the
        // side the path is on: on the surface of a sphere light itself, "inside" (sees all of it) and
        // "outside" (sees none of it) would otherwise be decided by rounding.
        const Vec3 ref = offset_ray_origin(hit.p, hit.ng, wi_world, hit.magnitude);

        // A guided vertex's loads are spread over its work (deep vertices land anywhere in the scene, so
        // p's grid slot and the cache's map are rarely in the CPU's caches): the slot starts loading
        // after the intersection (above) and is read after light sampling; the lookup starts loading the
        // cache's header and row ends, read after NEE's BSDF evaluation; the rows of the map the vertex
        // will read then start loading before NEE's shadow ray.

        // Random numbers in a fixed order: the continuation's, then the light's.
        // (At the first non-Dirac vertex the 2D numbers may come from the pixel's stratified sequences.)
        const FirstVertexSamples* strat = delta_only ? nullptr : stratified_numbers;
        if (strat) stratified_numbers = nullptr;
        const bool stratified = strat != nullptr;
        const float uc = rng.next_float();
        const Vec2 u = stratified ? strat->u_continue : Vec2{rng.next_float(), rng.next_float()};
        LightSample ls;
        bool light_found = false;  // NEE only where the BSDF has a non-delta part
        if (use_nee && !delta_only) {
            const float u_sel = rng.next_float();
            const Vec2 u_light = stratified ? strat->u_light : Vec2{rng.next_float(), rng.next_float()};
            light_found = sample_light(scene, ref, u_sel, u_light, &ls) && ls.pdf > 0 && !is_black(ls.radiance);
        }

        // The cache serving this vertex, and the one-sample mixture of BSDF and cache sampling (DESIGN
        // 4.3). The cache replaces only the lobes bsdf_guidable_share/pdf name (a layered BSDF keeps its
        // coat: a map cannot resolve a glossy highlight): of those, the share alpha stays with the BSDF.
        //   p_mix = p_bsdf + (1 - alpha) (g p_cache - q),  g = guidable share, q = those lobes' density,
        // i.e. the coat as the BSDF samples it, plus g (alpha p_lobes + (1 - alpha) p_cache).
        int cache = -1;
        float alpha = 1.0f, g = 0.0f;
        float sharpness = 0.0f;  // > 0: the cache guides a glossy lobe, by its product with the map
        if (guided_here) {
            ++guided_vertices;
            ++counters.lookups;
            Vec3 n_side = dot(hit.ng, wi_world) >= 0 ? hit.ng : -hit.ng;
            cache = guide->lookup(probe, n_side);
            sharpness = cache >= 0 ? glossy_lobe_sharpness(bsdf) : 0.0f;
            if (sharpness > 0) guide->prefetch_product(cache);
        }
        // NEE's BSDF value (the rest of NEE follows once the cache's rows are loading).
        Vec3 wo_light;
        RGB f_light(0.0f);
        if (light_found) {
            wo_light = hit.frame.to_local(ls.wi);
            if (consistent_side(ls.wi, hit.ng, wo_light.z)) f_light = bsdf_eval(bsdf, wi, wo_light);
        }
        if (cache >= 0) {
            alpha = ps.mode == GuideMode::NeeCache ? 0.0f : guide->bsdf_fraction(cache);
            g = bsdf_guidable_share(bsdf, wi);
        }
        // Where the lobe the cache replaces is glossy, the cache technique samples the map's product
        // with it (Guide::product); every density of the cache technique below is then the product's.
        Guide::Product product;
        const bool use_product =
            sharpness > 0 && guide->product(cache, mirror_direction(wi_world, hit.frame.n), sharpness, &product);
        auto cache_pdf = [&](Guide::Texel t) { return use_product ? guide->product_pdf(product, t) : guide->texel_pdf(cache, t); };
        const float k_cache = (1 - alpha) * g;  // probability of the cache technique (0 unguided)
        auto mix_from = [&](Vec3 wo, float p_bsdf, float p_cache) {
            // Where the whole BSDF is replaceable (g = 1) q is p_bsdf itself (bsdf.h's contract): no
            // second evaluation of the BSDF's density.
            const float q = g < 1 ? bsdf_guidable_pdf(bsdf, wi, wo) : p_bsdf;
            return std::max(0.0f, p_bsdf + (1 - alpha) * (g * p_cache - q));
        };
        const bool use_cache = cache >= 0 && uc >= 1 - k_cache;
        // Where a cache guides, the rows of its map that the vertex will read start loading here, so
        // that they arrive during NEE's shadow ray: the light direction's (see below), and the
        // continuation's (the row the cache sample searches, or the BSDF sample's: the BSDF technique
        // draws its sample now, from random numbers already drawn, so nothing else changes).
        Guide::Texel nee_texel{}, bsdf_texel{};
        int sample_row = 0;  // the row of the cache's map that the cache technique samples
        BsdfSample bs_guided;
        bool bs_guided_ok = false;
        Vec3 bs_guided_world;
        // The light direction's texel only where light samples here are mostly unoccluded (per tile so
        // far): after an occluded shadow ray its density is never read (a light inside glass, as on the
        // egg: 84 % occluded), and computing and loading it there is wasted. Either way the density is
        // the same, so the image does not depend on this choice.
        const bool nee_density = cache >= 0 && !is_black(f_light) && !ls.delta;
        const bool nee_density_early = nee_density && counters.mostly_unoccluded();
        if (cache >= 0) {
            if (nee_density_early) {
                nee_texel = guide->texel(cache, ls.wi);
                guide->prefetch_texel(cache, nee_texel);
            }
            if (use_cache) {
                if (use_product) guide->product_block(&product, u.x);
                else sample_row = guide->sample_row(cache, u);
            } else {
                // uc is remapped to stay uniform for the BSDF's own lobe choice: below 1 - g (the coat)
                // as it is, the rest of [1 - g, 1 - k_cache) stretched onto [1 - g, 1).
                const float keep = 1 - g;
                const float uc_bsdf = uc < keep ? uc : std::min(keep + (uc - keep) / alpha, 0x1.fffffep-1f);
                bs_guided_ok = bsdf_sample(bsdf, wi, u, uc_bsdf, &bs_guided);
                if (bs_guided_ok) bs_guided_world = hit.frame.to_world(bs_guided.wo);
                if (bs_guided_ok && !bs_guided.delta) {
                    bsdf_texel = guide->texel(cache, bs_guided_world);
                    guide->prefetch_texel(cache, bsdf_texel);
                }
            }
        }

        // Next-event estimation, MIS-weighted against the continuation's full mixture density.
        if (!is_black(f_light)) {
            Vec3 from = offset_ray_origin(hit.p, hit.ng, ls.wi, hit.magnitude);
            bool blocked;
            ++counters.rays;
            if (std::isinf(ls.dist)) {
                Ray sr{from, ls.wi, 0.0f, kInf};
                blocked = scene.occluded(sr);
            } else {
                Vec3 to = ls.delta ? ls.p : offset_ray_origin(ls.p, ls.n, -ls.wi);
                blocked = scene.occluded(from, to);
            }
            if (nee_density) {
                ++counters.guided_shadow_tests;
                counters.guided_unoccluded += blocked ? 0 : 1;
            }
            if (!blocked) {
                float w = 1.0f;
                if (nee_density && !nee_density_early) nee_texel = guide->texel(cache, ls.wi);
                if (!ls.delta) {
                    const float p_bsdf = bsdf_pdf(bsdf, wi, wo_light);
                    const float p_mix = cache < 0 ? p_bsdf : mix_from(wo_light, p_bsdf, cache_pdf(nee_texel));
                    w = power_heuristic(ls.pdf, p_mix);
                }
                L += beta * f_light * ls.radiance * (w / ls.pdf);
            }
        }

        // Caustic connection (connections.h): join the light vertex y chosen above, where the whole path
        // fits in the depth limit. Added before the continuation, so that hybrid caches do not count it as
        // light the continuation received.
        if (join) {
            const LightVertex& v = *join;
            const Vec3 d = v.hit.p - hit.p;
            const float dist2 = dot(d, d);
            const Vec3 w = d / std::sqrt(dist2);
            const Vec3 wo_x = hit.frame.to_local(w);
            const float cos_y_x = -dot(w, v.hit.ng), cos_y_chain = dot(v.w_light, v.hit.ng);
            if ((ps.max_depth < 0 || depth + 1 + v.depth <= ps.max_depth) && dist2 > 0 &&
                consistent_side(w, hit.ng, wo_x.z) && cos_y_x * cos_y_chain > 0) {
                const RGB f_x = bsdf_eval(bsdf, wi, wo_x);
                Bsdf bsdf_y_at;
                const Bsdf& bsdf_y = scene_bsdf_at(scene, v.hit, &bsdf_y_at);
                const Vec3 wi_y = v.hit.frame.to_local(-w), wo_y = v.hit.frame.to_local(v.w_light);
                const RGB f_y = wi_y.z != 0 ? bsdf_eval(bsdf_y, wi_y, wo_y) : RGB(0.0f);
                if (!is_black(f_x) && !is_black(f_y)) {
                    ++counters.rays;
                    if (!scene.occluded(offset_ray_origin(hit.p, hit.ng, w, hit.magnitude),
                                        offset_ray_origin(v.hit.p, v.hit.ng, -w, v.hit.magnitude))) {
                        // The path tracer's densities of x -> y and of y -> the chain.
                        const float pb_x = bsdf_pdf(bsdf, wi, wo_x);
                        const float p_x = cache < 0 ? pb_x : mix_from(wo_x, pb_x, cache_pdf(guide->texel(cache, w)));
                        const bool y_guided =
                            guide && v.cache >= 0 && guided_vertices < ps.guide_vertices && guidable(bsdf_y);
                        const float p_y = y_guided ? guided_density(*guide, v.cache, ps.mode, bsdf_y, wi_y, wo_y, -w,
                                                                    v.w_light, v.hit.frame.n)
                                                   : bsdf_pdf(bsdf_y, wi_y, wo_y);
                        const float w_connect =
                            1 - connection_path_weight(ps.paths_per_vertex, v.emit_density, std::abs(cos_y_chain),
                                                       std::abs(cos_y_x), dist2, p_x, p_y);
                        L += beta * f_x * f_y * v.beta *
                             (w_connect * std::abs(cos_y_x) / (dist2 * std::abs(cos_y_chain)) * pool->weight);
                    }
                }
            }
        }

        // Continue the path: BSDF sampling, or (guided) a one-sample choice between BSDF and cache.
        const bool in_delta = prev_delta;  // how the path reached this vertex (for last_y)
        const float in_pdf = prev_pdf;
        Vec3 wo_world;
        if (cache < 0) {
            BsdfSample bs;
            if (!bsdf_sample(bsdf, wi, u, uc, &bs)) break;
            wo_world = hit.frame.to_world(bs.wo);
            if (!consistent_side(wo_world, hit.ng, bs.wo.z)) break;
            beta *= bs.weight;
            eta_scale *= bs.eta * bs.eta;
            prev_pdf = bs.pdf;
            prev_delta = bs.delta;
        } else if (!use_cache) {
            // BSDF technique (its sample drawn above).
            if (!bs_guided_ok) break;
            const BsdfSample& bs = bs_guided;
            const Vec3 wo = bs.wo;
            wo_world = bs_guided_world;
            if (!consistent_side(wo_world, hit.ng, wo.z)) break;
            eta_scale *= bs.eta * bs.eta;
            if (bs.delta) {
                // A Dirac coat comes only from the BSDF technique, with the BSDF's own probability.
                beta *= bs.weight;
                prev_pdf = bs.pdf;
                prev_delta = true;
            } else {
                const float p = mix_from(wo, bs.pdf, cache_pdf(bsdf_texel));
                if (!(p > 0)) break;
                // f = weight * pdf of the BSDF's own sample (bsdf.h): no second evaluation of the BSDF.
                beta *= bs.weight * (bs.pdf / p);
                prev_pdf = p;
                prev_delta = false;
                if (samples) record(cache, guide->texel_index(bsdf_texel), wo_world, p);
            }
        } else {
            float p_cache;
            int texel = 0;
            wo_world = use_product ? guide->sample_product(product, u.y, &p_cache, samples ? &texel : nullptr)
                                   : guide->sample(cache, u, sample_row, &p_cache, samples ? &texel : nullptr);
            const Vec3 wo = hit.frame.to_local(wo_world);
            if (!(p_cache > 0) || !consistent_side(wo_world, hit.ng, wo.z)) break;
            const float p = mix_from(wo, bsdf_pdf(bsdf, wi, wo), p_cache);
            RGB f = bsdf_eval(bsdf, wi, wo);
            if (is_black(f) || !(p > 0)) break;
            beta *= f / p;
            prev_pdf = p;
            prev_delta = false;
            if (samples) record(cache, texel, wo_world, p);
        }
        if (is_black(beta)) break;
        if (ps.connect && !prev_delta) {
            const float cos_x = dot(hit.ng, wi_world), cos_chain = dot(hit.ng, wo_world);
            const Vec3 d = hit.p - prev_hit_p;
            last_y = {depth >= 2 && !in_delta && cos_x * cos_chain > 0, in_pdf, prev_pdf, std::abs(cos_x),
                      std::abs(cos_chain), dot(d, d)};
        }
        prev_hit_p = hit.p;
        caustic_chain = depth == 1 ? !prev_delta : caustic_chain && prev_delta;
        prev_p = ref;
        ray = spawn_ray(hit, wo_world);

        // Russian roulette from rr_depth on (PathSettings::rr_threshold).
        if (depth >= ps.rr_depth) {
            // beta carries the 1/eta^2 radiance scaling of refractions; undo it for the decision only,
            // so paths inside glass are not killed for a change of units.
            float q = std::min(max_component(beta) * eta_scale / ps.rr_threshold, 0.95f);
            if (!(rng.next_float() < q)) break;
            beta /= q;
        }
    }
    // What each recorded vertex's continuation received: the radiance gathered after it, over the
    // throughput it had then (roulette's 1/q included: an unbiased estimate of L_i along it).
    for (int r = 0; r < n_recorded; ++r) {
        const Recorded& v = recorded[r];
        const float li = luminance(L - v.L_before) / v.beta_after;
        writer.add(v.cache, v.texel, li * v.cos_over_pdf);
    }
    return L;
}

namespace {

// Per pilot pixel: sum and sum of squares of the luminance of its samples, and of the same samples
// without their caustic class (what remains for the path tracer where the light tracer takes it).
struct PilotPixel {
    double sum = 0, sum2 = 0, rest = 0, rest2 = 0;
};

// The pilot's sparse pixel grid: every kPilotStride-th pixel in each direction.
constexpr int kPilotStride = 4;
struct PilotGrid {
    int px, py;
    PilotGrid(int width, int height) : px((width + kPilotStride - 1) / kPilotStride), py((height + kPilotStride - 1) / kPilotStride) {}
    static int coord(int i, int size) { return std::min(size - 1, i * kPilotStride + kPilotStride / 2); }
    size_t count() const { return size_t(px) * size_t(py); }
};

// Adds samples [s0, s1) of every pilot pixel to `acc`; returns the wall seconds taken.
double run_pilot(const Scene& scene, const Camera& camera, int width, int height, int s0, int s1, uint64_t seed,
                 const PathSettings& ps, std::vector<PilotPixel>& acc, const LightVertexPools* pools) {
    const PilotGrid grid(width, height);
    acc.resize(grid.count());
    const auto t0 = std::chrono::steady_clock::now();
    tbb::parallel_for(0, grid.py, [&](int j) {
        PathCounters counters;
        for (int i = 0; i < grid.px; ++i) {
            const int x = PilotGrid::coord(i, width), y = PilotGrid::coord(j, height);
            PilotPixel& pp = acc[size_t(j) * size_t(grid.px) + size_t(i)];
            for (int s = s0; s < s1; ++s) {
                ConnectionPool pool;
                if (ps.connect) pool = pool_of(*pools, s);
                // Streams apart from the image's (sample indices from 2^23 on, which no render reaches);
                // both techniques get the same numbers, which makes their comparison less noisy.
                Rng rng = Rng::for_index(seed, Stream::Camera,
                                         ((uint64_t(y) * uint64_t(width) + uint64_t(x)) << 24) ^ uint64_t((1 << 23) + s));
                const float fx = x + rng.next_float(), fy = y + rng.next_float();
                RGB caustic(0.0f);
                const RGB l = trace_path(scene, camera_ray(camera, fx, fy, width, height), rng, ps, counters, &caustic,
                                         nullptr, ps.connect ? &pool : nullptr);
                const bool ok = is_finite(l) && is_finite(caustic);
                const double v = ok ? double(luminance(l)) : 0.0, r = ok ? double(luminance(l - caustic)) : 0.0;
                pp.sum += v;
                pp.sum2 += v * v;
                pp.rest += r;
                pp.rest2 += r * r;
            }
        }
    });
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The light tracer's pilot: `paths` light paths (indices from 2^62 on, apart from the image's); per pilot
// pixel the sum and sum of squares of the luminance of their splats, and in *total the luminance of all
// splats (every pixel's: a small caustic can fall between pilot pixels). Returns the wall seconds taken.
double run_light_pilot(const CausticTracer& tracer, int width, int height, uint64_t seed, uint64_t paths,
                       std::vector<PilotPixel>& acc, double* total) {
    const PilotGrid grid(width, height);
    acc.assign(grid.count(), PilotPixel{});
    std::vector<int32_t> slot(size_t(width) * size_t(height), -1);
    for (int j = 0; j < grid.py; ++j)
        for (int i = 0; i < grid.px; ++i)
            slot[size_t(PilotGrid::coord(j, height)) * size_t(width) + size_t(PilotGrid::coord(i, width))] =
                int32_t(size_t(j) * size_t(grid.px) + size_t(i));
    std::atomic<uint64_t> rays{0};
    const auto t0 = std::chrono::steady_clock::now();
    // (A path that splats one pixel twice -- two of its vertices, rare -- counts as two paths here.)
    trace_light_paths(tracer, seed, uint64_t(1) << 62, paths,
                      [&](const CausticSplat& s) {
                          const double v = luminance(s.value);
                          *total += v;
                          if (const int32_t k = slot[s.pixel]; k >= 0) {
                              acc[size_t(k)].sum += v;
                              acc[size_t(k)].sum2 += v * v;
                          }
                      },
                      rays);
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

std::vector<PathSettings> guided_candidates(const PathSettings& guided, bool expand) {
    std::vector<PathSettings> c{guided};
    if (expand) {
        PathSettings deep = guided;
        deep.guide_vertices = 1 << 30;
        deep.rr_threshold = std::min(guided.rr_threshold, kDeepRouletteThreshold);
        c.push_back(deep);
    }
    return c;
}

size_t pick_candidate(const std::vector<double>& ratio, const std::vector<int>& guide_vertices) {
    const size_t n = ratio.size();
    if (n < 2) return 0;
    int deepest = 0;
    for (size_t c = 1; c < n; ++c) deepest = std::max(deepest, guide_vertices[c]);
    auto rank = [&](size_t c) { return guide_vertices[c] < deepest ? ratio[c] / kShallowMargin : ratio[c]; };
    size_t best = 1;
    for (size_t c = 2; c < n; ++c)
        if (rank(c) > rank(best)) best = c;
    return ratio[best] > kGuideMargin * ratio[0] ? best : 0;
}

bool take_connections(double with, double without, bool without_traced) {
    return without_traced ? with * kConnectTolerance >= without : with > kConnectMargin * without;
}

std::string describe(const PathSettings& s) {
    std::string v = s.guide_vertices >= (1 << 29) ? "every vertex"
                    : s.guide_vertices == 1       ? "first vertex"
                                                  : "first " + std::to_string(s.guide_vertices) + " vertices";
    if (s.rr_depth < (1 << 29)) {
        char buf[64];
        std::snprintf(buf, sizeof buf, ", roulette below %g from depth %d", s.rr_threshold, s.rr_depth);
        v += buf;
    }
    if (s.connect) v += ", caustic connections";
    return v;
}

GuideDecision decide_guiding(const Scene& scene, const Camera& camera, int width, int height, uint64_t seed,
                             const std::vector<PathSettings>& candidates, double budget_seconds,
                             const CausticTracer* light, double light_paths_per_pixel, float paths_per_vertex) {
    // Passes of 2 samples per pilot pixel alternate between the candidates (so none alone pays for cold
    // caches or a busy machine) until the budget is spent, with at least kMinSpp and at most kMaxSpp
    // samples per pilot pixel: rare bright paths (caustics, fireflies) dominate relMSE, and only enough
    // samples see them.
    constexpr int kPass = 2, kMinSpp = 8, kMaxSpp = 256;
    GuideDecision d;
    for (const PathSettings& c : candidates) {
        d.candidates.push_back({c});
        d.candidates.back().settings.light_traced_caustics = false;  // the pilot sees every path; it splits them
    }
    d.guided_choice = candidates.size() > 1;
    // Caustic connections (connections.h): each guided candidate also with them, always with the light
    // tracer (whose paths fill the pools in the render). The pilot's pools: kPoolPaths light paths per
    // sample index, from indices of their own.
    const bool weigh_connect = d.guided_choice && light && paths_per_vertex > 0;
    if (weigh_connect)
        for (size_t c = 1, n = d.candidates.size(); c < n; ++c) {
            d.candidates.push_back(d.candidates[c]);
            d.candidates.back().settings.connect = true;
            d.candidates.back().settings.paths_per_vertex = paths_per_vertex;
        }
    constexpr uint64_t kPoolPaths = 1 << 13, kPoolFirst = uint64_t(5) << 60;
    LightVertexPools pools;
    std::atomic<uint64_t> pool_rays{0};
    const size_t n_cand = d.candidates.size();
    std::vector<std::vector<PilotPixel>> acc(n_cand);
    std::vector<double> seconds(n_cand, 0.0);
    int spp = 0;
    double total = 0;
    while (spp < kMaxSpp && (spp < kMinSpp || total < budget_seconds)) {
        if (weigh_connect) {
            const auto t0 = std::chrono::steady_clock::now();
            build_pools(*light, candidates[1].guide, seed, kPoolFirst, spp, spp + kPass, kPoolPaths, paths_per_vertex,
                        &pools, nullptr, pool_rays);
            total += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        }
        for (size_t c = 0; c < n_cand; ++c) {
            const double t = run_pilot(scene, camera, width, height, spp, spp + kPass, seed, d.candidates[c].settings, acc[c],
                                       &pools);
            seconds[c] += t;
            total += t;
        }
        spp += kPass;
    }
    // The light tracer's pilot: one light path per 4 pixels (at least 2^17, so that rare caustics
    // through small glass objects are seen).
    std::vector<PilotPixel> lacc;
    uint64_t light_paths = 0;
    double light_total = 0;
    if (light) {
        light_paths = std::max<uint64_t>(uint64_t(width) * uint64_t(height) / 4, 1 << 17);
        const double t = run_light_pilot(*light, width, height, seed, light_paths, lacc, &light_total);
        total += t;
        d.light_weighed = true;
        d.light_pilot_paths = light_paths;
        d.light_seconds_per_path = t / double(light_paths);
    }
    // Relative noise of each against the same per-pixel value, so that all are judged on the same
    // scale, what relMSE against a reference weighs: the mean of all candidates' samples over the
    // pilot pixel and its 8 neighbours. The pixel's own mean would not do: one rare bright sample (a
    // caustic path found by BSDF sampling) raises it with the variance, so that variance / mean^2
    // stays near the sample count however heavy the tail, and the pilot would judge unguided sampling
    // far less noisy than it is exactly where guiding helps. Measured over 4 seeds on the six seed
    // scenes: this keeps the egg's predicted variance ratio at 1.5-1.8 where the own mean gave 1.3
    // (its equal-spp renders: ~2) and moves no other scene's by more than 10 %.
    const PilotGrid grid(width, height);
    const int px = grid.px, py = grid.py;
    std::vector<double> rel(n_cand, 0.0), rel_rest(n_cand, 0.0);
    double rel_light = 0, camera_mean = 0;
    auto var = [](double sum, double sum2, double n) { return std::max(0.0, (sum2 - sum * sum / n) / (n - 1)); };
    for (int j = 0; j < py; ++j)
        for (int i = 0; i < px; ++i) {
            double sum = 0;
            int count = 0;
            for (int y = std::max(0, j - 1); y <= std::min(py - 1, j + 1); ++y)
                for (int x = std::max(0, i - 1); x <= std::min(px - 1, i + 1); ++x, ++count)
                    for (size_t c = 0; c < n_cand; ++c) sum += acc[c][size_t(y) * size_t(px) + size_t(x)].sum;
            const double m = sum / (double(n_cand) * spp * count), norm = m * m + 0.01;
            const size_t k = size_t(j) * size_t(px) + size_t(i);
            for (size_t c = 0; c < n_cand; ++c) {
                const PilotPixel& a = acc[c][k];
                rel[c] += var(a.sum, a.sum2, spp) / norm;
                rel_rest[c] += var(a.rest, a.rest2, spp) / norm;
            }
            camera_mean += acc[0][k].sum / spp;
            if (light) {
                // Per light path; a pass of one light path per pixel traces width x height of them, so its
                // noise per camera sample is the per-path variance over that many.
                const PilotPixel& a = lacc[k];
                rel_light += var(a.sum, a.sum2, double(light_paths)) / (double(width) * height) / norm;
            }
        }
    const double pixels = double(std::max<size_t>(1, grid.count())), n = pixels * spp;
    d.pilot_seconds = total;
    d.pilot_spp = spp;
    d.light_rel_variance = rel_light / pixels;
    // Every light path estimates the whole image: its mean pixel is the splats' total over paths and pixels.
    const double light_mean = light ? light_total / double(light_paths) / (double(width) * height) : 0.0;
    camera_mean /= pixels;
    d.light_share = camera_mean > 0 ? light_mean / camera_mean : 0.0;
    const double t_light = d.light_seconds_per_path;
    // noise x time of each candidate without and (where weighed) with the light tracer; ratios against
    // candidate 0 without it. A scene without noise at all (0/0) keeps candidate 0.
    std::vector<double> nt_off(n_cand), nt_on(n_cand, 0.0), f_on(n_cand, 0.0);
    for (size_t c = 0; c < n_cand; ++c) {
        auto& k = d.candidates[c];
        k.rel_variance = rel[c] / pixels;
        k.rel_variance_rest = rel_rest[c] / pixels;
        k.seconds_per_sample = seconds[c] / n;
        nt_off[c] = k.rel_variance * k.seconds_per_sample;
        if (light) {
            double f = light_paths_per_pixel;
            if (!(f > 0)) {
                const double v = k.rel_variance_rest, vl = d.light_rel_variance;
                f = v > 0 && t_light > 0 ? std::sqrt(vl * k.seconds_per_sample / (v * t_light)) : kMaxLightPathsPerPixel;
                f = std::clamp(f, kMinLightPathsPerPixel, kMaxLightPathsPerPixel);
            }
            f_on[c] = f;
            nt_on[c] = (k.rel_variance_rest + d.light_rel_variance / f) * (k.seconds_per_sample + f * t_light);
        }
    }
    auto ratio = [&](double nt) { return nt > 0 ? nt_off[0] / nt : (nt_off[0] > 0 ? 1e30 : 1.0); };
    // Light tracing: where the caustic class is a visible share of the image (kMinCausticShare), or where
    // the pilot predicts a gain by a margin (it costs every pass). The share decides on its own because
    // the pilot's camera samples rarely see the path tracer's estimate of that class at all: it is made of
    // the rare bright samples that find a small light through glass (measured on the glass egg: class
    // 0.3 % of the image, absent from 144 pilot samples on every 16th pixel, yet the remedy for most of
    // its plain relMSE). Then guided only by a margin over candidate 0 (the pilot is noisy, and losing is
    // worse than not winning).
    d.light_share_decides = light && d.light_share >= kMinCausticShare;
    std::vector<double> best_ratio(n_cand);
    std::vector<char> traced(n_cand, 0);
    for (size_t c = 0; c < n_cand; ++c) {
        best_ratio[c] = ratio(nt_off[c]);
        if (d.candidates[c].settings.connect) {
            // Only with the light tracer; where taken, in place of the same candidate without them.
            const size_t twin = c - (n_cand - 1) / 2;
            if (take_connections(ratio(nt_on[c]), best_ratio[twin], traced[twin] != 0)) {
                best_ratio[c] = ratio(nt_on[c]);
                best_ratio[twin] = 0.0;
            } else {
                best_ratio[c] = 0.0;
            }
            traced[c] = 1;
        } else if (light && (d.light_share_decides || ratio(nt_on[c]) > kLightMargin * best_ratio[c])) {
            best_ratio[c] = ratio(nt_on[c]);
            traced[c] = 1;
        }
    }
    std::vector<int> guide_vertices(n_cand);
    for (size_t c = 0; c < n_cand; ++c) guide_vertices[c] = d.candidates[c].settings.guide_vertices;
    const size_t best = pick_candidate(best_ratio, guide_vertices);
    d.chosen = int(best);
    d.efficiency_ratio = best_ratio[best];
    d.light_trace = traced[best] != 0;
    d.light_paths_per_pixel = d.light_trace ? f_on[best] : 0.0;
    return d;
}

std::string describe(const GuideDecision& d) {
    // e.g. "guided (first vertex, roulette below 0.3 from depth 5), caustics light-traced (0.5 light paths
    // per pixel): pilot predicts 1.35x the efficiency of unguided sampling (relative variance [without
    // the caustics], us per sample: unguided 26 [20], 0.87; first vertex, ... 15 [9], 1.1; ...; light
    // tracer 0.5 per path per pixel, 0.12 us per path)"
    const auto& chosen = d.candidates.at(size_t(d.chosen));
    auto name_of = [](const PathSettings& p) { return p.guide ? describe(p) : std::string("unguided"); };
    std::string s = chosen.settings.guide ? "guided (" + describe(chosen.settings) + ")" : "unguided";
    char buf[200];
    if (d.light_weighed) {
        if (d.light_trace)
            std::snprintf(buf, sizeof buf, ", caustics light-traced (%.3g light paths per pixel; %s)", d.light_paths_per_pixel,
                          d.light_share_decides ? "their share of the image" : "predicted gain");
        else
            std::snprintf(buf, sizeof buf, ", caustics not light-traced");
        s += buf;
    }
    std::snprintf(buf, sizeof buf, ": pilot predicts %.2fx the efficiency of %s sampling%s (", d.efficiency_ratio,
                  d.guided_choice ? "unguided" : "plain", d.guided_choice && !d.guide() ? " for this choice" : "");
    s += buf;
    s += d.light_weighed ? "relative variance [without the caustic class], us per sample:" : "relative variance, us per sample:";
    for (size_t c = 0; c < d.candidates.size(); ++c) {
        const auto& k = d.candidates[c];
        const std::string name = name_of(k.settings);
        if (d.light_weighed)
            std::snprintf(buf, sizeof buf, "%s %s %.3g [%.3g], %.3g", c ? ";" : "", name.c_str(), k.rel_variance,
                          k.rel_variance_rest, k.seconds_per_sample * 1e6);
        else
            std::snprintf(buf, sizeof buf, "%s %s %.3g, %.3g", c ? ";" : "", name.c_str(), k.rel_variance,
                          k.seconds_per_sample * 1e6);
        s += buf;
    }
    if (d.light_weighed) {
        std::snprintf(buf, sizeof buf, "; light tracer %.3g at one path per pixel, %.3g us per path, caustic class %.2f %% of the image",
                      d.light_rel_variance, d.light_seconds_per_path * 1e6, 100 * d.light_share);
        s += buf;
    }
    std::snprintf(buf, sizeof buf, "; pilot %d spp on every 16th pixel%s, %.2f s)", d.pilot_spp,
                  d.light_weighed ? (", " + std::to_string(d.light_pilot_paths) + " light paths").c_str() : "",
                  d.pilot_seconds);
    return s + buf;
}

Image render_image(const Scene& scene, const RenderOptions& opt, RenderStats* stats) {
    const int width = opt.width > 0 ? opt.width : scene.film.width;
    const int height = opt.height > 0 ? opt.height : scene.film.height;
    if (width <= 0 || height <= 0 || width > 65536 || height > 65536)
        throw std::runtime_error("invalid resolution " + std::to_string(width) + "x" + std::to_string(height));
    if (opt.spp < 0) throw std::runtime_error("--spp must be positive, got " + std::to_string(opt.spp));
    if (opt.time < 0 || !std::isfinite(opt.time)) throw std::runtime_error("--time must be a positive number of seconds");
    if (opt.threads < 0) throw std::runtime_error("--threads must be positive");
    Camera camera = scene.camera;
    camera_prepare(camera, width, height);
    PathSettings ps;
    ps.guide = opt.guide;
    ps.mode = opt.guide ? opt.mode : GuideMode::NeeBsdf;
    if (opt.guide_vertices < -1) throw std::runtime_error("--guide-vertices must be >= 0");
    ps.guide_vertices = opt.guide_vertices < 0 ? 1 : opt.guide_vertices == 0 ? 1 << 30 : opt.guide_vertices;
    if (!opt.guide && opt.mode == GuideMode::BsdfCache) ps.mode = GuideMode::BsdfCache;
    ps.max_depth = opt.max_depth >= -1 ? opt.max_depth : scene.defaults.max_depth;
    ps.rr_depth = opt.rr_depth >= -1 ? opt.rr_depth : scene.defaults.rr_depth;
    if (ps.rr_depth < 0) ps.rr_depth = 1 << 30;
    if (opt.rr_threshold != -1 && !(opt.rr_threshold > 0 && opt.rr_threshold <= 1))
        throw std::runtime_error("--rr-threshold must be in (0, 1]");
    ps.rr_threshold = opt.rr_threshold == -1 ? kRouletteThreshold : opt.rr_threshold;
    const bool timed = opt.time > 0;
    const int target_spp = opt.spp > 0 ? opt.spp : (timed ? (1 << 30) : scene.defaults.spp);
    const bool part = opt.sample_end > 0;
    if (part) {
        // Refused where the samples a range holds would depend on a measurement made in this process
        // (a clock, a pilot): then the parts of one image could not add up to one run.
        const std::string range = std::to_string(opt.sample_begin) + ":" + std::to_string(opt.sample_end);
        if (timed) throw std::runtime_error("--sample-range needs a fixed --spp, not --time (a budget is not divisible into ranges)");
        if (opt.auto_guide && opt.guide)
            throw std::runtime_error("--sample-range cannot be used with --mode auto (its pilot's choice is measured per "
                                     "process); give a fixed --mode, e.g. nee+bsdf+cache");
        if (opt.caustics == RenderOptions::Caustics::Auto && CausticTracer::possible(scene))
            throw std::runtime_error("--sample-range cannot be used with --caustics auto (its pilot's choice is measured per "
                                     "process); give --caustics on or off");
        if (opt.snapshot_interval > 0) throw std::runtime_error("--sample-range cannot be used with --snapshot (a snapshot is not a whole part)");
        if (opt.learn)
            throw std::runtime_error("--sample-range cannot be used with --learn (a sample's maps are refit from the samples "
                                     "before it, which another process does not have)");
        if (!(opt.sample_begin >= 0 && opt.sample_begin < opt.sample_end && opt.sample_end <= target_spp))
            throw std::runtime_error("--sample-range " + range + " is not within the " + std::to_string(target_spp) +
                                     " samples per pixel of the render (0 <= A < B <= spp)");
        if (opt.sample_end - opt.sample_begin >= kMaxPartSpp)
            throw std::runtime_error("--sample-range " + range + " holds more than " + std::to_string(kMaxPartSpp) + " samples");
    }

    int threads = opt.threads > 0 ? opt.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, size_t(threads));

    FilterSampler filter(scene.film);
    Film film(width, height);
    constexpr int kTile = 16;
    const int tiles_x = (width + kTile - 1) / kTile, tiles_y = (height + kTile - 1) / kTile;
    const int tile_count = tiles_x * tiles_y;
    std::atomic<uint64_t> rays{0}, lookups{0}, nonfinite{0};

    // The clock starts before the pilot: its time is part of the budget (equal-time comparisons).
    auto start = std::chrono::steady_clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
    // Caustics seen directly (caustics.h): light-traced where that is possible and asked for; in Auto
    // the pilot weighs it (and with --mode auto, guiding too) and chooses the light paths per pixel.
    const bool light_possible = opt.caustics != RenderOptions::Caustics::Off && CausticTracer::possible(scene);
    const CausticTracer caustic_tracer(scene, camera, width, height, filter, ps.max_depth, ps.rr_depth);
    if (opt.light_paths_per_pixel < 0 || !std::isfinite(opt.light_paths_per_pixel))
        throw std::runtime_error("--light-paths must be positive");
    double light_paths_per_pixel = light_possible && opt.caustics == RenderOptions::Caustics::On
                                       ? (opt.light_paths_per_pixel > 0 ? opt.light_paths_per_pixel : 1.0)
                                       : 0.0;
    // Caustic connections (connections.h): n from light paths of their own (indices no pass uses), so
    // that the weights depend on no pool; before the pilot, which weighs them.
    float paths_per_vertex = 0;
    if (opt.connect != RenderOptions::Connect::Off && CausticTracer::possible(scene) && ps.mode != GuideMode::BsdfCache) {
        constexpr uint64_t kEstimatePaths = 1 << 15, kEstimateFirst = uint64_t(3) << 61;
        paths_per_vertex = estimate_paths_per_vertex(caustic_tracer, opt.seed, kEstimateFirst, kEstimatePaths);
    }
    GuideDecision decision;
    const bool weigh_guiding = opt.auto_guide && ps.guide;
    const bool weigh_light = light_possible && opt.caustics == RenderOptions::Caustics::Auto;
    if (weigh_guiding || weigh_light) {
        // A pilot of ~3 % of a time budget (or the minimum for a fixed spp). Without guiding to weigh it
        // measures the setting given, with and without the light tracer.
        const bool expand = opt.guide_vertices < 0 && opt.rr_depth < -1 && opt.rr_threshold == -1;
        std::vector<PathSettings> candidates{ps};
        if (weigh_guiding) {
            candidates[0].guide = nullptr;
            candidates[0].mode = GuideMode::NeeBsdf;
            for (const PathSettings& g : guided_candidates(ps, expand)) candidates.push_back(g);
        }
        decision = decide_guiding(scene, camera, width, height, opt.seed, candidates, timed ? 0.03 * opt.time : 0.0,
                                  weigh_light ? &caustic_tracer : nullptr, opt.light_paths_per_pixel,
                                  opt.connect == RenderOptions::Connect::Auto ? paths_per_vertex : 0.0f);
        if (!opt.quiet) std::fprintf(stderr, "render: %s\n", describe(decision).c_str());
        ps = decision.candidates[size_t(decision.chosen)].settings;
        if (weigh_light) light_paths_per_pixel = decision.light_paths_per_pixel;
    } else if (opt.caustics != RenderOptions::Caustics::Off && !opt.quiet) {
        std::fprintf(stderr, "render: caustics %s\n",
                     light_possible ? "light-traced (--caustics on)"
                                    : "not light-traced: no area light or sky reaches a surface through a specular (Dirac) bounce");
    }
    // Light paths per pass of one sample per pixel (an integer, so that the film's count is exact).
    const uint64_t light_paths_per_sample =
        light_paths_per_pixel > 0
            ? std::max<uint64_t>(1, uint64_t(std::llround(light_paths_per_pixel * double(width) * double(height))))
            : 0;
    if (light_paths_per_sample > 0) film.enable_light(double(light_paths_per_sample));
    ps.light_traced_caustics = light_paths_per_sample > 0;
    // Caustic connections: with the light tracer's paths (or, where it does not run, one light path per
    // pixel for the pools alone).
    if (opt.connect == RenderOptions::Connect::On && paths_per_vertex > 0) {
        ps.connect = true;
        ps.paths_per_vertex = paths_per_vertex;
    }
    const uint64_t pool_paths_per_sample =
        !ps.connect ? 0 : light_paths_per_sample > 0 ? light_paths_per_sample : uint64_t(width) * uint64_t(height);
    if (opt.connect == RenderOptions::Connect::On && !opt.quiet)
        std::fprintf(stderr, "render: caustic connections %s\n",
                     ps.connect ? ("on (" + std::to_string(pool_paths_per_sample) + " light paths per sample pass)").c_str()
                                : "off: no light path reaches a surface through a specular chain from an area light or the sky");
    Progress progress("render", timed ? uint64_t(opt.time * 1000) : uint64_t(part ? opt.sample_end - opt.sample_begin : target_spp) * tile_count, opt.quiet);

    // Hybrid caches: what the guided vertices receive (only while the chosen setting guides).
    if (opt.learn && opt.learn != opt.guide) throw std::runtime_error("render: the learning guide must be the guide");
    if (opt.learn && !opt.learn->learning()) throw std::runtime_error("render: the guide was not built to learn");
    std::unique_ptr<PathSamples> path_samples;
    if (opt.learn && ps.guide)
        path_samples = std::make_unique<PathSamples>(opt.learn->atlas().size(), opt.learn->atlas().texels());
    int next_refit = 1;  // samples per pixel after which the maps are next refit
    int refits = 0;
    double refit_seconds = 0;
    RefitSummary last_refit;

    // One pass renders samples [s0, s1) of every pixel. Each sample's random numbers come from
    // (seed, pixel, sample index), so the image does not depend on threads or on how passes are cut.
    LightVertexPools pools;
    const bool sobol = opt.sampler == RenderOptions::Sampler::Sobol;
    auto run_samples = [&](int s0, int s1) {
        tbb::parallel_for(0, tile_count, [&](int tile) {
            PathCounters counters;
            uint64_t bad = 0;
            int tx = tile % tiles_x, ty = tile / tiles_x;
            int x0 = tx * kTile, y0 = ty * kTile;
            int x1 = std::min(width, x0 + kTile), y1 = std::min(height, y0 + kTile);
            // Sample by sample over the tile: with connections, the tile's paths then read one pool at a time.
            for (int s = s0; s < s1; ++s) {
                ConnectionPool pool;
                if (ps.connect) pool = pool_of(pools, s);
                for (int y = y0; y < y1; ++y)
                    for (int x = x0; x < x1; ++x) {
                        const uint64_t pixel = uint64_t(y) * uint64_t(width) + uint64_t(x);
                        Rng rng = Rng::for_index(opt.seed, Stream::Camera, (pixel << 24) ^ uint64_t(s));
                        float w;
                        Vec2 u_filter;
                        FirstVertexSamples first;
                        if (sobol) {
                            // Three 2D sequences of the pixel, each with scrambles of its own: sample s
                            // is point s of each, and the shuffled indices pair them at random.
                            const uint64_t h = hash3(opt.seed, uint64_t(Stream::Camera), pixel);
                            u_filter = owen_sobol_2d(uint32_t(s), mix64(h));
                            first.u_continue = owen_sobol_2d(uint32_t(s), mix64(h + 1));
                            first.u_light = owen_sobol_2d(uint32_t(s), mix64(h + 2));
                        } else {
                            u_filter = Vec2{rng.next_float(), rng.next_float()};
                        }
                        Vec2 off = filter.sample(u_filter, &w);
                        float fx = x + 0.5f + off.x, fy = y + 0.5f + off.y;
                        RGB l = trace_path(scene, camera_ray(camera, fx, fy, width, height), rng, ps, counters,
                                           nullptr, path_samples.get(), ps.connect ? &pool : nullptr,
                                           sobol ? &first : nullptr);
                        if (!is_finite(l) || !std::isfinite(w)) {
                            ++bad;  // counted and reported; the sample still counts with zero radiance
                            l = RGB(0.0f);
                            if (!std::isfinite(w)) w = 0;
                        }
                        film.add(x, y, l, w);
                    }
            }
            rays += counters.rays;
            lookups += counters.lookups;
            nonfinite += bad;
            if (!timed) progress.advance(uint64_t(s1 - s0));
        });
        if (light_paths_per_sample > 0 && !ps.connect)
            nonfinite += trace_light_paths(caustic_tracer, opt.seed, uint64_t(s0) * light_paths_per_sample,
                                           uint64_t(s1 - s0) * light_paths_per_sample,
                                           [&](const CausticSplat& sp) { film.add_light(sp.pixel, sp.value); }, rays);
    };
    // With connections, the light paths of a batch of samples come first (they fill its pools, and are
    // splatted where the caustics are light-traced), in batches of at most ~1M light paths.
    auto run_pass = [&](int s0, int s1) {
        if (!ps.connect) return run_samples(s0, s1);
        const int batch = int(std::max<uint64_t>(1, (uint64_t(1) << 20) / pool_paths_per_sample));
        for (int a = s0; a < s1; a += batch) {
            const int b = std::min(s1, a + batch);
            nonfinite += build_pools(caustic_tracer, ps.guide, opt.seed, 0, a, b, pool_paths_per_sample, ps.paths_per_vertex,
                                     &pools,
                                     light_paths_per_sample > 0
                                         ? std::function<void(const CausticSplat&)>(
                                               [&](const CausticSplat& sp) { film.add_light(sp.pixel, sp.value); })
                                         : nullptr,
                                     rays);
            run_samples(a, b);
        }
    };

    // The image as it stands after `spp` samples per pixel (the final one, or a progressive snapshot).
    auto make_image = [&](int spp, double seconds) {
        Image img;
        add_film_layers(img, film, opt.variance_layer, opt.samples_layer);
        img.metadata["iris:spp"] = std::to_string(spp);
        if (part) {
            add_film_parts(img, film);
            img.metadata["iris:sample_range"] = std::to_string(opt.sample_begin) + ":" + std::to_string(opt.sample_end);
            img.metadata["iris:spp_total"] = std::to_string(target_spp);
            img.metadata["iris:light_paths_per_sample"] = std::to_string(light_paths_per_sample);
            img.metadata["iris:variance_layer"] = opt.variance_layer ? "1" : "0";
            img.metadata["iris:samples_layer"] = opt.samples_layer ? "1" : "0";
            // Everything that changes a sample (the range aside): parts merge only where these agree.
            char buf[512];
            std::snprintf(buf, sizeof buf,
                          "resolution %dx%d; seed %llu; mode %s; max_depth %d; rr_depth %d; rr_threshold %.9g; "
                          "guide_vertices %d; guided %d; light paths per sample %llu; connections %d %.9g; sampler %d; filter %d %.9g %.9g; spp %d",
                          width, height, (unsigned long long)opt.seed, guide_mode_name(ps.mode), ps.max_depth,
                          ps.rr_depth, double(ps.rr_threshold), ps.guide_vertices, ps.guide ? 1 : 0,
                          (unsigned long long)light_paths_per_sample, ps.connect ? 1 : 0, double(ps.paths_per_vertex),
                          int(opt.sampler), int(scene.film.filter),
                          double(scene.film.filter_radius), double(scene.film.filter_stddev), target_spp);
            img.metadata["iris:settings"] = std::string(buf) + (opt.settings_extra.empty() ? "" : "; " + opt.settings_extra);
        }
        img.metadata["iris:seconds"] = std::to_string(seconds);
        img.metadata["iris:seed"] = std::to_string(opt.seed);
        img.metadata["iris:max_depth"] = std::to_string(ps.max_depth);
        img.metadata["iris:nonfinite_samples"] = std::to_string(nonfinite.load());
        img.metadata["iris:rays"] = std::to_string(rays.load());
        img.metadata["iris:cache_lookups"] = std::to_string(lookups.load());
        img.metadata["iris:scene"] = scene.source;
        img.metadata["iris:scene_fingerprint"] = scene.fingerprint;
        img.metadata["iris:command_line"] = opt.command_line;
        img.metadata["iris:version"] = IRIS_VERSION;
        img.metadata["iris:tool"] = "render";
        img.metadata["iris:mode"] = guide_mode_name(ps.mode);
        img.metadata["iris:sampler"] = sobol ? "sobol" : "independent";
        if (weigh_guiding || weigh_light) img.metadata["iris:auto_guide"] = describe(decision);
        else if (opt.auto_guide)  // (without a guide: the atlas had no cache that guides; no pilot ran)
            img.metadata["iris:auto_guide"] = "unguided: no cache in the atlas guides";
        if (ps.guide) img.metadata["iris:guiding"] = describe(ps);
        if (path_samples) img.metadata["iris:hybrid_caches"] = describe(last_refit, refits, refit_seconds);
        img.metadata["iris:light_paths"] = std::to_string(uint64_t(spp) * light_paths_per_sample);
        if (opt.caustics != RenderOptions::Caustics::Off)
            img.metadata["iris:caustics"] = light_paths_per_sample > 0 ? "light-traced, " + std::to_string(light_paths_per_sample) +
                                                                             " light paths per sample pass"
                                                                       : "not light-traced";
        return img;
    };

    // Passes: one for a fixed spp without snapshots (best load balance). Otherwise passes grow
    // geometrically while the cost per sample is learnt, then are sized so that a pass takes at most
    // ~1/8 of the time budget (so a timed render ends close to its budget) and at most about half the
    // snapshot interval (so snapshots come on time). Samples are seeded per (pixel, index), so how the
    // passes are cut does not change the image.
    const bool snapshots = opt.snapshot_interval > 0 && opt.snapshot;
    int spp = 0;
    double last_snapshot = 0;
    int pass = 1;
    if (part) {
        // One pass of this part's samples, seeded by their indices as in a single run.
        run_pass(opt.sample_begin, opt.sample_end);
        spp = opt.sample_end - opt.sample_begin;
    }
    while (!part && spp < target_spp) {
        int n = (timed || snapshots) ? std::min(pass, target_spp - spp) : target_spp - spp;
        // Learning: a pass ends where the maps are refit, so that which maps a sample sees depends on its
        // index only, not on how the time budget cut the passes.
        if (path_samples) n = std::min(n, next_refit - spp);
        run_pass(spp, spp + n);
        spp += n;
        // (Not after the last pass: no sample would see that refit.)
        if (path_samples && spp == next_refit && spp < target_spp) {
            const double t0 = elapsed();
            last_refit = opt.learn->refit(*path_samples);
            refit_seconds += elapsed() - t0;
            ++refits;
            next_refit = next_refit < (1 << 29) ? 2 * next_refit : 1 << 30;
        }
        const double t = elapsed();
        progress.advance(0);
        if (spp >= target_spp) break;
        const double per_spp = t / spp;
        double horizon = 1e300;  // the longest a pass should take, seconds
        if (timed) {
            const double remaining = opt.time - t;
            if (remaining < per_spp * 0.5) break;  // another sample would overshoot more than it helps
            horizon = std::min(remaining, opt.time / 8);
        }
        if (snapshots) {
            if (t - last_snapshot >= opt.snapshot_interval) {
                opt.snapshot(make_image(spp, t));
                last_snapshot = elapsed();
            }
            horizon = std::min(horizon, opt.snapshot_interval / 2);
        }
        pass = std::max(1, std::min(int(std::min(horizon / per_spp, 1e9)), pass * 2));
    }
    const double seconds = elapsed();
    progress.finish(std::to_string(spp) + " spp" +
                    (nonfinite ? ", " + std::to_string(nonfinite.load()) + " NaN/Inf samples discarded" : ""));
    Image img = make_image(spp, seconds);
    if (stats) {
        stats->decision = decision;
        stats->decided = weigh_guiding || weigh_light;
        stats->spp = spp;
        stats->seconds = seconds;
        stats->paths = uint64_t(spp) * uint64_t(width) * uint64_t(height);
        stats->rays = rays.load();
        stats->nonfinite = nonfinite.load();
        stats->light_paths = uint64_t(spp) * light_paths_per_sample;
        stats->threads = threads;
        stats->refits = refits;
        stats->refit_seconds = refit_seconds;
        stats->last_refit = last_refit;
    }
    return img;
}

}  // namespace iris
