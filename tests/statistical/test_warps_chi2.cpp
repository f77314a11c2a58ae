// Chi-square goodness of fit of the direction warps against their PDFs (tests/support/chi2.h).
// The significance level is Sidak-corrected over the kWarpChi2Tests tests of this file.
//
// Narrow cones would fall inside one or two cells of the chi-square grid, so they are tested through
// a "cap zoom": a fixed bijection that stretches the cap 1 - cos(theta) <= cap around +z linearly in
// 1 - cos(theta) onto the whole sphere (azimuth unchanged). Solid angle scales by 2/cap, so the
// zoomed density is pdf * cap/2. The cap is chosen so the cone's rim lands exactly on a cell edge,
// where the midpoint quadrature of the expected counts is exact.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "libcommon/sampling.h"
#include "support/chi2.h"

namespace iris {
namespace {

constexpr int kWarpChi2Tests = 6;

test::Chi2Options options() {
    test::Chi2Options o;
    o.test_count = kWarpChi2Tests;
    o.samples = 1000000;
    return o;
}

struct CapZoom {
    double cap;  // 1 - cos(theta) of the cap that fills the sphere
    // Zoomed image of w; false if w lies outside the cap.
    bool forward(Vec3 w, Vec3* out) const {
        double t = double(one_minus_cos_theta(w));  // accurate near the pole, where float z is not
        if (t > cap) return false;
        double tz = 2.0 * t / cap;
        double s = std::sqrt(std::max(0.0, tz * (2.0 - tz)));
        double phi = std::atan2(double(w.y), double(w.x));
        *out = Vec3(float(s * std::cos(phi)), float(s * std::sin(phi)), float(1.0 - tz));
        return true;
    }
    // 1 - cos(theta) of the original direction of a zoomed direction.
    double original_one_minus_cos(Vec3 wz) const { return (1.0 - double(wz.z)) * cap / 2.0; }
    double density_scale() const { return cap / 2.0; }
};

// The summary line (statistic, dof, p-value) is printed for every test, the cell table on failure.
void expect_pass(const test::Chi2Result& r) {
    std::printf("    %s", r.log.substr(0, r.log.find('\n') + 1).c_str());
    EXPECT_TRUE(r.passed) << r.log;
}

TEST(WarpChi2, UniformSphere) {
    expect_pass(test::chi2_test_sphere(
        [](Rng& rng) { return test::DirSample{sample_uniform_sphere({rng.next_float(), rng.next_float()}), true}; },
        [](Vec3) { return double(uniform_sphere_pdf()); }, options()));
}

TEST(WarpChi2, UniformHemisphere) {
    expect_pass(test::chi2_test_sphere(
        [](Rng& rng) {
            return test::DirSample{sample_uniform_hemisphere({rng.next_float(), rng.next_float()}), true};
        },
        [](Vec3 w) { return w.z > 0 ? double(uniform_hemisphere_pdf()) : 0.0; }, options()));
}

TEST(WarpChi2, CosineHemisphere) {
    auto o = options();
    expect_pass(test::chi2_test_sphere(
        [](Rng& rng) {
            return test::DirSample{sample_cosine_hemisphere({rng.next_float(), rng.next_float()}), true};
        },
        [](Vec3 w) { return double(cosine_hemisphere_pdf(w.z)); }, o));
}

TEST(WarpChi2, UniformConeWide) {
    const float cos_max = 0.2f;  // a cell edge of the 10 theta bins (z = 1 - 2j/10)
    expect_pass(test::chi2_test_sphere(
        [&](Rng& rng) {
            return test::DirSample{sample_uniform_cone({rng.next_float(), rng.next_float()}, cos_max), true};
        },
        [&](Vec3 w) { return w.z >= cos_max ? double(uniform_cone_pdf(cos_max)) : 0.0; }, options()));
}

// A narrow cone through the cap zoom; the rim maps to z = -0.6, the edge after 8 of 10 theta bins.
// Zoomed directions are a function of u alone, so the two narrow-cone tests take different seeds.
void narrow_cone_test(float omc, const std::function<Vec3(Vec2)>& sample, double pdf_value, uint64_t seed) {
    CapZoom zoom{double(omc) / 0.8};
    long long outside = 0;
    auto r = test::chi2_test_sphere(
        [&](Rng& rng) {
            Vec3 w = sample({rng.next_float(), rng.next_float()}), wz;
            if (!zoom.forward(w, &wz)) {
                ++outside;
                return test::DirSample{};
            }
            return test::DirSample{wz, true};
        },
        [&](Vec3 wz) {
            return zoom.original_one_minus_cos(wz) <= double(omc) ? pdf_value * zoom.density_scale() : 0.0;
        },
        [&] {
            auto o = options();
            o.seed = seed;
            return o;
        }());
    EXPECT_EQ(outside, 0) << "samples outside the cone";
    expect_pass(r);
}

TEST(WarpChi2, UniformConeNarrow) {
    const float cos_max = 0.999f;
    const float omc = 1.0f - cos_max;  // exact in float (Sterbenz), the value the warp uses
    narrow_cone_test(omc, [&](Vec2 u) { return sample_uniform_cone(u, cos_max); }, uniform_cone_pdf(cos_max), 201);
}

TEST(WarpChi2, UniformConeTinyOneMinusCos) {
    const float omc = 2.5e-6f;  // a 0.0333-radius sphere seen from 15 units
    narrow_cone_test(omc, [&](Vec2 u) { return sample_uniform_cone(u, OneMinusCos{omc}); },
                     uniform_cone_pdf(OneMinusCos{omc}), 202);
}

}  // namespace
}  // namespace iris
