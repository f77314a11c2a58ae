// Fast exact checks of the BSDFs (STYLE.md habit 7): sample() agrees with eval()/pdf(), densities are
// finite and integrate to the non-delta mass, one-sided models vanish below the horizon, reciprocity,
// energy conservation, Fresnel reference values, transport-mode scaling, and robustness at grazing
// angles and tiny roughness. The distributional check of sample() against pdf() is the chi-square test
// in tests/statistical/test_bsdf_chi2.cpp.
#include <gtest/gtest.h>

#include <tuple>

#include <cmath>
#include <string>
#include <vector>

#include "libcommon/bsdf.h"
#include "libcommon/microfacet.h"
#include "libcommon/rng.h"
#include "support/chi2.h"

namespace iris {
namespace {

// ---- fixtures ---------------------------------------------------------------------------------------------

Vec3 dir(float theta_deg, float phi_deg) {
    float t = theta_deg * kPi / 180, p = phi_deg * kPi / 180;
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

struct Case {
    std::string name;
    Bsdf b;
    bool has_delta = false;  // a Dirac lobe besides the continuous part (plastic)
};

Bsdf prepared(Bsdf b) {
    bsdf_prepare(b);
    return b;
}

Bsdf diffuse(RGB rho) {
    Bsdf b;
    b.type = BsdfType::Diffuse;
    b.diffuse = rho;
    return prepared(b);
}
Bsdf rough_diffuse(RGB rho, float alpha) {
    Bsdf b;
    b.type = BsdfType::RoughDiffuse;
    b.diffuse = rho;
    b.alpha_u = b.alpha_v = alpha;
    return prepared(b);
}
// Gold-like complex IOR (RGB), and the "none" convention (eta 0, k 1): a perfect mirror.
constexpr RGB kGoldEta{0.143f, 0.374f, 1.442f}, kGoldK{3.983f, 2.385f, 1.603f};
Bsdf rough_conductor(Microfacet d, float au, float av, RGB eta = kGoldEta, RGB k = kGoldK, RGB spec = RGB(1)) {
    Bsdf b;
    b.type = BsdfType::RoughConductor;
    b.distribution = d;
    b.alpha_u = au;
    b.alpha_v = av;
    b.eta = eta;
    b.k = k;
    b.specular = spec;
    return prepared(b);
}
Bsdf plastic(float ior, RGB diff, RGB spec = RGB(1), bool nonlinear = false) {
    Bsdf b;
    b.type = BsdfType::Plastic;
    b.ior = ior;
    b.diffuse = diff;
    b.specular = spec;
    b.nonlinear = nonlinear;
    return prepared(b);
}
Bsdf rough_plastic(Microfacet d, float alpha, float ior, RGB diff, RGB spec = RGB(1), bool nonlinear = false) {
    Bsdf b = plastic(ior, diff, spec, nonlinear);
    b.type = BsdfType::RoughPlastic;
    b.distribution = d;
    b.alpha_u = b.alpha_v = alpha;
    return prepared(b);
}
Bsdf ward(WardVariant v, float au, float av, RGB diff, RGB spec) {
    Bsdf b;
    b.type = BsdfType::Ward;
    b.ward_variant = v;
    b.alpha_u = au;
    b.alpha_v = av;
    b.diffuse = diff;
    b.specular = spec;
    return prepared(b);
}
Bsdf dielectric(float ior, RGB refl = RGB(1), RGB trans = RGB(1)) {
    Bsdf b;
    b.type = BsdfType::Dielectric;
    b.ior = ior;
    b.specular = refl;
    b.transmittance = trans;
    return prepared(b);
}
Bsdf thin_dielectric(float ior, RGB refl = RGB(1), RGB trans = RGB(1)) {
    Bsdf b = dielectric(ior, refl, trans);
    b.type = BsdfType::ThinDielectric;
    return prepared(b);
}
Bsdf rough_dielectric(Microfacet d, float au, float av, float ior, RGB refl = RGB(1), RGB trans = RGB(1)) {
    Bsdf b = dielectric(ior, refl, trans);
    b.type = BsdfType::RoughDielectric;
    b.distribution = d;
    b.alpha_u = au;
    b.alpha_v = av;
    return prepared(b);
}
Bsdf conductor(RGB eta, RGB k, RGB spec = RGB(1)) {
    Bsdf b;
    b.type = BsdfType::Conductor;
    b.eta = eta;
    b.k = k;
    b.specular = spec;
    return prepared(b);
}

// Every model with a continuous lobe, over the parameter ranges the seed scenes and tests need.
std::vector<Case> nondelta_cases() {
    const RGB col{0.8f, 0.5f, 0.2f};
    std::vector<Case> c;
    c.push_back({"diffuse", diffuse(col)});
    for (float a : {0.3f, 0.74f, 1.0f}) c.push_back({"roughdiffuse_a" + std::to_string(a), rough_diffuse(col, a)});
    for (Microfacet d : {Microfacet::Beckmann, Microfacet::GGX}) {
        std::string n = d == Microfacet::Beckmann ? "beckmann" : "ggx";
        c.push_back({"roughconductor_" + n + "_0.01", rough_conductor(d, 0.01f, 0.01f)});
        c.push_back({"roughconductor_" + n + "_0.1", rough_conductor(d, 0.1f, 0.1f)});
        c.push_back({"roughconductor_" + n + "_0.5", rough_conductor(d, 0.5f, 0.5f)});
        c.push_back({"roughconductor_" + n + "_aniso", rough_conductor(d, 0.05f, 0.4f)});
        c.push_back({"roughplastic_" + n + "_0.005", rough_plastic(d, 0.005f, 2.0f, {0.07f, 0.09f, 0.13f})});
        c.push_back({"roughplastic_" + n + "_0.1", rough_plastic(d, 0.1f, 1.5f, col)});
        c.push_back({"roughplastic_" + n + "_0.4_nonlinear", rough_plastic(d, 0.4f, 1.5f, col, RGB(0.8f), true)});
    }
    c.push_back({"plastic_1.5", plastic(1.5f, col), true});
    c.push_back({"plastic_2_nonlinear", plastic(2.0f, {0.07f, 0.09f, 0.13f}, RGB(1), true), true});
    for (WardVariant v : {WardVariant::Ward, WardVariant::WardDuer, WardVariant::Balanced}) {
        std::string n = v == WardVariant::Ward ? "ward" : v == WardVariant::WardDuer ? "wardduer" : "balanced";
        c.push_back({n + "_iso", ward(v, 0.2f, 0.2f, RGB(0.3f), RGB(0.5f))});
        c.push_back({n + "_aniso", ward(v, 0.08f, 0.4f, RGB(0.2f), col)});
    }
    c.push_back({"ward_seed_lamp", ward(WardVariant::Balanced, 0.4f, 0.4f, RGB(0), {0.616f, 0.4752f, 0.352f})});
    // Mitsuba 0.5's phong (exponent in alpha_u): living_room's dark metal and a broad lobe, and one
    // without a diffuse part (then one lobe, wholly guidable).
    for (auto [n, kd, ks] : {std::tuple{615.486f, RGB(0.01f), RGB(0.149f, 0.086f, 0.063f)}, {10.87f, RGB(0.3f), RGB(0.6f)},
                             {30.0f, RGB(0.0f), RGB(0.5f)}}) {
        Bsdf b;
        b.type = BsdfType::Phong;
        b.diffuse = kd;
        b.specular = ks;
        b.alpha_u = b.alpha_v = n;
        c.push_back({"phong_n" + std::to_string(int(n)) + (is_black(kd) ? "_nodiffuse" : ""), prepared(b)});
    }
    return c;
}

// Incident directions: normal, oblique, grazing, at various azimuths (anisotropic models care).
const std::vector<Vec3>& incident_dirs() {
    static const std::vector<Vec3> d = {dir(0, 0), dir(30, 10), dir(45, 30), dir(60, 100), dir(80, -120),
                                        dir(89, 45)};
    return d;
}

// A direction on the upper hemisphere, biased towards grazing angles (z = u^2).
Vec3 random_upper(Rng& rng) {
    float z = sqr(rng.next_float());
    float r = safe_sqrt(1 - z * z), p = 2 * kPi * rng.next_float();
    return {r * std::cos(p), r * std::sin(p), std::max(z, 1e-6f)};
}
Vec3 random_sphere(Rng& rng) {
    float z = 1 - 2 * rng.next_float();
    float r = safe_sqrt(1 - z * z), p = 2 * kPi * rng.next_float();
    return {r * std::cos(p), r * std::sin(p), z};
}
Vec2 next2(Rng& rng) { return {rng.next_float(), rng.next_float()}; }

bool finite_nonneg(RGB c) { return is_finite(c) && c.r >= 0 && c.g >= 0 && c.b >= 0; }

// |a - b| <= rel * max(|a|, |b|) per channel (plus a tiny absolute floor for zeros).
::testing::AssertionResult rgb_near(RGB a, RGB b, float rel) {
    for (int c = 0; c < 3; ++c) {
        float tol = rel * std::max(std::abs(a[c]), std::abs(b[c])) + 1e-12f;
        if (!(std::abs(a[c] - b[c]) <= tol))
            return ::testing::AssertionFailure() << "channel " << c << ": " << a[c] << " vs " << b[c];
    }
    return ::testing::AssertionSuccess();
}

// ---- sample() against eval()/pdf() -------------------------------------------------------------------------

TEST(BsdfSample, WeightIsEvalOverPdfAndPdfMatches) {
    for (const Case& c : nondelta_cases()) {
        SCOPED_TRACE(c.name);
        Rng rng(11, 1);
        int nondelta = 0;
        for (int i = 0; i < 4000; ++i) {
            Vec3 wi = i < 600 ? incident_dirs()[i % incident_dirs().size()] : random_upper(rng);
            BsdfSample s;
            if (!bsdf_sample(c.b, wi, next2(rng), rng.next_float(), &s)) continue;
            ASSERT_TRUE(is_finite(s.wo) && std::abs(length(s.wo) - 1) < 1e-4f);
            ASSERT_TRUE(finite_nonneg(s.weight)) << s.weight.r << " " << s.weight.g << " " << s.weight.b;
            ASSERT_GT(s.wo.z, 0) << "reflection models reflect";
            if (s.delta) {
                ASSERT_TRUE(c.has_delta);
                continue;
            }
            ++nondelta;
            const float pdf = bsdf_pdf(c.b, wi, s.wo);
            ASSERT_TRUE(std::isfinite(s.pdf) && s.pdf > 0);
            ASSERT_NEAR(s.pdf, pdf, 1e-5f * pdf) << "sample's pdf vs bsdf_pdf";
            RGB f = bsdf_eval(c.b, wi, s.wo);
            ASSERT_TRUE(rgb_near(s.weight, f / pdf, 1e-3f));
        }
        EXPECT_GT(nondelta, 300) << "too few continuous samples to exercise the check";
    }
}

// The lobes a guide may replace (bsdf_guidable_share/pdf): q is the part of bsdf_pdf that those lobes
// contribute (0 <= q <= p_bsdf, q = p_bsdf for one-lobe models), and bsdf_sample takes them exactly for
// uc >= 1 - g: there a layered model samples its cosine lobe (the same direction as a diffuse BSDF for
// the same u), below it its coat (a different direction).
TEST(BsdfGuidable, ShareAndDensityMatchTheLobeChoiceOfSample) {
    const Bsdf lambert = diffuse(RGB(0.5f));
    Rng rng(5, 1);
    for (const Case& c : nondelta_cases()) {
        SCOPED_TRACE(c.name);
        const bool layered = c.b.type == BsdfType::Plastic || c.b.type == BsdfType::RoughPlastic ||
                             ((c.b.type == BsdfType::Ward || c.b.type == BsdfType::Phong) && !is_black(c.b.diffuse));
        for (Vec3 wi : incident_dirs()) {
            const float g = bsdf_guidable_share(c.b, wi);
            ASSERT_GT(g, 0.0f);
            ASSERT_LE(g, 1.0f);
            if (!layered) {
                EXPECT_EQ(g, 1.0f);
            }
            for (int i = 0; i < 64; ++i) {
                const Vec2 u{rng.next_float(), rng.next_float()};
                const Vec3 wo = dir(89.0f * rng.next_float(), 360.0f * rng.next_float());
                const float q = bsdf_guidable_pdf(c.b, wi, wo), p = bsdf_pdf(c.b, wi, wo);
                EXPECT_GE(q, 0.0f);
                EXPECT_LE(q, p * (1 + 1e-5f) + 1e-7f);
                if (!layered) {
                    EXPECT_EQ(q, p);
                }
                if (!layered || g >= 1) continue;
                BsdfSample lobe, coat, cosine;
                ASSERT_TRUE(bsdf_sample(lambert, wi, u, 0.5f, &cosine));
                const float uc_lobe = (1 - g) + g * rng.next_float(), uc_coat = (1 - g) * rng.next_float();
                ASSERT_TRUE(bsdf_sample(c.b, wi, u, std::min(uc_lobe, 0x1.fffffep-1f), &lobe));
                EXPECT_EQ(lobe.wo.x, cosine.wo.x);
                EXPECT_EQ(lobe.wo.z, cosine.wo.z);
                if (bsdf_sample(c.b, wi, u, uc_coat, &coat)) {
                    EXPECT_NE(coat.wo.z, cosine.wo.z);
                }
            }
        }
    }
    // Dirac-only models have nothing to replace.
    EXPECT_EQ(bsdf_guidable_share(dielectric(1.5f), dir(30, 0)), 0.0f);
    EXPECT_EQ(bsdf_guidable_share(conductor(kGoldEta, kGoldK), dir(30, 0)), 0.0f);
}

TEST(BsdfSample, PdfAndEvalFiniteAndNonNegativeEverywhere) {
    for (const Case& c : nondelta_cases()) {
        SCOPED_TRACE(c.name);
        Rng rng(12, 1);
        for (int i = 0; i < 20000; ++i) {
            Vec3 wi = random_sphere(rng), wo = i % 2 ? random_sphere(rng) : random_upper(rng);
            float p = bsdf_pdf(c.b, wi, wo);
            RGB f = bsdf_eval(c.b, wi, wo);
            ASSERT_TRUE(std::isfinite(p) && p >= 0) << p;
            ASSERT_TRUE(finite_nonneg(f));
        }
    }
}

// One-sided reflection models (Mitsuba convention): nothing below the horizon, on either side.
TEST(BsdfSample, OneSidedModelsVanishBelowHorizon) {
    for (const Case& c : nondelta_cases()) {
        SCOPED_TRACE(c.name);
        Rng rng(13, 1);
        for (int i = 0; i < 2000; ++i) {
            Vec3 up = random_upper(rng), any = random_sphere(rng);
            Vec3 down = -random_upper(rng);
            EXPECT_EQ(bsdf_pdf(c.b, down, any), 0.0f);
            EXPECT_TRUE(is_black(bsdf_eval(c.b, down, any)));
            EXPECT_EQ(bsdf_pdf(c.b, up, down), 0.0f);
            EXPECT_TRUE(is_black(bsdf_eval(c.b, up, down)));
            BsdfSample s;
            EXPECT_FALSE(bsdf_sample(c.b, down, next2(rng), rng.next_float(), &s));
            // Exactly on the horizon counts as below.
            Vec3 horizon(up.x, up.y, 0.0f);
            horizon = horizon / std::max(length(horizon), 1e-20f);
            EXPECT_EQ(bsdf_pdf(c.b, horizon, up), 0.0f);
            EXPECT_TRUE(is_black(bsdf_eval(c.b, up, horizon)));
        }
    }
}

TEST(BsdfSample, ReciprocityOfSymmetricModels) {
    // f(wi, wo) = f(wo, wi) for every non-delta model here; eval includes cos(theta_o).
    for (const Case& c : nondelta_cases()) {
        SCOPED_TRACE(c.name);
        Rng rng(14, 1);
        for (int i = 0; i < 5000; ++i) {
            Vec3 wi = random_upper(rng), wo = random_upper(rng);
            if (i % 3 == 0) {  // near the specular peak too, where glossy lobes are large
                BsdfSample s;
                if (!bsdf_sample(c.b, wi, next2(rng), rng.next_float(), &s) || s.delta) continue;
                wo = s.wo;
            }
            RGB a = bsdf_eval(c.b, wi, wo) / wo.z, b = bsdf_eval(c.b, wo, wi) / wi.z;
            ASSERT_TRUE(rgb_near(a, b, 2e-3f)) << "wi " << wi.x << "," << wi.y << "," << wi.z << " wo " << wo.x
                                               << "," << wo.y << "," << wo.z;
        }
    }
}

// The density integrates to the probability that sample() returns a non-delta direction: 1 for cosine
// sampling, 1 - P(delta) for plastic, less than 1 where microfacet/Ward reflections can leave through
// the horizon (such samples are rejected).
TEST(BsdfSample, PdfIntegratesToNonDeltaSampleMass) {
    for (const Case& c : nondelta_cases()) {
        for (Vec3 wi : {dir(0, 0), dir(45, 30), dir(80, -120)}) {
            SCOPED_TRACE(c.name + " theta_i=" + std::to_string(std::acos(wi.z) * 180 / kPi));
            // Glossy lobes peak near the mirror direction: grade the quadrature grid towards it.
            double integral = test::integrate_sphere_peaked([&](Vec3 w) { return bsdf_pdf(c.b, wi, w); },
                                                            Vec3(-wi.x, -wi.y, wi.z));
            Rng rng(15, 1);
            const int n = 40000;
            int hits = 0;
            for (int i = 0; i < n; ++i) {
                BsdfSample s;
                if (bsdf_sample(c.b, wi, next2(rng), rng.next_float(), &s) && !s.delta) ++hits;
            }
            double frac = double(hits) / n;
            double sigma = std::sqrt(std::max(frac * (1 - frac), 1e-6) / n);
            EXPECT_NEAR(integral, frac, 5 * sigma + 2e-3);
            EXPECT_LE(integral, 1.0 + 2e-3);
            if (c.b.type == BsdfType::Diffuse || c.b.type == BsdfType::RoughDiffuse) {
                EXPECT_NEAR(integral, 1.0, 1e-3);
            }
            if (c.b.type == BsdfType::Plastic) {
                float F = fresnel_dielectric(wi.z, c.b.ior);
                float w = c.b.specular_sampling_weight;
                EXPECT_NEAR(integral, 1.0 - F * w / (F * w + (1 - F) * (1 - w)), 1e-3);
            }
        }
    }
}

// ---- energy -----------------------------------------------------------------------------------------------

struct Albedo {
    double mean = 0, stderr_ = 0;
};
Albedo albedo(const Bsdf& b, Vec3 wi, TransportMode mode = TransportMode::Radiance, int n = 200000) {
    // (Albedo = E[average weight]; stderr_ its Monte Carlo standard error.)
    Rng rng(16, 7);
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
        BsdfSample s;
        double v = 0;
        if (bsdf_sample(b, wi, next2(rng), rng.next_float(), &s, mode)) v = average(s.weight);
        sum += v;
        sum2 += v * v;
    }
    Albedo a;
    a.mean = sum / n;
    a.stderr_ = std::sqrt(std::max(0.0, sum2 / n - a.mean * a.mean) / n);
    return a;
}

TEST(BsdfEnergy, WhiteModelsDoNotCreateEnergy) {
    // Oren-Nayar is left out on purpose: the model itself reflects more than it receives at grazing
    // incidence for rho = 1 (see BsdfRoughDiffuse.AlbedoMatchesOrenNayarPaper).
    std::vector<Case> white = {
        {"roughconductor_beckmann_0.05", rough_conductor(Microfacet::Beckmann, 0.05f, 0.05f, RGB(0), RGB(1))},
        {"roughconductor_beckmann_0.5", rough_conductor(Microfacet::Beckmann, 0.5f, 0.5f, RGB(0), RGB(1))},
        {"roughconductor_ggx_0.05", rough_conductor(Microfacet::GGX, 0.05f, 0.05f, RGB(0), RGB(1))},
        {"roughconductor_ggx_0.8_aniso", rough_conductor(Microfacet::GGX, 0.8f, 0.2f, RGB(0), RGB(1))},
        {"roughplastic_beckmann_0.05", rough_plastic(Microfacet::Beckmann, 0.05f, 1.5f, RGB(1))},
        {"roughplastic_ggx_0.1", rough_plastic(Microfacet::GGX, 0.1f, 2.0f, RGB(1))},
        {"balanced_ward_0.1", ward(WardVariant::Balanced, 0.1f, 0.1f, RGB(0), RGB(1))},
        {"balanced_ward_0.4", ward(WardVariant::Balanced, 0.4f, 0.4f, RGB(0), RGB(1))},
        {"balanced_ward_aniso_mixed", ward(WardVariant::Balanced, 0.1f, 0.5f, RGB(0.5f), RGB(0.5f))},
    };
    for (const Case& c : white)
        for (float theta : {0.0f, 45.0f, 70.0f, 85.0f}) {
            SCOPED_TRACE(c.name + " theta_i=" + std::to_string(theta));
            Albedo a = albedo(c.b, dir(theta, 20), TransportMode::Radiance, 100000);
            EXPECT_LE(a.mean, 1.0 + 4 * a.stderr_ + 1e-4);
            EXPECT_GT(a.mean, 0.3);
        }
}

// Models that lose no energy by construction reflect (or transmit) exactly all of it.
TEST(BsdfEnergy, LosslessModelsConserveEnergyExactly) {
    std::vector<Case> lossless = {
        {"diffuse", diffuse(RGB(1))},
        // White plastic: F_i (specular) + (1 - F_i) (diffuse, through the exact internal Fdr) = 1.
        {"plastic_1.5", plastic(1.5f, RGB(1))},
        {"plastic_2.0", plastic(2.0f, RGB(1))},
        {"plastic_1.33_nonlinear", plastic(1.33f, RGB(1), RGB(1), true)},
        {"conductor_none", conductor(RGB(0), RGB(1))},
        {"conductor_zero", conductor(RGB(0), RGB(0))},
        {"dielectric_1.5", dielectric(1.5f)},
        {"thin_dielectric_1.5", thin_dielectric(1.5f)},
    };
    for (const Case& c : lossless)
        for (float theta : {0.0f, 45.0f, 70.0f, 85.0f}) {
            SCOPED_TRACE(c.name + " theta_i=" + std::to_string(theta));
            // Importance mode: the dielectric's weights are then R/P(R) = T/P(T) = 1.
            Albedo a = albedo(c.b, dir(theta, 20), TransportMode::Importance);
            EXPECT_NEAR(a.mean, 1.0, 4 * a.stderr_ + 1e-4);
        }
    // From inside the glass too (including total internal reflection at 60 degrees), and the thin pane
    // from its back (in radiance mode: it never rescales).
    for (float theta : {100.0f, 135.0f, 150.0f, 179.0f}) {
        Albedo a = albedo(dielectric(1.5f), dir(theta, 20), TransportMode::Importance);
        EXPECT_NEAR(a.mean, 1.0, 4 * a.stderr_ + 1e-4) << theta;
        Albedo thin = albedo(thin_dielectric(1.5f), dir(theta, 20), TransportMode::Radiance);
        EXPECT_NEAR(thin.mean, 1.0, 4 * thin.stderr_ + 1e-4) << theta;
    }
}

// ---- Fresnel ----------------------------------------------------------------------------------------------

TEST(FresnelDielectric, NormalIncidenceAndSnell) {
    for (float eta : {1.1f, 1.33f, 1.5f, 2.0f, 2.4f}) {
        float r0 = sqr((eta - 1) / (eta + 1));
        float ct;
        EXPECT_NEAR(fresnel_dielectric(1.0f, eta, &ct), r0, 1e-6f);
        EXPECT_NEAR(ct, -1.0f, 1e-6f);
        EXPECT_NEAR(fresnel_dielectric(-1.0f, eta, &ct), r0, 1e-6f) << "same from inside";
        EXPECT_NEAR(ct, 1.0f, 1e-6f);
        // Snell's law at 50 degrees outside: sin_t = sin_i / eta, and cos_t points inside.
        float ci = std::cos(50 * kPi / 180);
        fresnel_dielectric(ci, eta, &ct);
        EXPECT_NEAR(std::sqrt(1 - ct * ct), std::sin(50 * kPi / 180) / eta, 1e-5f);
        EXPECT_LT(ct, 0);
        // Brewster's angle: Rp = 0, so R = Rs^2 / 2 with Rs = cos(2 theta_B) (tan theta_B = eta).
        float tb = std::atan(eta);
        EXPECT_NEAR(fresnel_dielectric(std::cos(tb), eta), 0.5f * sqr(std::cos(2 * tb)), 1e-5f);
        // Reciprocity: R is the same for the two ends of a refracted ray.
        float ri = fresnel_dielectric(ci, eta, &ct);
        EXPECT_NEAR(fresnel_dielectric(ct, eta), ri, 1e-5f);
        // Grazing: everything is reflected.
        EXPECT_NEAR(fresnel_dielectric(1e-6f, eta), 1.0f, 1e-4f);
    }
}

TEST(FresnelDielectric, TotalInternalReflectionAndIndexMatch) {
    float ct = 123;
    // Critical angle for 1.5 from inside: sin = 1/1.5 -> cos = 0.745.
    EXPECT_EQ(fresnel_dielectric(-0.7f, 1.5f, &ct), 1.0f);
    EXPECT_EQ(ct, 0.0f);
    EXPECT_LT(fresnel_dielectric(-0.8f, 1.5f, &ct), 1.0f);
    EXPECT_GT(ct, 0.0f);
    // Horizon from either side: no NaN, full reflection.
    EXPECT_EQ(fresnel_dielectric(0.0f, 1.5f, &ct), 1.0f);
    EXPECT_EQ(fresnel_dielectric(-0.0f, 1.5f, &ct), 1.0f);
    // eta = 1: no interface.
    EXPECT_EQ(fresnel_dielectric(0.3f, 1.0f, &ct), 0.0f);
    EXPECT_EQ(ct, -0.3f);
}

TEST(FresnelConductor, LimitsAndReferenceValues) {
    for (float c : {1.0f, 0.8f, 0.5f, 0.2f, 0.01f}) {
        // Perfect mirror conventions.
        RGB none = fresnel_conductor(c, RGB(0), RGB(1)), zero = fresnel_conductor(c, RGB(0), RGB(0));
        EXPECT_EQ(none.r, 1.0f);
        EXPECT_EQ(zero.g, 1.0f);
        // k -> infinity: a perfect conductor.
        EXPECT_GT(fresnel_conductor(c, RGB(1.5f), RGB(1e4f)).r, 0.9995f);
        // k = 0: a dielectric.
        for (float eta : {1.2f, 1.5f, 2.5f})
            EXPECT_NEAR(fresnel_conductor(c, RGB(eta), RGB(0)).g, fresnel_dielectric(c, eta), 1e-5f);
        // Within [0, 1].
        RGB g = fresnel_conductor(c, kGoldEta, kGoldK);
        for (int ch = 0; ch < 3; ++ch) EXPECT_TRUE(g[ch] >= 0 && g[ch] <= 1);
    }
    // Normal incidence: ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
    RGB r = fresnel_conductor(1.0f, kGoldEta, kGoldK);
    for (int ch = 0; ch < 3; ++ch) {
        float n = kGoldEta[ch], k = kGoldK[ch];
        EXPECT_NEAR(r[ch], (sqr(n - 1) + k * k) / (sqr(n + 1) + k * k), 1e-5f);
    }
    // Grazing: 1.
    EXPECT_NEAR(fresnel_conductor(0.0f, kGoldEta, kGoldK).b, 1.0f, 1e-5f);
}

// Published fits of the diffuse Fresnel reflectance, to cross-check the numerical integral.
double fdr_deon_irving(double eta) {  // d'Eon & Irving 2011, eta > 1
    double i = 1 / eta;
    return 0.919317 - 3.4793 * i + 6.75335 * i * i - 7.80989 * i * i * i + 4.98554 * i * i * i * i -
           1.36881 * i * i * i * i * i;
}
double fdr_egan_hilgeman(double eta) {  // Egan & Hilgeman 1973, eta < 1
    return -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta;
}

TEST(FresnelDiffuseReflectance, MatchesFitsAndReciprocity) {
    EXPECT_EQ(fresnel_diffuse_reflectance(1.0f), 0.0f);
    for (float eta : {1.2f, 1.33f, 1.5f, 1.8f, 2.0f, 3.0f}) {
        double ext = fresnel_diffuse_reflectance(eta), in = fresnel_diffuse_reflectance(1 / eta);
        // The fits' stated accuracy: d'Eon-Irving 0.2 %, Egan-Hilgeman 0.1-0.6 % up to eta = 2.
        EXPECT_NEAR(ext, fdr_deon_irving(eta), 0.003 * ext) << eta;
        if (eta <= 2.0f) {
            EXPECT_NEAR(in, fdr_egan_hilgeman(1 / eta), 0.01 * in) << eta;
        }
        // Exact identity (reciprocity of hemispherical transmittance): 1 - Fdr_int = (1 - Fdr_ext)/eta^2.
        EXPECT_NEAR(1 - in, (1 - ext) / (eta * eta), 2e-6) << eta;
    }
    // Mitsuba plastic's numbers for its default IOR 1.49 (polypropylene): Fdr_int ~ 0.6, Fdr_ext ~ 0.09.
    EXPECT_NEAR(fresnel_diffuse_reflectance(1.5f), 0.0918, 1e-3);
    EXPECT_NEAR(fresnel_diffuse_reflectance(1 / 1.5f), 0.5963, 1e-3);
}

// ---- delta models -----------------------------------------------------------------------------------------

TEST(BsdfDielectric, ReflectionRefractionProbabilitiesAndDirections) {
    const float ior = 1.5f;
    Bsdf b = dielectric(ior, RGB(0.9f), RGB(0.8f));
    EXPECT_TRUE(bsdf_is_delta(b));
    for (Vec3 wi : {dir(0, 0), dir(40, 30), dir(85, -60), dir(130, 200), dir(170, 10), dir(150, 0)}) {
        float cos_t;
        const float F = fresnel_dielectric(wi.z, ior, &cos_t);
        EXPECT_EQ(bsdf_pdf(b, wi, -wi), 0.0f);
        EXPECT_TRUE(is_black(bsdf_eval(b, wi, Vec3(-wi.x, -wi.y, wi.z))));
        // uc below F reflects, above refracts.
        BsdfSample r, t;
        ASSERT_TRUE(bsdf_sample(b, wi, {0.3f, 0.6f}, F * 0.5f, &r));
        if (F > 0) {
            EXPECT_TRUE(r.delta);
            EXPECT_NEAR(r.pdf, F, 1e-6f);
            EXPECT_EQ(r.eta, 1.0f);
            EXPECT_NEAR(r.wo.z, wi.z, 1e-6f);
            EXPECT_NEAR(r.wo.x, -wi.x, 1e-6f);
            EXPECT_TRUE(rgb_near(r.weight, RGB(0.9f), 1e-6f));
        }
        if (F >= 1) continue;  // total internal reflection: refraction impossible
        ASSERT_TRUE(bsdf_sample(b, wi, {0.3f, 0.6f}, F + (1 - F) * 0.5f, &t, TransportMode::Importance));
        EXPECT_TRUE(t.delta);
        EXPECT_NEAR(t.pdf, 1 - F, 1e-6f);
        EXPECT_LT(t.wo.z * wi.z, 0) << "refraction crosses the surface";
        EXPECT_NEAR(length(t.wo), 1.0f, 1e-5f);
        const bool entering = wi.z > 0;
        EXPECT_EQ(t.eta, entering ? ior : 1 / ior);
        // Snell: eta_i sin_i = eta_t sin_t; the tangential direction flips.
        float sin_i = std::sqrt(wi.x * wi.x + wi.y * wi.y), sin_t = std::sqrt(t.wo.x * t.wo.x + t.wo.y * t.wo.y);
        EXPECT_NEAR(entering ? sin_i : ior * sin_i, entering ? ior * sin_t : sin_t, 1e-5f);
        if (sin_i > 0) {
            EXPECT_LT(t.wo.x * wi.x + t.wo.y * wi.y, 0);
        }
        EXPECT_TRUE(rgb_near(t.weight, RGB(0.8f), 1e-6f)) << "importance: no eta^2 scaling";
        // Radiance: scaled by (eta_i/eta_t)^2 = 1/eta^2 on entering, eta^2 on leaving.
        BsdfSample tr;
        ASSERT_TRUE(bsdf_sample(b, wi, {0.3f, 0.6f}, F + (1 - F) * 0.5f, &tr, TransportMode::Radiance));
        float scale = entering ? 1 / (ior * ior) : ior * ior;
        EXPECT_TRUE(rgb_near(tr.weight, RGB(0.8f * scale), 1e-5f));
        EXPECT_EQ(tr.wo.z, t.wo.z);
    }
    // Beyond the critical angle from inside: reflection with probability one.
    BsdfSample s;
    ASSERT_TRUE(bsdf_sample(b, dir(130, 0), {0.5f, 0.5f}, 0.999f, &s));
    EXPECT_EQ(s.pdf, 1.0f);
    EXPECT_LT(s.wo.z, 0);
}

TEST(BsdfDielectric, IndexMatchedAndHorizonAreSafe) {
    Bsdf b = dielectric(1.0f);
    BsdfSample s;
    Vec3 wi = dir(60, 40);
    ASSERT_TRUE(bsdf_sample(b, wi, {0.5f, 0.5f}, 0.0f, &s));
    EXPECT_EQ(s.pdf, 1.0f);
    EXPECT_NEAR(s.wo.x, -wi.x, 1e-6f);
    EXPECT_NEAR(s.wo.z, -wi.z, 1e-6f);
    EXPECT_TRUE(rgb_near(s.weight, RGB(1), 1e-6f));
    // On the horizon exactly: finite output.
    Bsdf g = dielectric(1.5f);
    for (float uc : {0.0f, 0.5f, 0.9999f}) {
        ASSERT_TRUE(bsdf_sample(g, Vec3(1, 0, 0), {0.5f, 0.5f}, uc, &s));
        EXPECT_TRUE(is_finite(s.wo) && is_finite(s.weight) && std::isfinite(s.pdf));
    }
}

// A thin pane reflects R' = 2R / (1 + R) of the light in all (R: one face's Fresnel reflectance; the
// closed form of the series R + T R T + T R^3 T + ... that the model sums) and lets the rest through
// undeviated, the same from either side, without the eta^2 scaling of a refraction.
TEST(BsdfThinDielectric, ReflectsTheFacesInterreflectionsAndPassesStraightThrough) {
    const float ior = 1.5f;
    Bsdf b = thin_dielectric(ior, RGB(0.9f), RGB(0.8f));
    EXPECT_TRUE(bsdf_is_delta(b));
    EXPECT_TRUE(bsdf_has_delta_lobe(b));
    EXPECT_EQ(bsdf_guidable_share(b, dir(30, 0)), 0.0f);
    // Normal incidence: R = ((n - 1) / (n + 1))^2 = 0.04, R' = 0.08 / 1.04.
    BsdfSample s;
    ASSERT_TRUE(bsdf_sample(b, dir(0, 0), {0.5f, 0.5f}, 0.0f, &s));
    EXPECT_NEAR(s.pdf, 0.08f / 1.04f, 1e-6f);
    for (Vec3 wi : {dir(0, 0), dir(40, 30), dir(60, 0), dir(85, -60), dir(130, 200), dir(170, 10)}) {
        SCOPED_TRACE(std::to_string(wi.z));
        const float R = fresnel_dielectric(std::abs(wi.z), ior), R_pane = 2 * R / (1 + R);
        EXPECT_EQ(bsdf_pdf(b, wi, -wi), 0.0f);
        EXPECT_TRUE(is_black(bsdf_eval(b, wi, -wi)));
        for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
            BsdfSample r, t;
            ASSERT_TRUE(bsdf_sample(b, wi, {0.3f, 0.6f}, R_pane * 0.5f, &r, mode));
            EXPECT_TRUE(r.delta);
            EXPECT_NEAR(r.pdf, R_pane, 1e-6f);
            EXPECT_EQ(r.eta, 1.0f);
            EXPECT_NEAR(r.wo.x, -wi.x, 1e-6f);
            EXPECT_NEAR(r.wo.y, -wi.y, 1e-6f);
            EXPECT_NEAR(r.wo.z, wi.z, 1e-6f);
            EXPECT_TRUE(rgb_near(r.weight, RGB(0.9f), 1e-6f));
            ASSERT_TRUE(bsdf_sample(b, wi, {0.3f, 0.6f}, R_pane + (1 - R_pane) * 0.5f, &t, mode));
            EXPECT_TRUE(t.delta);
            EXPECT_NEAR(t.pdf, 1 - R_pane, 1e-6f);
            EXPECT_EQ(t.eta, 1.0f);
            EXPECT_EQ(t.wo.x, -wi.x);
            EXPECT_EQ(t.wo.y, -wi.y);
            EXPECT_EQ(t.wo.z, -wi.z);
            EXPECT_TRUE(rgb_near(t.weight, RGB(0.8f), 1e-6f));
        }
    }
    // Index-matched: everything passes; on the horizon: everything reflects.
    ASSERT_TRUE(bsdf_sample(thin_dielectric(1.0f), dir(50, 10), {0.5f, 0.5f}, 0.0f, &s));
    EXPECT_EQ(s.pdf, 1.0f);
    EXPECT_NEAR(s.wo.z, -dir(50, 10).z, 1e-6f);
    ASSERT_TRUE(bsdf_sample(b, Vec3(1, 0, 0), {0.5f, 0.5f}, 0.9999f, &s));
    EXPECT_EQ(s.pdf, 1.0f);
    EXPECT_TRUE(is_finite(s.wo) && is_finite(s.weight));
}

// ---- rough dielectric ------------------------------------------------------------------------------------

// The rough glass cases: both distributions, smooth to rough, anisotropic, denser and thinner than the
// exterior (ior < 1: the surface's normal points into the denser medium).
std::vector<Case> rough_dielectric_cases() {
    std::vector<Case> c;
    for (Microfacet d : {Microfacet::Beckmann, Microfacet::GGX}) {
        const std::string n = d == Microfacet::Beckmann ? "beckmann" : "ggx";
        c.push_back({"roughdielectric_" + n + "_0.05", rough_dielectric(d, 0.05f, 0.05f, 1.5f)});
        c.push_back({"roughdielectric_" + n + "_0.3", rough_dielectric(d, 0.3f, 0.3f, 1.5f, RGB(0.9f), RGB(0.8f, 0.7f, 0.6f))});
        c.push_back({"roughdielectric_" + n + "_aniso", rough_dielectric(d, 0.1f, 0.5f, 1.33f)});
        c.push_back({"roughdielectric_" + n + "_inverted", rough_dielectric(d, 0.2f, 0.2f, 1.0f / 1.5f)});
    }
    return c;
}

// Smooth glass's refracted direction about the normal (for the quadrature's grading), or the mirror
// direction under total internal reflection.
Vec3 refracted(Vec3 wi, float ior) {
    float cos_t;
    fresnel_dielectric(wi.z, ior, &cos_t);
    if (cos_t == 0) return Vec3(-wi.x, -wi.y, wi.z);
    const float e = wi.z > 0 ? 1 / ior : ior;
    return normalize(Vec3(-e * wi.x, -e * wi.y, cos_t));
}

// sample() agrees with eval()/pdf() from both sides and in both transport modes; reflection stays on
// wi's side and refraction crosses with the eta the sample reports.
TEST(BsdfRoughDielectric, SampleWeightIsEvalOverPdfFromBothSides) {
    for (const Case& c : rough_dielectric_cases()) {
        SCOPED_TRACE(c.name);
        EXPECT_FALSE(bsdf_is_delta(c.b));
        EXPECT_FALSE(bsdf_has_delta_lobe(c.b));
        Rng rng(21, 1);
        int reflected = 0, refracted_n = 0;
        for (int i = 0; i < 6000; ++i) {
            const Vec3 wi = random_sphere(rng);
            const TransportMode mode = i % 2 ? TransportMode::Radiance : TransportMode::Importance;
            BsdfSample s;
            if (!bsdf_sample(c.b, wi, next2(rng), rng.next_float(), &s, mode)) continue;
            ASSERT_TRUE(is_finite(s.wo) && std::abs(length(s.wo) - 1) < 1e-4f);
            ASSERT_FALSE(s.delta);
            ASSERT_TRUE(finite_nonneg(s.weight));
            const float pdf = bsdf_pdf(c.b, wi, s.wo);
            ASSERT_TRUE(pdf > 0 && std::isfinite(pdf));
            ASSERT_NEAR(s.pdf, pdf, 1e-5f * pdf);
            ASSERT_TRUE(rgb_near(s.weight, bsdf_eval(c.b, wi, s.wo, mode) / pdf, 1e-3f));
            if (wi.z * s.wo.z > 0) {
                ++reflected;
                EXPECT_EQ(s.eta, 1.0f);
            } else {
                ++refracted_n;
                EXPECT_EQ(s.eta, wi.z > 0 ? c.b.ior : 1 / c.b.ior);
            }
        }
        EXPECT_GT(reflected, 100);
        EXPECT_GT(refracted_n, 1000);
    }
}

// The adjoint: importance through the surface one way is radiance the other way,
// eval(wi, wo, Importance) / |wo.z| = eval(wo, wi, Radiance) / |wi.z|; the two modes differ by eta^2 on
// refraction only (radiance is compressed into the denser medium); reflection is reciprocal.
TEST(BsdfRoughDielectric, AdjointAndRadianceScaling) {
    for (const Case& c : rough_dielectric_cases()) {
        SCOPED_TRACE(c.name);
        Rng rng(22, 1);
        int nonzero = 0;
        for (int i = 0; i < 20000; ++i) {
            const Vec3 wi = random_sphere(rng);
            Vec3 wo = random_sphere(rng);
            if (i % 2) {  // near the lobes' peaks too
                BsdfSample s;
                if (!bsdf_sample(c.b, wi, next2(rng), rng.next_float(), &s)) continue;
                wo = s.wo;
            }
            const RGB imp = bsdf_eval(c.b, wi, wo, TransportMode::Importance) / std::abs(wo.z);
            const RGB rad_back = bsdf_eval(c.b, wo, wi, TransportMode::Radiance) / std::abs(wi.z);
            // (An absolute floor far below the lobes' values, ~0.1 to 1e4 per steradian: in Beckmann's
            // far tail, where D falls by orders of magnitude per degree, the float rounding of the two
            // ends' cosines differs by a few tenths of a percent at values of 1e-6 and below.)
            for (int ch = 0; ch < 3; ++ch)
                ASSERT_NEAR(imp[ch], rad_back[ch], 2e-3f * std::max(imp[ch], rad_back[ch]) + 1e-6f)
                    << "wi " << wi.x << "," << wi.y << "," << wi.z << " wo " << wo.x << "," << wo.y << "," << wo.z;
            const RGB rad = bsdf_eval(c.b, wi, wo, TransportMode::Radiance) / std::abs(wo.z);
            const float eta = wi.z * wo.z > 0 ? 1.0f : wi.z > 0 ? c.b.ior : 1 / c.b.ior;
            ASSERT_TRUE(rgb_near(imp, rad * (eta * eta), 1e-4f));
            nonzero += is_black(imp) ? 0 : 1;
        }
        EXPECT_GT(nonzero, 5000);
    }
}

// The density integrates to the probability that sample() returns a direction (less than one only by the
// samples that leave through the wrong side of their microfacet): reflected and refracted halves
// integrated separately, each graded towards its smooth direction.
TEST(BsdfRoughDielectric, PdfIntegratesToSampleMass) {
    for (const Case& c : rough_dielectric_cases()) {
        if (c.b.alpha_u < 0.1f) continue;  // (the narrow lobes are the chi-square test's)
        for (Vec3 wi : {dir(0, 0), dir(45, 30), dir(80, -120), dir(150, 60), dir(120, 10)}) {
            SCOPED_TRACE(c.name + " theta_i=" + std::to_string(std::acos(wi.z) * 180 / kPi));
            const Vec3 mirror(-wi.x, -wi.y, wi.z);
            const double refl = test::integrate_sphere_peaked(
                [&](Vec3 w) { return w.z * wi.z > 0 ? double(bsdf_pdf(c.b, wi, w)) : 0.0; }, mirror);
            const double refr = test::integrate_sphere_peaked(
                [&](Vec3 w) { return w.z * wi.z < 0 ? double(bsdf_pdf(c.b, wi, w)) : 0.0; }, refracted(wi, c.b.ior));
            Rng rng(23, 1);
            const int n = 40000;
            int hits = 0;
            for (int i = 0; i < n; ++i) {
                BsdfSample s;
                hits += bsdf_sample(c.b, wi, next2(rng), rng.next_float(), &s) ? 1 : 0;
            }
            const double frac = double(hits) / n, sigma = std::sqrt(std::max(frac * (1 - frac), 1e-6) / n);
            EXPECT_NEAR(refl + refr, frac, 5 * sigma + 3e-3);
            EXPECT_LE(refl + refr, 1.0 + 3e-3);
        }
    }
}

// As roughness vanishes, the model becomes smooth glass: the share of energy reflected is the Fresnel
// reflectance F, the rest refracts (importance: unscaled; radiance: 1/eta^2 entering, eta^2 leaving),
// and from inside beyond the critical angle everything is reflected. White rough glass never creates
// energy.
TEST(BsdfRoughDielectric, SmoothLimitAndEnergy) {
    const float ior = 1.5f;
    for (Microfacet d : {Microfacet::Beckmann, Microfacet::GGX}) {
        const Bsdf b = rough_dielectric(d, 1e-3f, 1e-3f, ior);
        for (float theta : {0.0f, 30.0f, 60.0f, 80.0f, 120.0f, 140.0f, 170.0f}) {
            SCOPED_TRACE(std::to_string(theta));
            const Vec3 wi = dir(theta, 20);
            const float F = fresnel_dielectric(wi.z, ior);
            const float eta = wi.z > 0 ? ior : 1 / ior;
            for (TransportMode mode : {TransportMode::Importance, TransportMode::Radiance}) {
                Rng rng(24, 1);
                double r = 0, t = 0;
                const int n = 20000;
                for (int i = 0; i < n; ++i) {
                    BsdfSample s;
                    if (!bsdf_sample(b, wi, next2(rng), rng.next_float(), &s, mode)) continue;
                    (s.wo.z * wi.z > 0 ? r : t) += average(s.weight) / n;
                }
                const double scale = mode == TransportMode::Radiance ? 1.0 / (eta * eta) : 1.0;
                EXPECT_NEAR(r, F, 0.01);
                EXPECT_NEAR(t, (1 - F) * scale, 0.01 * scale);
            }
        }
    }
    for (const Case& c : rough_dielectric_cases())
        for (float theta : {0.0f, 45.0f, 70.0f, 85.0f, 100.0f, 135.0f, 179.0f}) {
            SCOPED_TRACE(c.name + " theta_i=" + std::to_string(theta));
            Bsdf white = c.b;
            white.specular = white.transmittance = RGB(1);
            const Albedo a = albedo(white, dir(theta, 20), TransportMode::Importance, 100000);
            EXPECT_LE(a.mean, 1.0 + 4 * a.stderr_ + 1e-4);
            EXPECT_GT(a.mean, 0.6);
        }
}

// Glass is no cache's to guide (a map covers one hemisphere), and at the horizon, at grazing angles and
// at tiny roughness everything stays finite.
TEST(BsdfRoughDielectric, NotGuidableAndRobust) {
    std::vector<Case> cases = rough_dielectric_cases();
    for (Microfacet d : {Microfacet::Beckmann, Microfacet::GGX}) {
        cases.push_back({"tiny", rough_dielectric(d, 1e-7f, 1e-7f, 1.5f)});
        cases.push_back({"tiny_aniso", rough_dielectric(d, 1e-7f, 0.4f, 1.5f)});
        cases.push_back({"near_index_match", rough_dielectric(d, 0.2f, 0.2f, 1.001f)});
    }
    Rng rng(25, 1);
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        EXPECT_EQ(bsdf_guidable_share(c.b, dir(30, 0)), 0.0f);
        EXPECT_EQ(bsdf_guidable_pdf(c.b, dir(30, 0), dir(40, 180)), 0.0f);
        for (float z : {1.0f, 0.5f, 1e-2f, 1e-4f, 1e-7f, 0.0f, -1e-7f, -0.3f, -1.0f})
            for (int i = 0; i < 300; ++i) {
                const float p = 2 * kPi * rng.next_float(), r = std::sqrt(std::max(0.0f, 1 - z * z));
                const Vec3 wi(r * std::cos(p), r * std::sin(p), z);
                const Vec3 wo = i % 3 == 0 ? Vec3(-wi.x, -wi.y, wi.z) : i % 3 == 1 ? -wi : random_sphere(rng);
                for (TransportMode mode : {TransportMode::Importance, TransportMode::Radiance}) {
                    ASSERT_TRUE(finite_nonneg(bsdf_eval(c.b, wi, wo, mode))) << z;
                    BsdfSample s;
                    Vec2 u = next2(rng);
                    if (i < 4) u = {i & 1 ? 0.0f : 0x1.fffffep-1f, i & 2 ? 0.0f : 0x1.fffffep-1f};
                    if (bsdf_sample(c.b, wi, u, rng.next_float(), &s, mode)) {
                        ASSERT_TRUE(is_finite(s.wo) && finite_nonneg(s.weight) && std::isfinite(s.pdf) && s.pdf > 0)
                            << z << " pdf " << s.pdf;
                    }
                }
                const float pdf = bsdf_pdf(c.b, wi, wo);
                ASSERT_TRUE(std::isfinite(pdf) && pdf >= 0) << z;
            }
    }
}

