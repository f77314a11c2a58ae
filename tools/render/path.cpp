#include "tools/render/path.h"

#include <algorithm>
#include <cmath>

#include "libcommon/mutation.h"
#include "libcommon/rng.h"
#include "libcommon/sampling.h"
#include "tools/render/connections.h"

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
        // Phong's exponent n is as wide as Beckmann alpha = sqrt(2 / (n + 2)) (Mitsuba's getRoughness):
        // alpha >= 0.2 <=> n <= 48.
        case BsdfType::Phong: return !is_black(b.diffuse) || b.alpha_u <= 48.0f;
        case BsdfType::Mixture:  // where some part may be guided (the others keep their own sampling)
            for (int i = 0; i < b.part_count; ++i)
                if (b.part_weight[i] > 0 && guidable(*b.part[i])) return true;
            return false;
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

// Caustic connections: the path's last non-Dirac vertex y, where the connection strategy could also have
// made the path so far (y reached from a non-Dirac vertex x, left on the side x is on), and the
// quantities of connections.h's density ratio.
struct LastJoinable {
    bool joinable = false;
    float p_x = 0, p_y = 0, cos_x = 0, cos_chain = 0, dist2 = 0;
};

// Hybrid caches: a vertex a cache served, with what it needs to turn the radiance the path gathers after
// it into the radiance its continuation received: L before the continuation's contributions, the
// throughput after the vertex (luminance), and cos(theta_c) / p of the continuation direction (its texel
// in the cache's map).
struct Recorded {
    int cache, texel;
    float cos_over_pdf, beta_after;
    RGB L_before;
};

// What trace_path works out at one vertex, step by step (the steps below, in this order).
struct Vertex {
    int depth = 0;
    Vec3 wi_world, wi, ref;  // towards where the path came from (world, local); NEE's reference point
    const Bsdf* bsdf = nullptr;
    bool delta_only = false, guided_here = false;
    Guide::Probe probe;                // a guided vertex's grid slot, loading
    const LightVertex* join = nullptr; // the light vertex a connection joins, loading
    // Random numbers, in a fixed order: the continuation's, then the light's.
    float uc = 0;
    Vec2 u;
    LightSample ls;
    bool light_found = false;  // NEE only where the BSDF has a non-delta part
    // The cache serving this vertex, and the one-sample mixture of BSDF and cache sampling (DESIGN
    // 4.3). The cache replaces only the lobes bsdf_guidable_share/pdf name (a layered BSDF keeps its
    // coat: a map cannot resolve a glossy highlight): of those, the share alpha stays with the BSDF.
    //   p_mix = p_bsdf + (1 - alpha) (g p_cache - q),  g = guidable share, q = those lobes' density,
    // i.e. the coat as the BSDF samples it, plus g (alpha p_lobes + (1 - alpha) p_cache).
    int cache = -1;
    float alpha = 1.0f, g = 0.0f;
    float sharpness = 0.0f;  // > 0: the cache guides a glossy lobe, by its product with the map
    Vec3 wo_light;           // NEE's direction (local) and BSDF value
    RGB f_light{0.0f};
    Guide::Product product;  // where the lobe the cache replaces is glossy (use_product)
    bool use_product = false, use_cache = false;
    Guide::Texel nee_texel{}, bsdf_texel{};
    int sample_row = 0;  // the row of the cache's map that the cache technique samples
    BsdfSample bs_guided;  // the BSDF technique's sample where a cache guides (drawn early)
    bool bs_guided_ok = false;
    Vec3 bs_guided_world;
    bool nee_density = false, nee_density_early = false;
};

