// MIS weights of the guided path tracer sum to one (DESIGN.md 4.3). At a non-specular vertex with
// cache c and BSDF share alpha, a path that ends on an emitter can be made by two techniques:
//   NEE:           weight p_light^2 / (p_light^2 + p_mix^2)
//   continuation:  weight p_mix^2   / (p_mix^2 + p_light^2),
//   p_mix = p_bsdf + (1 - alpha)(g p_cache - q)   (g = bsdf_guidable_share, q = bsdf_guidable_pdf:
//   the cache replaces only the diffuse lobe of a layered BSDF; for one-lobe BSDFs g = 1, q = p_bsdf and
//   p_mix = alpha p_bsdf + (1 - alpha) p_cache),
// with alpha = 1 unguided (nee+bsdf, or no cache serves), alpha = 0 in nee+cache, the Guide's share in
// the mixture modes; bsdf+cache has no NEE and gives the continuation weight 1.
//
// The integrator (tools/render/path.cpp) computes these inline, so this test rebuilds them from
// the public pieces it uses -- sample_light / light_pdf, bsdf_sample / bsdf_pdf, Guide::sample /
// Guide::pdf -- the way the integrator combines them, and checks that for every path the two weights,
// each evaluated *where its technique evaluates it*, sum to one:
//   - for a direction made by NEE: the NEE weight uses the density sample_light reported, the
//     continuation weight the density light_pdf gives when the ray actually hits the light;
//   - for a direction made by the continuation: its weight uses the density reported while sampling
//     (from bs.pdf and guide.pdf, or from bsdf_pdf and the p_cache sampled), the NEE
//     weight the densities evaluated afresh (bsdf_pdf, Guide::pdf) for the direction.
// So each sum is one exactly when each technique's reported density equals the density the other side
// evaluates for the same direction: same frame, same cache, same selection probabilities.
// Vertices: random points on the surfaces of the caustic box, of the three-rooms scene (mesh, sphere
// and point lights), of the layered tiles box (plastic, rough plastic, Ward) and of the glossy tiles box
// (rough conductor, Ward without a diffuse part: the cache technique is the map's product with the lobe,
// Guide::product_block / sample_product and product_pdf), found by tracing
// towards photon positions, with random incident directions.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "formats/scene_xml.h"
#include "libcommon/bsdf.h"
#include "libcommon/lights.h"
#include "libcommon/rng.h"
#include "libcommon/sampling.h"
#include "libcommon/scene.h"
#include "support/run_tool.h"
#include "tools/fill-caches/cache_filler.h"
#include "tools/place-caches/cache_placer.h"
#include "libguide/guide.h"
#include "tools/render/integrator.h"
#include "tools/trace-photons/photon_tracer.h"