TEST(BsdfConductor, MirrorWeightIsFresnel) {
    Bsdf b = conductor(kGoldEta, kGoldK, RGB(0.9f, 0.8f, 0.7f));
    EXPECT_TRUE(bsdf_is_delta(b));
    for (Vec3 wi : {dir(0, 0), dir(45, 10), dir(89.9f, 100)}) {
        BsdfSample s;
        ASSERT_TRUE(bsdf_sample(b, wi, {0.1f, 0.2f}, 0.3f, &s));
        EXPECT_TRUE(s.delta);
        EXPECT_EQ(s.pdf, 1.0f);
        EXPECT_NEAR(s.wo.x, -wi.x, 1e-7f);
        EXPECT_EQ(s.wo.z, wi.z);
        EXPECT_TRUE(rgb_near(s.weight, RGB(0.9f, 0.8f, 0.7f) * fresnel_conductor(wi.z, kGoldEta, kGoldK), 1e-6f));
        EXPECT_TRUE(is_black(bsdf_eval(b, wi, s.wo)));
        EXPECT_EQ(bsdf_pdf(b, wi, s.wo), 0.0f);
    }
    BsdfSample s;
    EXPECT_FALSE(bsdf_sample(b, dir(120, 0), {0.1f, 0.2f}, 0.3f, &s)) << "one-sided";
    b.two_sided = true;
    ASSERT_TRUE(bsdf_sample(b, dir(120, 0), {0.1f, 0.2f}, 0.3f, &s));
    EXPECT_LT(s.wo.z, 0);
    EXPECT_FALSE(bsdf_is_delta(diffuse(RGB(0.5f))));
    EXPECT_FALSE(bsdf_is_delta(plastic(1.5f, RGB(0.5f))));
}