// The state of one camera path and the steps of one vertex.
struct Walk {
    const Scene& scene;
    const PathSettings& ps;
    Rng& rng;
    PathCounters& counters;
    RGB* caustic;
    PathSamples* samples;
    const ConnectionPool* pool;
    const Guide* guide;
    bool use_nee;
    RGB L{0.0f}, beta{1.0f};
    Ray ray;
    float prev_pdf = 0;      // density of the technique mix that created `ray` (per steradian)
    bool prev_delta = true;  // camera rays and delta bounces: emitters hit are counted fully
    Vec3 prev_p;
    float eta_scale = 1.0f;  // product of relative IORs^2 crossed, for Russian roulette (Mitsuba)
    SurfaceHit hit;
    BsdfScratch bsdf_at_hit;        // textured BSDFs evaluated at the current vertex (scene_bsdf_at)
    int guided_vertices = 0; // vertices at which a cache was looked up so far
    bool caustic_chain = false;  // so far: a non-Dirac event at the first vertex, Dirac ones after it
    LastJoinable last_y;
    Vec3 prev_hit_p;         // the previous vertex (the camera's position for the first)
    // The pixel's stratified numbers (if any) serve the first vertex that samples a non-Dirac lobe: behind
    // a mirror or glass seen by the camera, that is the vertex whose direction decides the pixel's noise.
    const FirstVertexSamples* stratified_numbers;
    PathSamples::Writer writer;
    static constexpr int kMaxRecorded = 16;
    Recorded recorded[kMaxRecorded];
    int n_recorded = 0;

    Walk(const Scene& s, const Ray& camera_ray, Rng& r, const PathSettings& settings, PathCounters& c, RGB* caus,
         PathSamples* smp, const ConnectionPool* pl, const FirstVertexSamples* first)
        : scene(s), ps(settings), rng(r), counters(c), caustic(caus), samples(smp), pool(pl), guide(settings.guide),
          use_nee(settings.mode != GuideMode::BsdfCache), ray(camera_ray), prev_p(camera_ray.o),
          prev_hit_p(camera_ray.o), stratified_numbers(first),
          writer(smp ? smp->writer() : PathSamples::Writer{}) {}

    // Hybrid caches: vertex served by cache c, continuing in wo_world (texel: its index in c's map,
    // Guide::texel_index) with density p.
    void record(int c, int texel, Vec3 wo_world, float p) {
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
    }
    // What each recorded vertex's continuation received: the radiance gathered after it, over the
    // throughput it had then (roulette's 1/q included: an unbiased estimate of L_i along it).
    void finish_records() {
        for (int r = 0; r < n_recorded; ++r) {
            const Recorded& v = recorded[r];
            const float li = luminance(L - v.L_before) / v.beta_after;
            writer.add(v.cache, v.texel, li * v.cos_over_pdf);
        }
    }
    // Emission le that the path reached at its depth-th vertex from light `light_index` (p, n, prim: the
    // point, normal and triangle on an emitter; zero for the environment). Paths do not end at lights (an
    // emitter may also reflect, DESIGN 4.8).
    void add_emission(RGB le, int depth, int light_index, Vec3 p, Vec3 n, uint32_t prim) {
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
            if (IRIS_MUTANT(connection_weight_one) && prev_delta && ps.connect && last_y.joinable) w = 1.f;
            L += beta * le * w;
        }
    }

    // The density of the cache technique for texel t (the product's where the cache guides a glossy lobe).
    float cache_pdf(const Vertex& v, Guide::Texel t) const {
        return v.use_product ? guide->product_pdf(v.product, t) : guide->texel_pdf(v.cache, t);
    }
    // The mixture's density for direction wo (local) from its BSDF and cache parts. Where the whole BSDF
    // is replaceable (g = 1) q is p_bsdf itself (bsdf.h's contract): no second evaluation of the BSDF's
    // density.
    float mix_from(const Vertex& v, Vec3 wo, float p_bsdf, float p_cache) const {
        const float q = v.g < 1 ? bsdf_guidable_pdf(*v.bsdf, v.wi, wo) : p_bsdf;
        return std::max(0.0f, p_bsdf + (1 - v.alpha) * (v.g * p_cache - q));
    }

    void begin_vertex(Vertex& v);
    void draw_numbers(Vertex& v);
    void look_up_cache(Vertex& v);
    void start_loads(Vertex& v);
    void next_event(Vertex& v);
    void connect(const Vertex& v);
    bool continue_path(Vertex& v, Vec3* wo_world);
    bool after_continuation(const Vertex& v, Vec3 wo_world, bool in_delta, float in_pdf);
};

