// Chi-square tests of bsdf_sample() against bsdf_pdf() for every BSDF with a continuous lobe, at
// normal, oblique (45 degrees) and grazing (80 degrees) incidence (rough glass also from inside) and
// several roughnesses. Delta samples (plastic's specular reflection) are flagged discrete: the histogram covers the continuous
// part only, which is what pdf() describes. The significance level is Sidak-corrected over all the
// configurations below, so the suite as a whole has a 1 % false-alarm rate. Deterministic (seeded).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "libcommon/bsdf.h"
#include "libcommon/rng.h"
#include "support/chi2.h"

namespace iris {
namespace {

struct Config {
    std::string name;
    Bsdf b;
    Vec3 wi;
    bool peaky = false;  // narrow lobe: use a finer grid
};

Vec3 dir(float theta_deg, float phi_deg) {
    float t = theta_deg * kPi / 180, p = phi_deg * kPi / 180;
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

std::string fmt(float v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    std::string s = buf;
    for (char& c : s)
        if (c == '.') c = 'p';
    return s;
}

std::vector<Config> configs() {
    const RGB col{0.8f, 0.5f, 0.2f};
    std::vector<std::pair<std::string, Bsdf>> models;
    std::vector<bool> peaky;
    auto add = [&](std::string name, Bsdf b, bool narrow = false) {
        bsdf_prepare(b);
        models.push_back({std::move(name), b});
        peaky.push_back(narrow);
    };
    {
        Bsdf b;
        b.type = BsdfType::Diffuse;
        b.diffuse = col;
        add("diffuse", b);
    }
    for (float a : {0.3f, 0.74f}) {
        Bsdf b;
        b.type = BsdfType::RoughDiffuse;
        b.diffuse = col;
        b.alpha_u = b.alpha_v = a;
        add("roughdiffuse_a" + fmt(a), b);
    }
    for (Microfacet d : {Microfacet::Beckmann, Microfacet::GGX}) {
        const std::string dn = d == Microfacet::Beckmann ? "beckmann" : "ggx";
        for (auto [au, av] : {std::pair{0.05f, 0.05f}, {0.2f, 0.2f}, {0.6f, 0.6f}, {0.05f, 0.3f}, {0.3f, 0.8f}}) {
            Bsdf b;
            b.type = BsdfType::RoughConductor;
            b.distribution = d;
            b.alpha_u = au;
            b.alpha_v = av;
            b.eta = {0.143f, 0.374f, 1.442f};
            b.k = {3.983f, 2.385f, 1.603f};
            add("roughconductor_" + dn + "_" + fmt(au) + "_" + fmt(av), b, std::min(au, av) < 0.1f);
        }
        for (float a : {0.05f, 0.2f, 0.5f}) {
            Bsdf b;
            b.type = BsdfType::RoughPlastic;
            b.distribution = d;
            b.alpha_u = b.alpha_v = a;
            b.ior = 1.5f;
            b.diffuse = col;
            add("roughplastic_" + dn + "_" + fmt(a), b, a < 0.1f);
        }
    }
    {
        Bsdf b;
        b.type = BsdfType::Plastic;
        b.ior = 1.5f;
        b.diffuse = col;
        add("plastic", b);
        b.ior = 2.0f;
        b.diffuse = {0.07f, 0.09f, 0.13f};
        b.nonlinear = true;
        add("plastic_dark_nonlinear", b);
    }
    for (WardVariant v : {WardVariant::Ward, WardVariant::WardDuer, WardVariant::Balanced}) {
        const std::string vn = v == WardVariant::Ward ? "ward" : v == WardVariant::WardDuer ? "wardduer" : "balanced";
        for (auto [au, av] : {std::pair{0.1f, 0.1f}, {0.4f, 0.4f}, {0.1f, 0.4f}}) {
            Bsdf b;
            b.type = BsdfType::Ward;
            b.ward_variant = v;
            b.alpha_u = au;
            b.alpha_v = av;
            b.diffuse = RGB(0.2f);
            b.specular = col;
            add(vn + "_" + fmt(au) + "_" + fmt(av), b);
        }
    }
    // Three incident directions; azimuths off the axes so that anisotropic lobes are tilted.
    const std::pair<const char*, Vec3> incident[] = {{"normal", dir(0, 0)}, {"45deg", dir(45, 30)},
                                                      {"80deg", dir(80, -60)}};
    std::vector<Config> out;
    for (size_t i = 0; i < models.size(); ++i)
        for (auto& [in, wi] : incident) out.push_back({models[i].first + "_" + in, models[i].second, wi, peaky[i]});
    // Rough glass reflects and refracts over the whole sphere, from either side: from inside also beyond
    // the critical angle (41.8 degrees for 1.5), where the smooth interface reflects everything.
    const std::pair<const char*, Vec3> both_sides[] = {{"normal", dir(0, 0)},      {"45deg", dir(45, 30)},
                                                        {"80deg", dir(80, -60)},    {"inside30deg", dir(150, 70)},
                                                        {"inside60deg", dir(120, -20)}};
    for (Microfacet d : {Microfacet::Beckmann, Microfacet::GGX}) {
        const std::string dn = d == Microfacet::Beckmann ? "beckmann" : "ggx";
        for (auto [au, av] : {std::pair{0.05f, 0.05f}, {0.3f, 0.3f}, {0.1f, 0.5f}}) {
            Bsdf b;
            b.type = BsdfType::RoughDielectric;
            b.distribution = d;
            b.alpha_u = au;
            b.alpha_v = av;
            b.ior = 1.5f;
            bsdf_prepare(b);
            for (auto& [in, wi] : both_sides)
                out.push_back({"roughdielectric_" + dn + "_" + fmt(au) + "_" + fmt(av) + "_" + in, b, wi, au < 0.1f});
        }
    }
    return out;
}

const std::vector<Config>& all_configs() {
    static const std::vector<Config> c = configs();
    return c;
}

test::Chi2Result run(const Bsdf& b, Vec3 wi, const Bsdf& pdf_bsdf, bool peaky, int test_count, uint64_t seed) {
    test::Chi2Options o;
    o.samples = 300000;
    o.theta_bins = peaky ? 80 : 40;
    o.phi_bins = peaky ? 160 : 80;
    o.quadrature = 4;
    o.test_count = test_count;
    o.seed = seed;
    auto sampler = [&](Rng& rng) {
        test::DirSample d;
        Vec2 u{rng.next_float(), rng.next_float()};
        float uc = rng.next_float();
        BsdfSample s;
        if (bsdf_sample(b, wi, u, uc, &s)) {
            d.w = s.wo;
            d.valid = true;
            d.discrete = s.delta;
        }
        return d;
    };
    auto pdf = [&](Vec3 w) { return double(bsdf_pdf(pdf_bsdf, wi, w)); };
    return test::chi2_test_sphere(sampler, pdf, o);
}

class BsdfChi2 : public ::testing::TestWithParam<size_t> {};

TEST_P(BsdfChi2, SampleMatchesPdf) {
    const Config& c = all_configs()[GetParam()];
    test::Chi2Result r = run(c.b, c.wi, c.b, c.peaky, int(all_configs().size()), 1000 + GetParam());
    RecordProperty("p_value", std::to_string(r.p_value));
    if (std::getenv("IRIS_CHI2_VERBOSE")) std::printf("%s: %s", c.name.c_str(), r.log.c_str());
    EXPECT_TRUE(r.passed) << c.name << "\n" << r.log;
}

INSTANTIATE_TEST_SUITE_P(All, BsdfChi2, ::testing::Range<size_t>(0, all_configs().size()),
                         [](const ::testing::TestParamInfo<size_t>& info) { return all_configs()[info.param].name; });

// Power check: the test must reject a density that is only slightly wrong (alpha off by 5 %), or the
// passes above would mean little.
TEST(BsdfChi2Power, RejectsSlightlyWrongPdf) {
    Bsdf b;
    b.type = BsdfType::RoughConductor;
    b.distribution = Microfacet::Beckmann;
    b.alpha_u = b.alpha_v = 0.2f;
    bsdf_prepare(b);
    Bsdf wrong = b;
    wrong.alpha_u = wrong.alpha_v = 0.21f;
    test::Chi2Result r = run(b, dir(45, 30), wrong, false, 1, 99);
    EXPECT_FALSE(r.passed) << r.log;
    EXPECT_LT(r.p_value, 1e-6) << r.log;
}

}  // namespace
}  // namespace iris