// ---- model-specific reference values -------------------------------------------------------------------

TEST(BsdfPlastic, DeltaLobeAndDiffuseFormula) {
    Bsdf b = plastic(1.5f, {0.6f, 0.4f, 0.2f}, RGB(0.9f));
    Vec3 wi = dir(50, 30);
    const float Fi = fresnel_dielectric(wi.z, 1.5f);
    const float w = b.specular_sampling_weight;
    EXPECT_NEAR(w, luminance(RGB(0.9f)) / (luminance(RGB(0.9f)) + luminance({0.6f, 0.4f, 0.2f})), 1e-6f);
    const float ps = Fi * w / (Fi * w + (1 - Fi) * (1 - w));
    BsdfSample s;
    ASSERT_TRUE(bsdf_sample(b, wi, {0.2f, 0.7f}, ps * 0.99f, &s));
    EXPECT_TRUE(s.delta);
    EXPECT_NEAR(s.pdf, ps, 1e-6f);
    EXPECT_TRUE(rgb_near(s.weight, RGB(0.9f * Fi / ps), 1e-5f));
    EXPECT_NEAR(s.wo.z, wi.z, 1e-7f);
    // Diffuse part: diffuse / (1 - Fdr_int) (1 - Fi)(1 - Fo) / eta^2 cos_o / pi.
    Vec3 wo = dir(20, 250);
    const float Fo = fresnel_dielectric(wo.z, 1.5f), fdr = fresnel_diffuse_reflectance(1 / 1.5f);
    RGB expect = RGB(0.6f, 0.4f, 0.2f) / (1 - fdr) * ((1 - Fi) * (1 - Fo) / (1.5f * 1.5f) * wo.z * kInvPi);
    EXPECT_TRUE(rgb_near(bsdf_eval(b, wi, wo), expect, 1e-5f));
    EXPECT_NEAR(bsdf_pdf(b, wi, wo), (1 - ps) * wo.z * kInvPi, 1e-6f);
    // Nonlinear: per-channel 1 - diffuse * Fdr_int.
    b.nonlinear = true;
    RGB nl = bsdf_eval(b, wi, wo);
    EXPECT_NEAR(nl.r, 0.6f / (1 - 0.6f * fdr) * ((1 - Fi) * (1 - Fo) / 2.25f * wo.z * kInvPi), 1e-6f);
}