// The vertex's BSDF and whether a cache may guide it. A guided vertex's first load, its grid slot,
// starts here (its emission and light sample run meanwhile); so does the light vertex a connection joins
// (the pool is larger than the CPU's caches).
void Walk::begin_vertex(Vertex& v) {
    v.wi_world = -ray.d;
    v.bsdf = &scene_bsdf_at(scene, hit, &bsdf_at_hit);
    v.delta_only = bsdf_is_delta(*v.bsdf);
    v.guided_here = guide && !v.delta_only && guided_vertices < ps.guide_vertices && guidable(*v.bsdf);
    if (v.guided_here) v.probe = guide->probe(hit.p);
    if (pool && pool->count > 0 && !v.delta_only) {
        v.join = pool->vertices + std::min(pool->count - 1, uint32_t(rng.next_float() * float(pool->count)));
        for (size_t b = 0; b < sizeof(LightVertex); b += 64) __builtin_prefetch(reinterpret_cast<const char*>(v.join) + b);
    }
}

// Random numbers in a fixed order: the continuation's, then the light's (at the first non-Dirac vertex
// the 2D numbers may come from the pixel's stratified sequences); the light sample.
void Walk::draw_numbers(Vertex& v) {
    const FirstVertexSamples* strat = v.delta_only ? nullptr : stratified_numbers;
    if (strat) stratified_numbers = nullptr;
    const bool stratified = strat != nullptr;
    v.uc = rng.next_float();
    v.u = stratified ? strat->u_continue : Vec2{rng.next_float(), rng.next_float()};
    if (use_nee && !v.delta_only) {
        const float u_sel = rng.next_float();
        const Vec2 u_light = stratified ? strat->u_light : Vec2{rng.next_float(), rng.next_float()};
        v.light_found = sample_light(scene, v.ref, u_sel, u_light, &v.ls) && v.ls.pdf > 0 && !is_black(v.ls.radiance);
    }
}

// The cache serving a guided vertex and its mixture (Vertex::cache); NEE's BSDF value meanwhile.
void Walk::look_up_cache(Vertex& v) {
    if (v.guided_here) {
        ++guided_vertices;
        ++counters.lookups;
        Vec3 n_side = dot(hit.ng, v.wi_world) >= 0 ? hit.ng : -hit.ng;
        v.cache = guide->lookup(v.probe, n_side);
        v.sharpness = v.cache >= 0 ? glossy_lobe_sharpness(*v.bsdf) : 0.0f;
        if (v.sharpness > 0) guide->prefetch_product(v.cache);
    }
    // NEE's BSDF value (the rest of NEE follows once the cache's rows are loading).
    if (v.light_found) {
        v.wo_light = hit.frame.to_local(v.ls.wi);
        if (consistent_side(v.ls.wi, hit.ng, v.wo_light.z)) v.f_light = bsdf_eval(*v.bsdf, v.wi, v.wo_light, IRIS_MUTANT(nee_importance_mode) ? TransportMode::Importance : TransportMode::Radiance);
    }
    if (v.cache >= 0) {
        v.alpha = ps.mode == GuideMode::NeeCache ? 0.0f : guide->bsdf_fraction(v.cache);
        v.g = bsdf_guidable_share(*v.bsdf, v.wi);
    }
    // Where the lobe the cache replaces is glossy, the cache technique samples the map's product with it
    // (Guide::product); every density of the cache technique is then the product's.
    v.use_product =
        v.sharpness > 0 && guide->product(v.cache, mirror_direction(v.wi_world, hit.frame.n), v.sharpness, &v.product);
    const float k_cache = (1 - v.alpha) * v.g;  // probability of the cache technique (0 unguided)
    v.use_cache = v.cache >= 0 && v.uc >= 1 - k_cache;
}

