// Chi-square tests of the cache sampler (SphereDistribution::sample) against its density
// (SphereDistribution::pdf), DESIGN.md §4.1 "proven by chi-square tests". Seeded and deterministic.
//
// Two kinds of test, Sidak-corrected together (kTests):
//  - direction histograms on the helper's cos(theta) x phi cells (tests/support/chi2.h): checks the
//    whole chain — texel choice, placement inside the texel, the equal-area map — against pdf();
//  - texel histograms against the pmf, with exactly known expectations: a sharper check of the texel
//    choice that does not depend on the helper's quadrature.
//
// The pdf is piecewise constant with jumps along texel edges, which cut the helper's cells along
// curves; the helper's adaptive quadrature refines the cells that straddle them (at most
// quad_max_depth levels), which keeps the expected counts accurate to well under their statistical
// resolution (1e6 samples over 200 cells: ~1.4 % per cell).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "libcommon/rng.h"
#include "libcommon/spheremap.h"
#include "support/chi2.h"

namespace iris {
namespace {

constexpr int kTests = 8;  // all chi-square tests in this file, for the Sidak correction

Vec3 uniform_direction(Rng& rng) {
    double z = 1.0 - 2.0 * rng.next_double(), phi = 2.0 * M_PI * rng.next_double();
    double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return normalize(Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)));
}

// Peaky map as fill-caches makes them: clusters of photon splats, Gaussian filter, floor.
SphereMap peaky_map(int R, uint64_t seed, float sigma, float floor) {
    SphereMap m(R);
    Rng rng(seed, 23);
    for (int c = 0; c < 4; ++c) {
        Vec3 centre = uniform_direction(rng);
        float spread = 0.05f + 0.2f * rng.next_float();
        for (int p = 0; p < 500; ++p) {
            Vec3 w = normalize(centre + spread * Vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f,
                                                      rng.next_float() - 0.5f));
            m.splat(w, 1.0f + 4.0f * c);
        }
    }
    m.splat({0, 0, -1}, 100.0f);  // a peak at the -z pole, where the square's corners meet
    m.splat({0, 1, 0}, 50.0f);    // and one on the border fold (+y, the top edge's midpoint)
    m.gaussian_filter(sigma);
    m.normalise_floor(floor);
    return m;
}

SphereMap random_map(int R, uint64_t seed) {
    SphereMap m(R);
    Rng rng(seed, 29);
    for (int k = 0; k < m.size(); ++k) m[k] = rng.next_float() * rng.next_float();
    m.normalise_floor(0.05f);
    return m;
}

test::Chi2Result run_direction_chi2(const SphereDistribution& d, uint64_t seed) {
    test::Chi2Options o;
    o.theta_bins = 10;
    o.phi_bins = 20;
    o.samples = 1000000;
    o.test_count = kTests;
    o.seed = seed;
    return test::chi2_test_sphere(
        [&](Rng& rng) {
            test::DirSample s;
            float p = 0;
            s.w = d.sample({rng.next_float(), rng.next_float()}, &p);
            s.valid = p > 0;
            return s;
        },
        [&](Vec3 w) { return double(d.pdf(w)); }, o);
}

// Texel histogram against the pmf (exact expectations), cells with expectation < 5 pooled.
test::Chi2Result run_texel_chi2(const SphereDistribution& d, long long samples, uint64_t seed) {
    const int n = d.size();
    std::vector<double> observed(size_t(n), 0.0);
    Rng rng(seed, 31);
    for (long long i = 0; i < samples; ++i) {
        Vec3 w = d.sample({rng.next_float(), rng.next_float()}, nullptr);
        observed[size_t(sphere_texel_of(w, d.resolution()))] += 1;
    }
    double stat = 0, pool_obs = 0, pool_exp = 0;
    int bins = 0;
    for (int k = 0; k < n; ++k) {
        double e = double(d.pmf(k)) * double(samples);
        if (e < 5) {
            pool_obs += observed[size_t(k)];
            pool_exp += e;
            continue;
        }
        stat += (observed[size_t(k)] - e) * (observed[size_t(k)] - e) / e;
        ++bins;
    }
    if (pool_exp >= 5) {
        stat += (pool_obs - pool_exp) * (pool_obs - pool_exp) / pool_exp;
        ++bins;
    }
    test::Chi2Result r;
    r.dof = std::max(1, bins - 1);
    r.statistic = stat;
    r.p_value = test::gamma_q(r.dof / 2.0, stat / 2.0);
    r.passed = r.p_value > 1.0 - std::pow(1.0 - 0.01, 1.0 / kTests);
    r.log = "texel chi2 = " + std::to_string(stat) + ", dof = " + std::to_string(r.dof) +
            ", p = " + std::to_string(r.p_value) + "\n";
    return r;
}

// One summary line per test (the full table only on failure).
void report(const test::Chi2Result& r) {
    std::printf("    %s", r.log.substr(0, r.log.find('\n') + 1).c_str());
    EXPECT_TRUE(r.passed) << r.log;
}

TEST(SphereMapChi2, PeakyR16) {
    SphereDistribution d(peaky_map(16, 1, 0.1f, 0.02f));
    auto r = run_direction_chi2(d, 101);
    report(r);
}

TEST(SphereMapChi2, PeakyR32) {
    SphereDistribution d(peaky_map(32, 2, 0.05f, 0.01f));
    auto r = run_direction_chi2(d, 102);
    report(r);
}

TEST(SphereMapChi2, UniformR4) {
    SphereMap m(4);
    m.normalise_floor(0.0f);
    SphereDistribution d(m);
    auto r = run_direction_chi2(d, 103);
    report(r);
}

TEST(SphereMapChi2, RandomR4) {
    SphereDistribution d(random_map(4, 4));
    auto r = run_direction_chi2(d, 104);
    report(r);
}

TEST(SphereMapChi2, RandomR3OddResolution) {
    SphereDistribution d(random_map(3, 5));
    auto r = run_direction_chi2(d, 105);
    report(r);
}

TEST(SphereMapChi2, TexelHistogramPeakyR16) {
    SphereDistribution d(peaky_map(16, 6, 0.1f, 0.02f));
    auto r = run_texel_chi2(d, 2000000, 106);
    report(r);
}

TEST(SphereMapChi2, TexelHistogramPeakyR64) {
    SphereDistribution d(peaky_map(64, 7, 0.04f, 0.01f));
    auto r = run_texel_chi2(d, 4000000, 107);
    report(r);
}

TEST(SphereMapChi2, TexelHistogramRandomR32) {
    SphereDistribution d(random_map(32, 8));
    auto r = run_texel_chi2(d, 2000000, 108);
    report(r);
}

}  // namespace
}  // namespace iris