TEST(BsdfRoughDiffuse, OrenNayarReferenceValues) {
    const float alpha = 0.74f, rho = 0.7f;
    Bsdf b = rough_diffuse(RGB(rho), alpha);
    const float s2 = sqr(alpha / std::sqrt(2.0f));
    const float C1 = 1 - 0.5f * s2 / (s2 + 0.33f), C4 = 0.17f * s2 / (s2 + 0.13f);
    // Both at the pole: alpha = beta = 0, so f = (rho C1 + rho^2 C4) / pi.
    EXPECT_NEAR(bsdf_eval(b, dir(0, 0), dir(0, 0)).r, (rho * C1 + rho * rho * C4) / kPi, 1e-5f);
    // Normal incidence, 60 degrees out: beta = 0 kills C2 tan(beta) and C3; cos(phi) := 0 at the pole.
    Vec3 wo = dir(60, 77);
    EXPECT_NEAR(bsdf_eval(b, dir(0, 0), wo).g, (rho * C1 + rho * rho * C4) / kPi * wo.z, 1e-5f);
    // In-plane back-scattering (cos(phi) = 1) at 40/60 degrees, by the paper's formulas.
    {
        float ti = 40 * kPi / 180, to = 60 * kPi / 180, al = to, be = ti;
        float tmp = s2 / (s2 + 0.09f);
        float C2 = 0.45f * tmp * std::sin(al);
        float single = rho * (C1 + C2 * std::tan(be));
        float dbl = rho * rho * C4 * (1 - sqr(2 * be / kPi));
        EXPECT_NEAR(bsdf_eval(b, dir(40, 10), dir(60, 10)).b, (single + dbl) / kPi * std::cos(to), 1e-5f);
    }
    // sigma = 0 is Lambert.
    Bsdf l = rough_diffuse(RGB(rho), 0.0f);
    EXPECT_NEAR(bsdf_eval(l, dir(30, 0), dir(70, 190)).r, rho / kPi * std::cos(70 * kPi / 180), 1e-6f);
}