// A guided vertex's loads are spread over its work (deep vertices land anywhere in the scene, so p's grid
// slot and the cache's map are rarely in the CPU's caches): the slot starts loading after the
// intersection and is read after light sampling; the lookup starts loading the cache's header and row
// ends, read after NEE's BSDF evaluation; here the rows of the map the vertex will read start loading,
// so that they arrive during NEE's shadow ray: the light direction's, and the continuation's (the row the
// cache sample searches, or the BSDF sample's: the BSDF technique draws its sample now, from random
// numbers already drawn, so nothing else changes).
void Walk::start_loads(Vertex& v) {
    // The light direction's texel only where light samples here are mostly unoccluded (per tile so far):
    // after an occluded shadow ray its density is never read (a light inside glass, as on the egg: 84 %
    // occluded), and computing and loading it there is wasted. Either way the density is the same, so the
    // image does not depend on this choice.
    v.nee_density = v.cache >= 0 && !is_black(v.f_light) && !v.ls.delta;
    v.nee_density_early = v.nee_density && counters.mostly_unoccluded();
    if (v.cache < 0) return;
    if (v.nee_density_early) {
        v.nee_texel = guide->texel(v.cache, v.ls.wi);
        guide->prefetch_texel(v.cache, v.nee_texel);
    }
    if (v.use_cache) {
        if (v.use_product) guide->product_block(&v.product, v.u.x);
        else v.sample_row = guide->sample_row(v.cache, v.u);
        return;
    }
    // uc is remapped to stay uniform for the BSDF's own lobe choice: below 1 - g (the coat) as it is, the
    // rest of [1 - g, 1 - k_cache) stretched onto [1 - g, 1).
    const float keep = 1 - v.g;
    const float uc_bsdf = v.uc < keep ? v.uc : std::min(keep + (v.uc - keep) / v.alpha, 0x1.fffffep-1f);
    v.bs_guided_ok = bsdf_sample(*v.bsdf, v.wi, v.u, uc_bsdf, &v.bs_guided);
    if (v.bs_guided_ok) v.bs_guided_world = hit.frame.to_world(v.bs_guided.wo);
    if (v.bs_guided_ok && !v.bs_guided.delta) {
        v.bsdf_texel = guide->texel(v.cache, v.bs_guided_world);
        guide->prefetch_texel(v.cache, v.bsdf_texel);
    }
}

// Next-event estimation, MIS-weighted against the continuation's full mixture density.
void Walk::next_event(Vertex& v) {
    if (is_black(v.f_light)) return;
    const LightSample& ls = v.ls;
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
    if (v.nee_density) {
        ++counters.guided_shadow_tests;
        counters.guided_unoccluded += blocked ? 0 : 1;
    }
    if (blocked) return;
    float w = 1.0f;
    if (v.nee_density && !v.nee_density_early) v.nee_texel = guide->texel(v.cache, ls.wi);
    if (!ls.delta) {
        const float p_bsdf = bsdf_pdf(*v.bsdf, v.wi, v.wo_light);
        const float p_mix = v.cache < 0 ? p_bsdf : mix_from(v, v.wo_light, p_bsdf, cache_pdf(v, v.nee_texel));
        w = power_heuristic(ls.pdf, p_mix);
        if (IRIS_MUTANT(mis_weight_one)) w = 1.f;
    }
    L += beta * v.f_light * ls.radiance * (w / ls.pdf);
}