namespace iris {
namespace {

struct GuidedScene {
    Scene scene;
    PhotonMap photons;
    std::unique_ptr<Guide> guide;
};

// The scene, its photons and a guide built in-process the way the CLI pipeline builds them.
GuidedScene make_setup(const std::string& rel) {
    GuidedScene s;
    SceneLoadOptions lo;
    std::vector<std::string> warnings;
    lo.warnings = &warnings;
    s.scene = load_scene(test::data_file(rel), lo);
    PhotonOptions po;
    po.paths = 20000;
    po.seed = 9;
    po.quiet = true;
    s.photons = trace_photons(s.scene, po, nullptr);
    PlacementOptions pl;
    pl.count = 300;
    pl.quiet = true;
    CachePoints caches = place_caches(s.scene, s.photons, pl, nullptr);
    FillOptions fo;
    fo.k = 200;
    fo.min_photons = 16;
    fo.quiet = true;
    const double diagonal = length(s.scene.bounds_max - s.scene.bounds_min);
    s.guide = std::make_unique<Guide>(fill_caches(caches, s.photons, diagonal, fo, nullptr), 0.25f);
    return s;
}

const GuideMode kModes[] = {GuideMode::NeeBsdf, GuideMode::NeeCache, GuideMode::BsdfCache, GuideMode::NeeBsdfCache};

// A path vertex as the integrator sees it.
struct Vertex {
    SurfaceHit hit;
    Vec3 wi_world, wi, ref;
};

// The emitter a ray from the vertex in direction d reaches first, if any (with its hit record).
bool hits_emitter(const Scene& scene, const Vertex& v, Vec3 d, SurfaceHit* lh) {
    Ray r;
    r.o = offset_ray_origin(v.hit.p, v.hit.ng, d);
    r.d = d;
    if (!scene.intersect(r, lh) || lh->light < 0) return false;
    return !is_black(light_emitted(scene.lights[size_t(lh->light)], lh->ng, -d));
}

struct Tally {
    long long layered_vertices = 0;  // guided vertices on a BSDF whose coat the cache leaves alone
    long long product_vertices = 0;  // guided vertices on a glossy lobe: the cache technique is the product
    long long nee_paths = 0, hit_paths = 0, bad = 0;
    double worst = 0;
    void check(double sum, const char* what, GuideMode m) {
        // Densities are floats: sums of two weights computed from them are 1 to ~1e-6. The sampled and
        // the evaluated cache density may legitimately differ for a direction within float rounding of
        // a texel edge (see Guide::sample), a ~1e-6 fraction of samples: counted, and bounded below.
        const double err = std::abs(sum - 1.0);
        worst = std::max(worst, err);
        if (err > 1e-4) {
            ++bad;
            if (bad <= 5) ADD_FAILURE() << what << " in mode " << guide_mode_name(m) << ": weights sum to " << sum;
        }
    }
};

void check_scene(const GuidedScene& s, int vertices, int samples_per_vertex, Tally* tally) {
    const Scene& scene = s.scene;
    const Guide& guide = *s.guide;
    Rng rng(1234, 5);
    long long guided_vertices = 0;
    for (int vi = 0; vi < vertices; ++vi) {
        // A surface point: trace towards a random photon from just in front of it.
        const size_t pi = rng.next_u32() % s.photons.size();
        const Vec3 n = s.photons.normal[pi];
        Ray probe;
        probe.o = s.photons.position[pi] + n * (1e-3f * std::max(1.0f, scene.scale()));
        probe.d = -n;
        Vertex v;
        if (!scene.intersect(probe, &v.hit)) continue;
        const Bsdf& bsdf = scene.bsdfs[v.hit.bsdf];
        if (bsdf_is_delta(bsdf)) continue;
        // Incident direction: cosine-distributed on the photon's (lit) side.
        v.wi_world = Frame(n).to_world(sample_cosine_hemisphere({rng.next_float(), rng.next_float()}));
        v.wi = v.hit.frame.to_local(v.wi_world);
        if (v.wi.z == 0) continue;
        v.ref = offset_ray_origin(v.hit.p, v.hit.ng, v.wi_world);
        const Vec3 n_side = dot(v.hit.ng, v.wi_world) >= 0 ? v.hit.ng : -v.hit.ng;
        const int lookup = guide.lookup(v.hit.p, n_side);
        guided_vertices += lookup >= 0;
        tally->layered_vertices += lookup >= 0 && bsdf_guidable_share(bsdf, v.wi) < 1;

        for (GuideMode mode : kModes) {
            const bool use_nee = mode != GuideMode::BsdfCache;
            const int cache = mode == GuideMode::NeeBsdf ? -1 : lookup;
            const float alpha = cache < 0 ? 1.0f : mode == GuideMode::NeeCache ? 0.0f : guide.bsdf_fraction(cache);
            const float g = cache < 0 ? 0.0f : bsdf_guidable_share(bsdf, v.wi), keep = 1 - g;
            // On a glossy lobe the cache technique samples the map's product with it (as the integrator).
            const float sharpness = cache < 0 ? 0.0f : glossy_lobe_sharpness(bsdf);
            Guide::Product product;
            const bool use_product =
                sharpness > 0 && guide.product(cache, mirror_direction(v.wi_world, v.hit.frame.n), sharpness, &product);
            tally->product_vertices += use_product;
            auto cache_pdf = [&](Vec3 d) {
                return use_product ? guide.product_pdf(product, guide.texel(cache, d)) : guide.pdf(cache, d);
            };
            auto mix = [&](Vec3 d, float pb, float pc) {
                return std::max(0.0f, pb + (1 - alpha) * (g * pc - bsdf_guidable_pdf(bsdf, v.wi, v.hit.frame.to_local(d))));
            };
            // The density with which the continuation produces direction d, evaluated afresh.
            auto p_mix_eval = [&](Vec3 d) {
                const float pb = bsdf_pdf(bsdf, v.wi, v.hit.frame.to_local(d));
                return cache < 0 ? pb : mix(d, pb, cache_pdf(d));
            };
            for (int si = 0; si < samples_per_vertex; ++si) {
                // Technique 1: NEE.
                if (use_nee) {
                    LightSample ls;
                    const float u_sel = rng.next_float();
                    const Vec2 u{rng.next_float(), rng.next_float()};
                    SurfaceHit lh;
                    if (sample_light(scene, v.ref, u_sel, u, &ls) && ls.pdf > 0 && !ls.delta &&
                        hits_emitter(scene, v, ls.wi, &lh) && uint32_t(lh.light) == ls.light &&
                        length(lh.p - ls.p) < 1e-3f * std::max(1.0f, scene.scale())) {
                        const float pm = p_mix_eval(ls.wi);
                        if (pm > 0) {
                            ++tally->nee_paths;
                            const float w_nee = power_heuristic(ls.pdf, pm);
                            const float w_hit =
                                power_heuristic(pm, light_pdf(scene, uint32_t(lh.light), lh.prim, v.ref, lh.p, lh.ng, ls.wi));
                            tally->check(double(w_nee) + double(w_hit), "NEE-sampled path", mode);
                        }
                    }
                }
                // Technique 2: the continuation, as the integrator samples it.
                const float uc = rng.next_float();
                const Vec2 u{rng.next_float(), rng.next_float()};
                Vec3 d;
                float p_sampled = 0;
                if (cache < 0 || uc < 1 - (1 - alpha) * g) {
                    const float uc_bsdf = cache < 0 || uc < keep ? uc : std::min(keep + (uc - keep) / alpha, 0x1.fffffep-1f);
                    BsdfSample bs;
                    if (!bsdf_sample(bsdf, v.wi, u, uc_bsdf, &bs) || bs.delta) continue;
                    d = v.hit.frame.to_world(bs.wo);
                    p_sampled = cache < 0 ? bs.pdf : mix(d, bs.pdf, cache_pdf(d));
                } else {
                    float p_cache = 0;
                    if (use_product) {
                        guide.product_block(&product, u.x);
                        d = guide.sample_product(product, u.y, &p_cache);
                    } else {
                        d = guide.sample(cache, u, &p_cache);
                    }
                    p_sampled = mix(d, bsdf_pdf(bsdf, v.wi, v.hit.frame.to_local(d)), p_cache);
                }
                SurfaceHit lh;
                if (!(p_sampled > 0) || !hits_emitter(scene, v, d, &lh)) continue;
                ++tally->hit_paths;
                const float pl = light_pdf(scene, uint32_t(lh.light), lh.prim, v.ref, lh.p, lh.ng, d);
                const float w_hit = use_nee ? power_heuristic(p_sampled, pl) : 1.0f;
                const float w_nee = use_nee ? power_heuristic(pl, p_mix_eval(d)) : 0.0f;
                tally->check(double(w_hit) + double(w_nee), "continuation-sampled path", mode);
            }
        }
    }
    std::printf("vertices with a cache %lld of %d; NEE paths %lld, hit paths %lld, bad %lld, worst %.3g\n",
                guided_vertices, vertices, tally->nee_paths, tally->hit_paths, tally->bad, tally->worst);
    // The test must exercise guided vertices, not only the BSDF fallback.
    EXPECT_GT(guided_vertices, vertices / 4) << "too few vertices with a cache";
}

// Enough paths of each kind that a mismatch in any mode would show (measured: 2.9e5 NEE-sampled and
// 3300 continuation-sampled paths that reach the light in the caustic box; 1e5 and 5900 in the three
// rooms), and at most one path in 10^4 within rounding of a texel edge (expected: ~1 in 10^6).
void expect_sums_of_one(const Tally& t) {
    EXPECT_GT(t.nee_paths, 40000);
    EXPECT_GT(t.hit_paths, 3000);
    EXPECT_LE(t.bad, (t.nee_paths + t.hit_paths) / 10000) << "worst |sum - 1| = " << t.worst;
}

TEST(GuidingMis, WeightsSumToOneInTheCausticBox) {
    GuidedScene s = make_setup("guiding/caustic_box.xml");
    Tally t;
    check_scene(s, 3000, 40, &t);
    expect_sums_of_one(t);
}

TEST(GuidingMis, WeightsSumToOneWithSphereAndPointLights) {
    GuidedScene s = make_setup("guiding/three_rooms.xml");
    Tally t;
    check_scene(s, 3000, 40, &t);
    expect_sums_of_one(t);
}

TEST(GuidingMis, WeightsSumToOneOnLayeredBsdfs) {
    GuidedScene s = make_setup("guiding/layered_tiles_box.xml");
    Tally t;
    check_scene(s, 3000, 48, &t);
    EXPECT_GT(t.layered_vertices, 150) << "too few guided vertices on the plastic, rough plastic and Ward tiles";
    expect_sums_of_one(t);
}

// Glossy metal tiles (a rough conductor, a Ward without a diffuse part): there the cache technique is
// the map's product with the lobe (Guide::product), whose density every MIS weight must then use.
TEST(GuidingMis, WeightsSumToOneWithTheProductOnGlossyLobes) {
    GuidedScene s = make_setup("guiding/glossy_tiles_box.xml");
    Tally t;
    check_scene(s, 3000, 48, &t);
    EXPECT_GT(t.product_vertices, 150) << "too few guided vertices on the glossy tiles";
    expect_sums_of_one(t);
}

}  // namespace
}  // namespace iris