// Directional albedo of white Oren-Nayar (Mitsuba roughdiffuse, full model), against values computed
// independently from the paper's formulas (Oren & Nayar 1994, eqs. 30, 37, 38; double-precision
// midpoint quadrature, 700 x 1400 cells over the hemisphere, converged to ~1e-6). The model is a fit:
// it exceeds 1 at grazing incidence for rho = 1 and small sigma (1.028 at 85 degrees for alpha = 0.3),
// which is a property of the model (and of Mitsuba's images), not of this implementation.
TEST(BsdfRoughDiffuse, AlbedoMatchesOrenNayarPaper) {
    struct Ref {
        float alpha, theta;
        double albedo;
    };
    for (Ref r : {Ref{0.3f, 0, 0.98372}, Ref{0.3f, 45, 0.98905}, Ref{0.3f, 70, 1.00666}, Ref{0.3f, 85, 1.02804},
                  Ref{0.74f, 0, 0.88854}, Ref{0.74f, 45, 0.90058}, Ref{0.74f, 70, 0.94034}, Ref{0.74f, 85, 0.98861}}) {
        Albedo a = albedo(rough_diffuse(RGB(1), r.alpha), dir(r.theta, 20));
        EXPECT_NEAR(a.mean, r.albedo, 4 * a.stderr_ + 2e-4) << "alpha " << r.alpha << " theta " << r.theta;
    }
}

