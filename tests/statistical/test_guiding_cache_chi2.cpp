// The cache sampler as the renderer uses it: atlases built by fill_caches (tools/fill-caches) from
// photons, wrapped in a Guide (libguide/guide.h), sampled and evaluated in *world* directions.
// DESIGN.md 4.1 (exact PDFs) and 4.2 (one frame, one cache): Guide::sample must produce directions
// with exactly the density Guide::pdf reports, through the cache's own frame. Per cache:
//   1. cheap exact checks first (STYLE.md habit 7): the stored row sums to one (sum pdf 4 pi / N = 1),
//      its cdf ends at 1, the density is finite and at least floor / (4 pi) everywhere;
//   2. the world-space density integrates to one over the sphere by quadrature (independent of the
//      equal-area claim that makes the row sum equal the integral);
//   3. the density reported with each sample equals Guide::pdf of the returned direction;
//   4. chi-square of world-direction histograms (tests/support/chi2.h, cos theta x phi cells of the
//      world sphere, whose edges cut the tilted texels anywhere) against Guide::pdf;
//   5. chi-square of the texel each world sample falls in (re-derived through the frame) against the
//      texel probabilities of the guide's packed map (libguide/packed_map.h): exact expectations, no
//      quadrature.
// Caches come from two sources: photons made here by hand (clustered directions, caches with tilted
// and downward normals, two map settings) and the photons of the tiny caustic scene. All chi-square
// tests in this file are Sidak-corrected together (kTests).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "formats/scene_xml.h"
#include "libcommon/rng.h"
#include "libcommon/sampling.h"
#include "libcommon/spheremap.h"
#include "support/chi2.h"
#include "support/run_tool.h"
#include "tools/fill-caches/cache_filler.h"
#include "tools/place-caches/cache_placer.h"
#include "libguide/guide.h"
#include "tools/trace-photons/photon_tracer.h"

