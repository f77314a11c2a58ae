// Chi-square tests of bsdf_sample() against bsdf_pdf() for phong, mixturebsdf and blendbsdf
// (test_bsdf_chi2.cpp's method: Dirac samples flagged discrete, the histogram covers the continuous
// part; Sidak-corrected over this file's configurations; seeded), plus the guided half of the
// contract: samples drawn with uc in [1 - share, 1) against bsdf_guidable_pdf / share.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <string>
#include <vector>

#include "libcommon/bsdf.h"
#include "libcommon/rng.h"
#include "support/chi2.h"
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

Bsdf simple(BsdfType t, float alpha = 0.2f, RGB rho = RGB(0.5f)) {
    Bsdf b;
    b.type = t;
    b.diffuse = rho;
    b.alpha_u = b.alpha_v = alpha;
    b.eta = {0.155f, 0.117f, 0.138f};
    b.k = {4.83f, 3.12f, 2.15f};
    b.ior = 1.5f;
    return b;
}

struct Config {
    std::string name;
    Bsdf b;
    Vec3 wi;
    bool peaky = false;
    bool guided = false;  // sample only the replaceable share; compare with guidable_pdf / share
};

std::vector<Config> configs() {
    const RGB col{0.8f, 0.5f, 0.2f};
    struct Model {
        std::string name;
        Bsdf b;
        bool peaky, both_sides;
    };
    std::vector<Model> m = {
        {"phong_n5", phong(RGB(0.4f), RGB(0.4f), 5), false, false},
        {"phong_n60", phong(RGB(0.3f), RGB(0.5f), 60), false, false},
        {"phong_n600_specular_only", phong(RGB(0), RGB(0.3f), 600), true, false},
        {"mixture_mirror_diffuse", mix({{1, simple(BsdfType::Conductor)}, {1, simple(BsdfType::Diffuse, 0, RGB(0.99f))}}), false, false},
        {"mixture_three", mix({{0.2f, simple(BsdfType::RoughConductor, 0.3f)}, {0.5f, simple(BsdfType::Diffuse, 0, col)},
                               {0.3f, phong(RGB(0.1f), RGB(0.5f), 40)}}), false, false},
        {"blend_diffuse_roughglass", mix({{0.7f, simple(BsdfType::Diffuse)}, {0.3f, simple(BsdfType::RoughDielectric, 0.3f)}}), false, true},
        {"blend_diffuse_roughconductor", mix({{0.7f, simple(BsdfType::Diffuse, 0, RGB(0.05f))}, {0.3f, simple(BsdfType::RoughConductor, 0.2f)}}),
         false, false},
        {"mixture_nested", mix({{0.5f, mix({{1, simple(BsdfType::Conductor)}, {1, phong(col, RGB(0.1f), 10)}})},
                                {0.5f, simple(BsdfType::RoughPlastic, 0.15f)}}), false, false},
    };
    const std::pair<const char*, Vec3> front[] = {{"normal", dir(0, 0)}, {"45deg", dir(45, 30)}, {"80deg", dir(80, -60)}};
    const std::pair<const char*, Vec3> back[] = {{"inside30deg", dir(150, 70)}, {"inside60deg", dir(120, -20)}};
    std::vector<Config> out;
    for (const Model& x : m) {
        for (auto& [in, wi] : front) {
            out.push_back({x.name + "_" + in, x.b, wi, x.peaky});
            if (x.b.type == BsdfType::Mixture) out.push_back({x.name + "_" + in + "_guided", x.b, wi, x.peaky, true});
        }
        if (x.both_sides)
            for (auto& [in, wi] : back) out.push_back({x.name + "_" + in, x.b, wi, x.peaky});
    }
    return out;
}
const std::vector<Config>& all_configs() {
    static const std::vector<Config> c = configs();
    return c;
}

class MixtureChi2 : public ::testing::TestWithParam<size_t> {};

TEST_P(MixtureChi2, SampleMatchesPdf) {
    const Config& c = all_configs()[GetParam()];
    test::Chi2Options o;
    o.samples = 300000;
    o.theta_bins = c.peaky ? 80 : 40;
    o.phi_bins = c.peaky ? 160 : 80;
    o.quadrature = 4;
    o.test_count = int(all_configs().size());
    o.seed = 3000 + GetParam();
    const float g = bsdf_guidable_share(c.b, c.wi);
    if (c.guided) {
        ASSERT_GT(g, 0.0f);
    }
    auto sampler = [&](Rng& rng) {
        test::DirSample d;
        const Vec2 u{rng.next_float(), rng.next_float()};
        float uc = rng.next_float();
        if (c.guided) uc = std::min((1 - g) + g * uc, 0x1.fffffep-1f);
        BsdfSample s;
        if (bsdf_sample(c.b, c.wi, u, uc, &s)) {
            d.w = s.wo;
            d.valid = true;
            d.discrete = s.delta;
        }
        return d;
    };
    auto pdf = [&](Vec3 w) {
        return c.guided ? double(bsdf_guidable_pdf(c.b, c.wi, w)) / g : double(bsdf_pdf(c.b, c.wi, w));
    };
    test::Chi2Result r = test::chi2_test_sphere(sampler, pdf, o);
    if (std::getenv("IRIS_CHI2_VERBOSE")) std::printf("%s: %s", c.name.c_str(), r.log.c_str());
    EXPECT_TRUE(r.passed) << c.name << "\n" << r.log;
}

INSTANTIATE_TEST_SUITE_P(All, MixtureChi2, ::testing::Range<size_t>(0, all_configs().size()),
                         [](const ::testing::TestParamInfo<size_t>& info) { return all_configs()[info.param].name; });

}  // namespace
}  // namespace iris