TEST(BsdfWard, BalancedPeakValue) {
    // At the mirror direction h = n: balanced f_s = |h|^2 / (pi ax ay hz^4) with h = wi + wo unnormalised.
    Bsdf b = ward(WardVariant::Balanced, 0.2f, 0.3f, RGB(0.25f), RGB(0.5f));
    Vec3 wi = dir(30, 0), wo = dir(30, 180);
    double hz = 2 * std::cos(30 * kPi / 180);
    double fs = (hz * hz) / (M_PI * 0.2 * 0.3 * std::pow(hz, 4));
    EXPECT_NEAR(bsdf_eval(b, wi, wo).r, (0.5 * fs + 0.25 / M_PI) * wo.z, 1e-5);
    b.ward_variant = WardVariant::Ward;
    fs = 1 / (4 * M_PI * 0.2 * 0.3 * std::sqrt(wi.z * wo.z));
    EXPECT_NEAR(bsdf_eval(b, wi, wo).r, (0.5 * fs + 0.25 / M_PI) * wo.z, 1e-5);
    b.ward_variant = WardVariant::WardDuer;
    fs = 1 / (4 * M_PI * 0.2 * 0.3 * wi.z * wo.z);
    EXPECT_NEAR(bsdf_eval(b, wi, wo).r, (0.5 * fs + 0.25 / M_PI) * wo.z, 1e-5);
}