namespace iris {
namespace {

// Every chi-square test below: 4 hand-made caches x 2 atlases + 3 scene caches, 2 tests each.
constexpr int kTests = 2 * (4 * 2 + 3);
constexpr double kSignificance = 0.01;  // family-wise, Sidak-corrected over kTests

// Direction within a cone of half-angle `spread` (radians) around `axis`, uniform in solid angle.
Vec3 cone_direction(Rng& rng, Vec3 axis, float spread) {
    const float cos_max = std::cos(spread);
    const float z = 1 - rng.next_float() * (1 - cos_max), phi = 2 * kPi * rng.next_float();
    const float r = std::sqrt(std::max(0.0f, 1 - z * z));
    return normalize(Frame(axis).to_world({r * std::cos(phi), r * std::sin(phi), z}));
}

// Photons on a small disc around each cache, all on the cache's side (their normal is the cache's
// normal and their direction in its hemisphere, as the photon map's contract requires): half of the
// power in a narrow beam 35 degrees off the normal, a fifth in a grazing beam, the rest cosine-spread.
// Powers vary, so the maps weight photons by power rather than counting them.
PhotonMap hand_made_photons(const CachePoints& caches, int per_cache, uint64_t seed) {
    PhotonMap m;
    Rng rng(seed, 11);
    for (size_t c = 0; c < caches.size(); ++c) {
        const Vec3 n = caches.normal[c];
        const Frame f(n);
        const Vec3 beam = f.to_world({std::sin(0.61f), 0, std::cos(0.61f)});            // 35 deg
        const Vec3 grazing = normalize(f.to_world({-0.2f, -std::sin(1.4f), std::cos(1.4f)}));  // ~80 deg
        for (int i = 0; i < per_cache; ++i) {
            const float r = 0.3f * std::sqrt(rng.next_float()), a = 2 * kPi * rng.next_float();
            m.position.push_back(caches.position[c] + f.s * (r * std::cos(a)) + f.t * (r * std::sin(a)));
            m.normal.push_back(n);
            const float u = rng.next_float();
            Vec3 d = u < 0.5f ? cone_direction(rng, beam, 0.08f)
                     : u < 0.7f ? cone_direction(rng, grazing, 0.05f)
                                : f.to_world(sample_cosine_hemisphere({rng.next_float(), rng.next_float()}));
            if (dot(d, n) < 0) d = d - n * (2 * dot(d, n));  // keep it on the cache's side
            m.direction.push_back(normalize(d));
            const float p = 0.5f + rng.next_float();
            m.power.push_back(RGB(p, 0.8f * p, 1.2f * p));
        }
    }
    m.emitted_paths = m.size();
    return m;
}

CachePoints hand_made_caches() {
    CachePoints c;
    const Vec3 normals[4] = {Vec3(0, 0, 1), normalize(Vec3(1, 2, -3)), Vec3(0, 0, -1),
                             normalize(Vec3(0.3f, -0.9f, 0.1f))};
    for (int i = 0; i < 4; ++i) {
        c.position.push_back(Vec3(10.0f * float(i), 0, 0));  // far apart: each gathers only its own photons
        c.normal.push_back(normals[i]);
        c.origin.push_back(kCacheFromPhoton);
    }
    return c;
}

// Pearson's statistic over bins (those with expectation below 5 pooled into one), and its p-value.
struct BinChi2 {
    double stat = 0, p = 1;
    int dof = 0;
};
BinChi2 bin_chi2(const std::vector<double>& observed, const std::vector<double>& expected) {
    BinChi2 r;
    double pool_o = 0, pool_e = 0;
    int bins = 0;
    for (size_t i = 0; i < observed.size(); ++i) {
        if (expected[i] < 5) {
            pool_o += observed[i];
            pool_e += expected[i];
            continue;
        }
        r.stat += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
        ++bins;
    }
    if (pool_e >= 5) {
        r.stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        ++bins;
    } else if (pool_o > 20 + 4 * pool_e) {
        r.stat += 1e9;  // samples where the density is (almost) zero
    }
    r.dof = std::max(1, bins - 1);
    r.p = test::gamma_q(r.dof / 2.0, r.stat / 2.0);
    return r;
}

double sidak_alpha() { return 1.0 - std::pow(1.0 - kSignificance, 1.0 / kTests); }

// All five checks for cache c of `guide`.
// `atlas` is the one the guide was made from (the guide keeps its maps in its own table).
void check_cache(const Guide& guide, const CacheAtlas& atlas, int c, const std::string& label) {
    SCOPED_TRACE(label + ", cache " + std::to_string(c));
    ASSERT_TRUE(atlas.usable[size_t(c)]);
    const int R = atlas.resolution;
    const size_t N = atlas.texels();
    const double texel_sr = 4 * M_PI / double(N);
    const float* pdf = atlas.pdf_row(size_t(c));
    const float* cdf = atlas.cdf_row(size_t(c));

    // 1. The stored row. Sums in double of N float densities: rounding is ~1e-7 per texel.
    double sum = 0, max_pdf = 0;
    for (size_t k = 0; k < N; ++k) {
        ASSERT_TRUE(std::isfinite(pdf[k]));
        // The floor mixes f / N into every texel's probability: the density is >= f / (4 pi), less the
        // float cdf's rounding -- a texel's probability is the difference of two cdf values below 1, each
        // within half a ULP (2^-25) of exact, i.e. 2^-24 at most, times N / (4 pi) per steradian (at
        // R = 32, 0.25 % of the floor's density).
        const double slack = std::ldexp(1.0, -24) * double(N) / (4 * M_PI);
        EXPECT_GE(pdf[k], atlas.floor / (4 * M_PI) * (1 - 1e-6) - slack) << "texel " << k;
        sum += pdf[k] * texel_sr;
        max_pdf = std::max(max_pdf, double(pdf[k]));
    }
    EXPECT_NEAR(sum, 1.0, 1e-5);
    EXPECT_EQ(cdf[N - 1], 1.0f);

    // 2. Quadrature over the world sphere, 400 x 800 midpoint points uniform in (cos theta, phi): the
    // density is constant per texel, so the only error is at texel edges, where a point decides for a
    // whole quadrature cell. Measured at most 3e-4 on these maps, hence the bound of 1e-3; a map whose
    // texels were not of equal solid angle (those of a plain octahedral map differ by tens of percent)
    // misses it by far more.
    const double integral = test::integrate_sphere([&](Vec3 w) { return double(guide.pdf(c, w)); }, 400, 800);
    EXPECT_NEAR(integral, 1.0, 1e-3);

    // 3 and 4: samples in world space.
    const long long samples = 1000000;
    long long mismatched = 0, invalid = 0;
    std::vector<double> texel_observed(N, 0.0);
    Rng rng(0x5eed + uint64_t(c), 3);
    const Frame frame(atlas.normal[size_t(c)]);
    for (long long i = 0; i < samples; ++i) {
        float p = 0;
        const Vec3 w = guide.sample(c, {rng.next_float(), rng.next_float()}, &p);
        if (!(p > 0) || !(std::abs(length(w) - 1) < 1e-4f)) {
            ++invalid;
            continue;
        }
        // The reported density must be the one pdf() gives for the direction. In world space the
        // to_world / to_local round trip can move a sample lying within float rounding (~1e-7) of a
        // texel edge across it (the pitfall spheremap.h documents); such samples are a fraction of
        // ~1e-6 of all, so more than 1e-4 means the frames or caches disagree.
        if (p != guide.pdf(c, w)) ++mismatched;
        texel_observed[size_t(sphere_texel_of(frame.to_local(w), R))] += 1;
    }
    EXPECT_EQ(invalid, 0) << "samples without a density or not of unit length";
    EXPECT_LE(mismatched, samples / 10000) << "reported density differs from Guide::pdf";

    test::Chi2Options o;
    o.samples = samples;
    o.theta_bins = 16;
    o.phi_bins = 32;
    o.test_count = kTests;
    o.significance = kSignificance;
    o.seed = 0x5eed + uint64_t(c);
    // The density jumps by up to ~300x at texel edges (R = 7, floor 0.01, no filter), which cut the
    // world cells along arbitrary curves. The helper's default 6 x 6 points per cell can miss a sliver
    // of a bright texel in a dark cell altogether (and then "converge" on the wrong value: expected
    // 19.5 instead of 99.5 counts in one cell); 16 x 16 points, refined up to 2 levels, agree with a
    // brute-force 400 x 400 midpoint rule per cell to within 0.5 standard deviations (sqrt of the
    // expected count) in every cell of every cache here (checked once, too slow to run each time;
    // deeper refinement changed no cell by more than 0.01 of that).
    o.quadrature = 16;
    o.quad_max_depth = 2;
    auto sampler = [&](Rng& r) {
        test::DirSample s;
        float p = 0;
        s.w = guide.sample(c, {r.next_float(), r.next_float()}, &p);
        s.valid = p > 0;
        return s;
    };
    test::Chi2Result res = test::chi2_test_sphere(sampler, [&](Vec3 w) { return double(guide.pdf(c, w)); }, o);
    EXPECT_TRUE(res.passed) << res.log;
    // 5. Texel histogram against the probabilities of the guide's packed map (exact expectations; the
    // unit tests bound their distance from the atlas's).
    std::vector<double> texel_expected(N);
    for (size_t k = 0; k < N; ++k) texel_expected[k] = double(guide.texel_pdf(c, int(k))) * texel_sr * double(samples);
    BinChi2 t = bin_chi2(texel_observed, texel_expected);
    EXPECT_GT(t.p, sidak_alpha()) << "texel chi2 = " << t.stat << ", dof " << t.dof << ", p = " << t.p;
    std::printf("  %s cache %d: max density %.3g/sr, integral %.6f, mismatched %lld; %s  texel chi2 %.1f (dof %d, p %.3g)\n",
                label.c_str(), c, max_pdf, integral, mismatched, res.log.c_str(), t.stat, t.dof, t.p);
}

// Hand-made photons in two map settings: R = 16 with the default filter and floor, and an odd resolution without
// a filter and with a small floor, whose maps are far peakier.
struct MapSetting {
    int resolution;
    double sigma, floor;
};

TEST(GuidingCacheChi2, HandMadePhotons) {
    const CachePoints caches = hand_made_caches();
    const PhotonMap photons = hand_made_photons(caches, 3000, 5);
    for (MapSetting ms : {MapSetting{16, 0.75, 0.1}, MapSetting{7, 0.0, 0.01}}) {
        FillOptions o;
        o.k = 1500;
        o.resolution = ms.resolution;
        o.filter_sigma = ms.sigma;
        o.floor = ms.floor;
        o.threads = 1;
        o.quiet = true;
        FillStats stats;
        CacheAtlas atlas = fill_caches(caches, photons, 30.0, o, &stats);
        ASSERT_EQ(stats.usable, caches.size());
        Guide guide(atlas, 0.25f);
        for (int c = 0; c < int(caches.size()); ++c)
            check_cache(guide, atlas, c, "R = " + std::to_string(ms.resolution));
    }
}

TEST(GuidingCacheChi2, CausticScenePhotons) {
    SceneLoadOptions lo;
    std::vector<std::string> warnings;
    lo.warnings = &warnings;
    Scene scene = load_scene(test::data_file("guiding/caustic_box.xml"), lo);
    PhotonOptions po;
    po.paths = 30000;
    po.seed = 2;
    po.quiet = true;
    PhotonMap photons = trace_photons(scene, po, nullptr);
    PlacementOptions pl;
    pl.count = 200;
    pl.quiet = true;
    CachePoints caches = place_caches(scene, photons, pl, nullptr);
    FillOptions fo;
    fo.k = 400;
    fo.quiet = true;
    const double diagonal = length(scene.bounds_max - scene.bounds_min);
    const CacheAtlas atlas = fill_caches(caches, photons, diagonal, fo, nullptr);
    Guide guide(atlas, 0.25f);
    // The peakiest usable cache (on the caustic, or looking at the light), the least peaky one, and a
    // camera cache from the middle of the list.
    int peaky = -1, flat = -1, camera = -1;
    float peak_max = 0, flat_max = kInf;
    for (size_t c = 0; c < atlas.size(); ++c) {
        if (!atlas.usable[c]) continue;
        const float m = *std::max_element(atlas.pdf_row(c), atlas.pdf_row(c) + atlas.texels());
        if (m > peak_max) peak_max = m, peaky = int(c);
        if (m < flat_max) flat_max = m, flat = int(c);
    }
    for (size_t c = 0; c < atlas.size(); ++c)
        if (atlas.usable[c] && caches.origin[c] == kCacheFromCamera && int(c) != peaky && int(c) != flat &&
            (camera < 0 || c <= atlas.size() / 4))
            camera = int(c);
    ASSERT_GE(peaky, 0);
    ASSERT_GE(camera, 0);
    ASSERT_NE(peaky, flat);
    for (int c : {peaky, flat, camera}) check_cache(guide, atlas, c, "caustic scene");
}

}  // namespace
}  // namespace iris