// Caustic connection (connections.h): join the light vertex y chosen in begin_vertex, where the whole
// path fits in the depth limit. Added before the continuation, so that hybrid caches do not count it as
// light the continuation received.
void Walk::connect(const Vertex& x) {
    const LightVertex& v = *x.join;
    const Vec3 d = v.hit.p - hit.p;
    const float dist2 = dot(d, d);
    const Vec3 w = d / std::sqrt(dist2);
    const Vec3 wo_x = hit.frame.to_local(w);
    const float cos_y_x = -dot(w, v.hit.ng), cos_y_chain = dot(v.w_light, v.hit.ng);
    if (!((ps.max_depth < 0 || x.depth + 1 + v.depth <= ps.max_depth) && dist2 > 0 &&
          consistent_side(w, hit.ng, wo_x.z) && cos_y_x * cos_y_chain > 0))
        return;
    const RGB f_x = bsdf_eval(*x.bsdf, x.wi, wo_x);
    BsdfScratch bsdf_y_at;
    const Bsdf& bsdf_y = scene_bsdf_at(scene, v.hit, &bsdf_y_at);
    const Vec3 wi_y = v.hit.frame.to_local(-w), wo_y = v.hit.frame.to_local(v.w_light);
    const RGB f_y = wi_y.z != 0 ? bsdf_eval(bsdf_y, wi_y, wo_y) : RGB(0.0f);
    if (is_black(f_x) || is_black(f_y)) return;
    ++counters.rays;
    if (scene.occluded(offset_ray_origin(hit.p, hit.ng, w, hit.magnitude),
                       offset_ray_origin(v.hit.p, v.hit.ng, -w, v.hit.magnitude)))
        return;
    // The path tracer's densities of x -> y and of y -> the chain.
    const float pb_x = bsdf_pdf(*x.bsdf, x.wi, wo_x);
    const float p_x = x.cache < 0 ? pb_x : mix_from(x, wo_x, pb_x, cache_pdf(x, guide->texel(x.cache, w)));
    const bool y_guided = guide && v.cache >= 0 && guided_vertices < ps.guide_vertices && guidable(bsdf_y);
    const float p_y = y_guided ? guided_density(*guide, v.cache, ps.mode, bsdf_y, wi_y, wo_y, -w, v.w_light, v.hit.frame.n)
                               : bsdf_pdf(bsdf_y, wi_y, wo_y);
    const float w_connect = 1 - connection_path_weight(ps.paths_per_vertex, v.emit_density, std::abs(cos_y_chain),
                                                       std::abs(cos_y_x), dist2, p_x, p_y);
    L += beta * f_x * f_y * v.beta * (w_connect * std::abs(cos_y_x) / (dist2 * std::abs(cos_y_chain)) * pool->weight);
}

// Continue the path: BSDF sampling, or (guided) a one-sample choice between BSDF and cache. Returns
// false where the path ends; else the new direction is *wo_world and beta and the densities are updated.
bool Walk::continue_path(Vertex& v, Vec3* wo_world) {
    const Bsdf& bsdf = *v.bsdf;
    if (v.cache < 0) {
        BsdfSample bs;
        if (!bsdf_sample(bsdf, v.wi, v.u, v.uc, &bs)) return false;
        *wo_world = hit.frame.to_world(bs.wo);
        if (!consistent_side(*wo_world, hit.ng, bs.wo.z)) return false;
        beta *= bs.weight;
        eta_scale *= bs.eta * bs.eta;
        prev_pdf = bs.pdf;
        prev_delta = bs.delta;
    } else if (!v.use_cache) {
        // BSDF technique (its sample drawn in start_loads).
        if (!v.bs_guided_ok) return false;
        const BsdfSample& bs = v.bs_guided;
        const Vec3 wo = bs.wo;
        *wo_world = v.bs_guided_world;
        if (!consistent_side(*wo_world, hit.ng, wo.z)) return false;
        eta_scale *= bs.eta * bs.eta;
        if (bs.delta) {
            // A Dirac coat comes only from the BSDF technique, with the BSDF's own probability.
            beta *= bs.weight;
            prev_pdf = bs.pdf;
            prev_delta = true;
        } else {
            const float p = mix_from(v, wo, bs.pdf, cache_pdf(v, v.bsdf_texel));
            if (!(p > 0)) return false;
            // f = weight * pdf of the BSDF's own sample (bsdf.h): no second evaluation of the BSDF.
            beta *= bs.weight * (bs.pdf / p);
            prev_pdf = p;
            prev_delta = false;
            if (samples) record(v.cache, guide->texel_index(v.bsdf_texel), *wo_world, p);
        }
    } else {
        float p_cache;
        int texel = 0;
        *wo_world = v.use_product ? guide->sample_product(v.product, v.u.y, &p_cache, samples ? &texel : nullptr)
                                  : guide->sample(v.cache, v.u, v.sample_row, &p_cache, samples ? &texel : nullptr);
        const Vec3 wo = hit.frame.to_local(*wo_world);
        if (!(p_cache > 0) || !consistent_side(*wo_world, hit.ng, wo.z)) return false;
        const float p = mix_from(v, wo, bsdf_pdf(bsdf, v.wi, wo), p_cache);
        RGB f = bsdf_eval(bsdf, v.wi, wo);
        if (is_black(f) || !(p > 0)) return false;
        beta *= f / p;
        prev_pdf = p;
        prev_delta = false;
        if (samples) record(v.cache, texel, *wo_world, p);
    }
    return true;
}