TEST(BsdfRoughConductor, MatchesTorranceSparrow) {
    Bsdf b = rough_conductor(Microfacet::GGX, 0.3f, 0.3f, kGoldEta, kGoldK, RGB(0.9f));
    Vec3 wi = dir(35, 20), wo = dir(50, 170);
    Vec3 h = normalize(wi + wo);
    MicrofacetDistribution d(Microfacet::GGX, 0.3f, 0.3f);
    float D = microfacet_d(d, h);
    // GGX closed forms.
    float c2 = h.z * h.z, t2 = (1 - c2) / c2;
    EXPECT_NEAR(D, 1 / (kPi * 0.09f * c2 * c2 * sqr(1 + t2 / 0.09f)), 1e-4f * D);
    auto g1 = [](Vec3 v) { return 2 / (1 + std::sqrt(1 + 0.09f * (1 - v.z * v.z) / (v.z * v.z))); };
    RGB F = fresnel_conductor(dot(wi, h), kGoldEta, kGoldK);
    RGB expect = RGB(0.9f) * F * (D * g1(wi) * g1(wo) / (4 * wi.z * wo.z) * wo.z);
    EXPECT_TRUE(rgb_near(bsdf_eval(b, wi, wo), expect, 1e-4f));
}

// ---- microfacet distributions -------------------------------------------------------------------------

