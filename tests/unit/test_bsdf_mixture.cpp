// Phong, mixturebsdf and blendbsdf (libcommon/bsdf_phong.cpp, bsdf_mixture.cpp): sample() against
// eval()/pdf(), the guiding contract (bsdf_guidable_share/pdf), Dirac parts, reciprocity, energy,
// twosided, and the reference values of Mitsuba 0.5's formulas.
#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <string>
#include <vector>

#include "libcommon/bsdf.h"
#include "libcommon/rng.h"
#include "support/mixtures.h"

namespace iris {
namespace {

using test::keep;
using test::mix;
using test::phong;

Vec3 dir(float theta_deg, float phi_deg) {
    const float t = theta_deg * kPi / 180, p = phi_deg * kPi / 180;
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}
Vec3 random_upper(Rng& rng) {
    const float z = std::max(rng.next_float(), 1e-4f), r = safe_sqrt(1 - z * z), p = 2 * kPi * rng.next_float();
    return {r * std::cos(p), r * std::sin(p), z};
}
Vec3 random_sphere(Rng& rng) {
    const float z = 1 - 2 * rng.next_float(), r = safe_sqrt(1 - z * z), p = 2 * kPi * rng.next_float();
    return {r * std::cos(p), r * std::sin(p), z};
}
Vec2 next2(Rng& rng) { return {rng.next_float(), rng.next_float()}; }

::testing::AssertionResult rgb_near(RGB a, RGB b, float rel) {
    for (int c = 0; c < 3; ++c)
        if (!(std::abs(a[c] - b[c]) <= rel * std::max(std::abs(a[c]), std::abs(b[c])) + 1e-12f))
            return ::testing::AssertionFailure() << "channel " << c << ": " << a[c] << " vs " << b[c];
    return ::testing::AssertionSuccess();
}

Bsdf diffuse(RGB rho) {
    Bsdf b;
    b.diffuse = rho;
    return b;
}
Bsdf conductor(RGB spec) {  // silver-like complex IOR
    Bsdf b;
    b.type = BsdfType::Conductor;
    b.eta = {0.155f, 0.117f, 0.138f};
    b.k = {4.83f, 3.12f, 2.15f};
    b.specular = spec;
    return b;
}
Bsdf rough(BsdfType t, float alpha) {
    Bsdf b;
    b.type = t;
    b.alpha_u = b.alpha_v = alpha;
    b.eta = {0.155f, 0.117f, 0.138f};
    b.k = {4.83f, 3.12f, 2.15f};
    b.ior = 1.5f;
    return b;
}

struct Case {
    std::string name;
    Bsdf b;
    bool has_delta = false, transmits = false;
};
std::vector<Case> cases() {
    const RGB col{0.8f, 0.5f, 0.2f};
    std::vector<Case> c;
    c.push_back({"phong_n30", phong(RGB(0.5f), RGB(0.2f), 30)});
    c.push_back({"phong_n600_dark", phong(RGB(0.01f), {0.15f, 0.09f, 0.06f}, 600)});
    c.push_back({"phong_specular_only", phong(RGB(0), RGB(0.6f), 5)});
    // living_room's ceiling_list: a silver mirror and a white diffuse, weights 1, 1 (no normalisation).
    c.push_back({"mixture_mirror_diffuse", mix({{1, conductor(RGB(0.078f))}, {1, diffuse(RGB(0.99f))}}), true});
    c.push_back({"mixture_rough_three", mix({{0.2f, rough(BsdfType::RoughConductor, 0.3f)}, {0.5f, diffuse(col)},
                                             {0.3f, phong(RGB(0.1f), RGB(0.5f), 40)}})});
    // A blend as on glass_of_milk's table (there a diffuse and a rough conductor, weight 0.3; here rough
    // glass, which transmits).
    c.push_back({"blend_diffuse_roughglass", mix({{0.7f, diffuse(RGB(0.05f, 0, 0))}, {0.3f, rough(BsdfType::RoughDielectric, 0.2f)}}),
                 false, true});
    Bsdf nested = mix({{0.5f, mix({{1, conductor(RGB(1))}, {1, phong(col, RGB(0.1f), 10)}})}, {0.5f, rough(BsdfType::RoughPlastic, 0.1f)}});
    c.push_back({"mixture_nested", nested, true});
    Bsdf two = mix({{0.4f, diffuse(col)}, {0.6f, rough(BsdfType::RoughConductor, 0.2f)}});
    two.two_sided = true;
    c.push_back({"mixture_twosided", two});
    return c;
}

TEST(BsdfMixture, SampleWeightIsEvalOverPdf) {
    for (const Case& c : cases()) {
        SCOPED_TRACE(c.name);
        Rng rng(21, 1);
        int nondelta = 0, delta = 0;
        for (int i = 0; i < 6000; ++i) {
            const Vec3 wi = c.transmits || c.b.two_sided ? random_sphere(rng) : random_upper(rng);
            for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
                BsdfSample s;
                if (!bsdf_sample(c.b, wi, next2(rng), rng.next_float(), &s, mode)) continue;
                ASSERT_TRUE(is_finite(s.weight) && s.weight.r >= 0 && s.weight.g >= 0 && s.weight.b >= 0);
                ASSERT_NEAR(length(s.wo), 1.0f, 1e-4f);
                if (s.delta) {
                    ASSERT_TRUE(c.has_delta);
                    ++delta;
                    continue;
                }
                ++nondelta;
                const float pdf = bsdf_pdf(c.b, wi, s.wo);
                ASSERT_NEAR(s.pdf, pdf, 1e-5f * pdf);
                ASSERT_TRUE(rgb_near(s.weight, bsdf_eval(c.b, wi, s.wo, mode) / pdf, 1e-3f));
            }
        }
        EXPECT_GT(nondelta, 1000);
        EXPECT_EQ(delta > 0, c.has_delta);
        EXPECT_EQ(bsdf_has_delta_lobe(c.b), c.has_delta);
        EXPECT_EQ(bsdf_transmits(c.b), c.transmits);
        EXPECT_FALSE(bsdf_is_delta(c.b));
    }
}

// The mixture's value and density are the weighted sums of its parts' (Mitsuba's mixturebsdf: values
// times the weights as given, densities times the normalised weights).
TEST(BsdfMixture, EvalAndPdfAreWeightedSumsOfTheParts) {
    const Bsdf a = phong(RGB(0.3f), RGB(0.4f), 20), d = diffuse(RGB(0.6f));
    const Bsdf m = mix({{1, a}, {3, d}});
    Rng rng(22, 1);
    for (int i = 0; i < 1000; ++i) {
        const Vec3 wi = random_upper(rng), wo = random_upper(rng);
        EXPECT_TRUE(rgb_near(bsdf_eval(m, wi, wo), bsdf_eval(a, wi, wo) + bsdf_eval(d, wi, wo) * 3.0f, 1e-5f));
        EXPECT_NEAR(bsdf_pdf(m, wi, wo), 0.25f * bsdf_pdf(a, wi, wo) + 0.75f * bsdf_pdf(d, wi, wo), 1e-5f * bsdf_pdf(m, wi, wo));
    }
}

// A mirror part is chosen with its discrete probability and weighted by weight / probability: weights
// 1, 1 make the mirror's expected contribution its full Fresnel reflectance (not half of it).
TEST(BsdfMixture, DiracPartKeepsItsDiscreteProbability) {
    const Bsdf mirror = conductor(RGB(1));
    const Bsdf m = mix({{1, mirror}, {1, diffuse(RGB(0.5f))}});
    const Vec3 wi = dir(40, 10);
    BsdfSample s, ref;
    ASSERT_TRUE(bsdf_sample(mirror, wi, {0.3f, 0.3f}, 0.5f, &ref));
    int n_delta = 0;
    Rng rng(23, 1);
    for (int i = 0; i < 20000; ++i) {
        if (!bsdf_sample(m, wi, next2(rng), rng.next_float(), &s) || !s.delta) continue;
        ++n_delta;
        EXPECT_FLOAT_EQ(s.pdf, 0.5f);
        EXPECT_TRUE(rgb_near(s.weight, ref.weight * 2.0f, 1e-6f));
        EXPECT_EQ(s.wo.z, wi.z);
    }
    EXPECT_NEAR(n_delta / 20000.0, 0.5, 0.02);
}

// bsdf.h's guiding contract, for composites: share and density of the replaceable lobes sum the parts',
// and bsdf_sample draws exactly those for uc >= 1 - share: its samples there are non-Dirac, reflect,
// and their histogram matches guidable_pdf / share (checked on a coarse grid by a moment test).
TEST(BsdfMixture, GuidableShareAndDensityMatchTheLobeChoice) {
    for (const Case& c : cases()) {
        SCOPED_TRACE(c.name);
        if (c.b.type != BsdfType::Mixture) continue;
        Rng rng(24, 1);
        for (Vec3 wi : {dir(0, 0), dir(45, 30), dir(80, -60)}) {
            float g_parts = 0;
            for (int i = 0; i < c.b.part_count; ++i)
                g_parts += bsdf_part_probability(c.b, i) * bsdf_guidable_share(*c.b.part[i], wi);
            const float g = bsdf_guidable_share(c.b, wi);
            ASSERT_NEAR(g, g_parts, 1e-6f);
            ASSERT_GT(g, 0.0f);
            ASSERT_LE(g, 1.0f);
            // Mean of wo.z (and of wo.x) over the replaceable samples vs the same moments of q / g.
            double mz = 0, mx = 0, made = 0;  // (microfacet samples may leave below the horizon: failures)
            const int n = 40000;
            for (int i = 0; i < n; ++i) {
                const float uc = std::min((1 - g) + g * rng.next_float(), 0x1.fffffep-1f);
                BsdfSample s;
                if (!bsdf_sample(c.b, wi, next2(rng), uc, &s)) continue;
                ASSERT_FALSE(s.delta) << "a Dirac lobe in the replaceable share";
                made += 1.0 / n;
                mz += s.wo.z / n;
                mx += s.wo.x / n;
            }
            // Riemann sum of q / g over the sphere (q vanishes below the surface: caches replace reflection).
            double qz = 0, qx = 0, qsum = 0;
            const int nt = 400, np = 200;
            for (int it = 0; it < nt; ++it)
                for (int ip = 0; ip < np; ++ip) {
                    const float ct = 1 - (it + 0.5f) / nt, phi = 2 * kPi * (ip + 0.5f) / np, st = safe_sqrt(1 - ct * ct);
                    const Vec3 w(st * std::cos(phi), st * std::sin(phi), ct);
                    const double q = bsdf_guidable_pdf(c.b, wi, w) / g * (1.0 / nt) * (2 * kPi / np);
                    qsum += q;
                    qz += q * w.z;
                    qx += q * w.x;
                }
            EXPECT_NEAR(qsum, made, 0.01);
            EXPECT_NEAR(mz, qz, 0.01);
            EXPECT_NEAR(mx, qx, 0.01);
            // Below 1 - g: only the parts' own (non-replaceable) lobes; nothing guided leaks in.
            for (int i = 0; i < 2000; ++i) {
                BsdfSample s;
                const Vec2 u = next2(rng);
                const float uc = (1 - g) * rng.next_float();
                if (!bsdf_sample(c.b, wi, u, uc, &s)) continue;
                ASSERT_TRUE(s.wo.z == s.wo.z);
            }
        }
    }
}

TEST(BsdfMixture, ReciprocityAndTwoSided) {
    for (const Case& c : cases()) {
        if (c.transmits) continue;  // (rough glass: radiance is not reciprocal across the interface)
        SCOPED_TRACE(c.name);
        Rng rng(25, 1);
        for (int i = 0; i < 3000; ++i) {
            const Vec3 wi = random_upper(rng), wo = random_upper(rng);
            EXPECT_TRUE(rgb_near(bsdf_eval(c.b, wi, wo) / wo.z, bsdf_eval(c.b, wo, wi) / wi.z, 2e-3f));
            const Vec3 bi(wi.x, wi.y, -wi.z), bo(wo.x, wo.y, -wo.z);
            if (c.b.two_sided) {
                EXPECT_TRUE(rgb_near(bsdf_eval(c.b, bi, bo), bsdf_eval(c.b, wi, wo), 1e-6f));
                EXPECT_EQ(bsdf_pdf(c.b, bi, bo), bsdf_pdf(c.b, wi, wo));
            } else {
                EXPECT_TRUE(is_black(bsdf_eval(c.b, bi, bo)));
                EXPECT_EQ(bsdf_pdf(c.b, bi, bo), 0.0f);
            }
        }
    }
}

// Albedo: the sample weights' mean. Phong with kd + ks <= 1 reflects at most 1 (its lobe is normalised
// to reflect at most ks); a mixture of white parts with weights summing to 1 the mean of the parts'.
double albedo(const Bsdf& b, Vec3 wi, int n = 200000) {
    Rng rng(26, 3);
    double sum = 0;
    for (int i = 0; i < n; ++i) {
        BsdfSample s;
        if (bsdf_sample(b, wi, next2(rng), rng.next_float(), &s)) sum += average(s.weight);
    }
    return sum / n;
}
TEST(BsdfMixture, EnergyOfPhongAndMixtures) {
    for (float theta : {0.0f, 45.0f, 80.0f}) {
        SCOPED_TRACE(theta);
        const Vec3 wi = dir(theta, 20);
        // At normal incidence the lobe lies above the horizon up to cos^n's tail: kd + ks exactly.
        const double a = albedo(phong(RGB(0.5f), RGB(0.49f), 200), wi);
        EXPECT_LE(a, 0.99 + 3e-3);
        if (theta == 0) {
            EXPECT_NEAR(a, 0.99, 3e-3);
        }
        const double d = albedo(diffuse(RGB(1)), wi), p = albedo(phong(RGB(0), RGB(1), 20), wi);
        EXPECT_NEAR(albedo(mix({{0.25f, diffuse(RGB(1))}, {0.75f, phong(RGB(0), RGB(1), 20)}}), wi), 0.25 * d + 0.75 * p, 5e-3);
    }
}

// Mitsuba 0.5's phong at one configuration, by hand: f = kd/pi + ks (n+2)/(2 pi) cos^n(alpha).
TEST(BsdfPhong, ValueAndDensityByHand) {
    const Bsdf b = phong({0.2f, 0.3f, 0.4f}, RGB(0.25f), 10);
    const Vec3 wi = dir(30, 0), wo = dir(40, 180);  // 10 degrees from the mirror direction (30, 180)
    const float ca = std::cos(10 * kPi / 180);
    const float lobe = (12 / (2 * kPi)) * std::pow(ca, 10.0f);
    const RGB expect = (RGB(0.2f, 0.3f, 0.4f) * kInvPi + RGB(0.25f * lobe)) * wo.z;
    EXPECT_TRUE(rgb_near(bsdf_eval(b, wi, wo), expect, 1e-5f));
    const float w = luminance(RGB(0.25f)) / (luminance(RGB(0.25f)) + luminance({0.2f, 0.3f, 0.4f}));
    EXPECT_NEAR(bsdf_pdf(b, wi, wo), w * (11 / (2 * kPi)) * std::pow(ca, 10.0f) + (1 - w) * wo.z * kInvPi, 1e-5f);
    // No lobe beyond 90 degrees from the mirror direction, nothing below the surface.
    EXPECT_TRUE(rgb_near(bsdf_eval(b, dir(30, 0), dir(70, 0)), RGB(0.2f, 0.3f, 0.4f) * (kInvPi * dir(70, 0).z), 1e-5f));
    EXPECT_TRUE(is_black(bsdf_eval(b, wi, dir(100, 0))));
}

}  // namespace
}  // namespace iris