// After the continuation was sampled (in_delta, in_pdf: how the path reached this vertex): the
// connection strategy's bookkeeping, the next ray, and Russian roulette from rr_depth on
// (PathSettings::rr_threshold). Returns false where the path ends.
bool Walk::after_continuation(const Vertex& v, Vec3 wo_world, bool in_delta, float in_pdf) {
    if (is_black(beta)) return false;
    if (ps.connect && !prev_delta) {
        const float cos_x = dot(hit.ng, v.wi_world), cos_chain = dot(hit.ng, wo_world);
        const Vec3 d = hit.p - prev_hit_p;
        last_y = {v.depth >= 2 && !in_delta && cos_x * cos_chain > 0, in_pdf, prev_pdf, std::abs(cos_x),
                  std::abs(cos_chain), dot(d, d)};
    }
    prev_hit_p = hit.p;
    caustic_chain = v.depth == 1 ? !prev_delta : caustic_chain && prev_delta;
    prev_p = v.ref;
    ray = spawn_ray(hit, wo_world);
    if (v.depth >= ps.rr_depth) {
        // beta carries the 1/eta^2 radiance scaling of refractions; undo it for the decision only, so
        // paths inside glass are not killed for a change of units.
        float q = std::min(max_component(beta) * eta_scale / ps.rr_threshold, 0.95f);
        if (!(rng.next_float() < q)) return false;
        beta /= q;
    }
    return true;
}

}  // namespace

RGB trace_path(const Scene& scene, const Ray& camera_ray, Rng& rng, const PathSettings& ps, PathCounters& counters,
               RGB* caustic, PathSamples* samples, const ConnectionPool* pool, const FirstVertexSamples* first) {
    Walk p(scene, camera_ray, rng, ps, counters, caustic, samples, pool, first);
    for (int depth = 1;; ++depth) {
        ++counters.rays;
        if (!scene.intersect(p.ray, &p.hit)) {
            if (scene.environment_light >= 0) {
                const Light& env = scene.lights[scene.environment_light];
                p.add_emission(light_emitted(env, Vec3(0), -p.ray.d), depth, scene.environment_light, Vec3(0), Vec3(0), 0);
            }
            break;
        }
        Vertex v;
        v.depth = depth;
        p.begin_vertex(v);
        const SurfaceHit& hit = p.hit;
        if (hit.light >= 0) {
            const RGB le = light_emitted(scene.lights[hit.light], hit.ng, v.wi_world);
            if (!is_black(le)) p.add_emission(le, depth, hit.light, hit.p, hit.ng, hit.prim);
        }
        if (ps.max_depth >= 0 && depth >= ps.max_depth) break;
        v.wi = hit.frame.to_local(v.wi_world);
        if (v.wi.z == 0) break;
        // Light sampling and its MIS density are evaluated from a point moved off the surface to the side
        // the path is on: on the surface of a sphere light itself, "inside" (sees all of it) and "outside"
        // (sees none of it) would otherwise be decided by rounding.
        v.ref = offset_ray_origin(hit.p, hit.ng, v.wi_world, hit.magnitude);
        p.draw_numbers(v);
        p.look_up_cache(v);
        p.start_loads(v);
        p.next_event(v);
        if (v.join) p.connect(v);
        const bool in_delta = p.prev_delta;  // how the path reached this vertex (for last_y)
        const float in_pdf = p.prev_pdf;
        Vec3 wo_world;
        if (!p.continue_path(v, &wo_world)) break;
        if (!p.after_continuation(v, wo_world, in_delta, in_pdf)) break;
    }
    p.finish_records();
    return p.L;
}

}  // namespace iris