// Projected-area normalisation, and the visible-normal identity that ties Lambda to D exactly:
// integral of G1(v,m) max(0, v.m) D(m) dm = v.z, i.e. the VNDF integrates to one.
TEST(BsdfMicrofacet, NormalisationAndVisibleNormalsIntegrateToOne) {
    for (Microfacet t : {Microfacet::Beckmann, Microfacet::GGX})
        for (auto [ax, ay] : {std::pair{0.1f, 0.1f}, {0.5f, 0.5f}, {0.05f, 0.3f}, {1.0f, 0.6f}}) {
            MicrofacetDistribution d(t, ax, ay);
            SCOPED_TRACE(std::string(t == Microfacet::GGX ? "ggx " : "beckmann ") + std::to_string(ax) + " " +
                         std::to_string(ay));
            const Vec3 n(0, 0, 1);
            double proj = test::integrate_sphere_peaked(
                [&](Vec3 m) { return microfacet_d(d, m) * std::max(0.0f, m.z); }, n);
            EXPECT_NEAR(proj, 1.0, 1e-3);
            for (Vec3 v : {dir(0, 0), dir(45, 30), dir(80, 100), dir(88, -20)}) {
                double vis = test::integrate_sphere_peaked([&](Vec3 m) { return microfacet_pdf_visible(d, v, m); }, n);
                EXPECT_NEAR(vis, 1.0, 1e-3) << "theta_v " << std::acos(v.z) * 180 / kPi;
            }
        }
}

TEST(BsdfMicrofacet, VisibleSamplesAreVisibleAndFinite) {
    Rng rng(17, 1);
    for (Microfacet t : {Microfacet::Beckmann, Microfacet::GGX})
        for (float a : {1e-6f, 1e-4f, 0.01f, 0.3f, 1.5f}) {
            MicrofacetDistribution d(t, a, a * 0.5f);
            for (int i = 0; i < 5000; ++i) {
                Vec3 v = random_upper(rng);
                Vec2 u = next2(rng);
                if (i < 4) u = {i & 1 ? 0.0f : 0x1.fffffep-1f, i & 2 ? 0.0f : 0x1.fffffep-1f};  // corners
                Vec3 m = microfacet_sample_visible(d, v, u);
                ASSERT_TRUE(is_finite(m)) << a;
                ASSERT_NEAR(length(m), 1.0f, 1e-5f);
                ASSERT_GE(m.z, 0.0f);
                ASSERT_GE(dot(m, v), -1e-5f) << "a back-facing normal is never visible";
            }
        }
}

// ---- two-sided and robustness ------------------------------------------------------------------------------

TEST(BsdfTwoSided, BackSideMirrorsFrontSide) {
    for (Case c : nondelta_cases()) {
        SCOPED_TRACE(c.name);
        c.b.two_sided = true;
        Rng rng(18, 1);
        for (int i = 0; i < 500; ++i) {
            Vec3 wi = random_upper(rng), wo = random_upper(rng);
            Vec3 wib(wi.x, wi.y, -wi.z), wob(wo.x, wo.y, -wo.z);
            EXPECT_TRUE(rgb_near(bsdf_eval(c.b, wib, wob), bsdf_eval(c.b, wi, wo), 1e-6f));
            EXPECT_EQ(bsdf_pdf(c.b, wib, wob), bsdf_pdf(c.b, wi, wo));
            EXPECT_TRUE(is_black(bsdf_eval(c.b, wib, wo))) << "still no transmission";
            Vec2 u = next2(rng);
            float uc = rng.next_float();
            BsdfSample f, bk;
            bool okf = bsdf_sample(c.b, wi, u, uc, &f), okb = bsdf_sample(c.b, wib, u, uc, &bk);
            ASSERT_EQ(okf, okb);
            if (!okf) continue;
            EXPECT_EQ(bk.wo.z, -f.wo.z);
            EXPECT_EQ(bk.wo.x, f.wo.x);
            EXPECT_TRUE(rgb_near(bk.weight, f.weight, 1e-6f));
        }
    }
}

TEST(BsdfRobustness, GrazingTinyAlphaAndIndexMatchedAreFinite) {
    std::vector<Case> cases = nondelta_cases();
    for (Microfacet d : {Microfacet::Beckmann, Microfacet::GGX}) {
        cases.push_back({"roughconductor_tiny", rough_conductor(d, 1e-7f, 1e-7f)});
        cases.push_back({"roughconductor_tiny_aniso", rough_conductor(d, 1e-7f, 0.3f)});
        cases.push_back({"roughplastic_tiny", rough_plastic(d, 0.0f, 1.5f, RGB(0.5f))});
        cases.push_back({"roughplastic_ior1", rough_plastic(d, 0.2f, 1.0f, RGB(0.5f))});
    }
    cases.push_back({"plastic_ior1", plastic(1.0f, RGB(0.5f)), true});
    cases.push_back({"plastic_black_diffuse", plastic(1.5f, RGB(0.0f)), true});
    cases.push_back({"plastic_black_both", plastic(1.5f, RGB(0.0f), RGB(0.0f)), true});
    for (WardVariant v : {WardVariant::Ward, WardVariant::WardDuer, WardVariant::Balanced})
        cases.push_back({"ward_tiny", ward(v, 1e-6f, 1e-6f, RGB(0.2f), RGB(0.5f))});
    cases.push_back({"dielectric", dielectric(1.5f), true});
    cases.push_back({"dielectric_ior1", dielectric(1.0f), true});
    cases.push_back({"thin_dielectric", thin_dielectric(1.5f), true});
    cases.push_back({"thin_dielectric_ior1", thin_dielectric(1.0f), true});
    cases.push_back({"conductor", conductor(kGoldEta, kGoldK), true});
    Rng rng(19, 1);
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        for (float z : {1.0f, 0.5f, 1e-2f, 1e-4f, 1e-7f, 0.0f, -1e-7f, -0.3f})
            for (int i = 0; i < 300; ++i) {
                float p = 2 * kPi * rng.next_float(), r = std::sqrt(std::max(0.0f, 1 - z * z));
                Vec3 wi(r * std::cos(p), r * std::sin(p), z);
                Vec3 wo = i % 2 ? random_upper(rng) : Vec3(-wi.x, -wi.y, wi.z);  // incl. the mirror direction
                RGB f = bsdf_eval(c.b, wi, wo);
                float pdf = bsdf_pdf(c.b, wi, wo);
                ASSERT_TRUE(finite_nonneg(f)) << z;
                ASSERT_TRUE(std::isfinite(pdf) && pdf >= 0) << z;
                BsdfSample s;
                Vec2 u = next2(rng);
                if (i < 4) u = {i & 1 ? 0.0f : 0x1.fffffep-1f, i & 2 ? 0.0f : 0x1.fffffep-1f};
                if (bsdf_sample(c.b, wi, u, rng.next_float(), &s)) {
                    ASSERT_TRUE(is_finite(s.wo) && finite_nonneg(s.weight) && std::isfinite(s.pdf) && s.pdf > 0)
                        << z << " pdf " << s.pdf;
                }
            }
    }
}

}  // namespace
}  // namespace iris
