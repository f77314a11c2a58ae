// Exact checks of the warps and of Distribution1D (STYLE.md habit 7): sample -> invert round trips,
// inverses at the domain edges, PDFs that integrate to one, PDFs that equal the inverse Jacobian
// determinant of the map, a discrete distribution whose choices match its pmf, and the stratification
// and uniformity of the scrambled Sobol points.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <vector>

#include "libcommon/rng.h"
#include "libcommon/sampling.h"
#include "support/chi2.h"

namespace iris {
namespace {

constexpr float kOneMinusEps = 0x1.fffffep-1f;

// Distance between two values of a periodic coordinate in [0, 1).
double wrap_dist(double a, double b) {
    double d = std::abs(a - b);
    return std::min(d, 1.0 - d);
}

// u values that include both ends of [0, 1) and a few interior ones.
std::vector<float> edge_and_interior_values() {
    return {0.0f, 1e-7f, 1e-4f, 0.1f, 0.25f, 0.3333f, 0.5f, 0.6f, 0.75f, 0.9f, 0.9999f, kOneMinusEps};
}

void expect_unit(Vec3 w) {
    ASSERT_TRUE(is_finite(w));
    EXPECT_NEAR(length(w), 1.0f, 2e-6f);
}

// ---- round trips -----------------------------------------------------------------------------------

// For maps to the sphere: invert(sample(u)) == u, except that the azimuth is undefined at the poles
// (checked with `pole(u)`) and periodic.
void check_sphere_round_trip(const std::function<Vec3(Vec2)>& sample, const std::function<Vec2(Vec3)>& invert,
                             const std::function<bool(Vec2)>& pole, double tol) {
    for (float a : edge_and_interior_values())
        for (float b : edge_and_interior_values()) {
            Vec2 u{a, b};
            Vec3 w = sample(u);
            expect_unit(w);
            Vec2 v = invert(w);
            ASSERT_GE(v.x, 0.0f);
            ASSERT_LT(v.x, 1.0f);
            ASSERT_GE(v.y, 0.0f);
            ASSERT_LT(v.y, 1.0f);
            EXPECT_NEAR(v.x, u.x, tol) << "u = (" << a << ", " << b << ")";
            if (!pole(u)) { EXPECT_LT(wrap_dist(v.y, u.y), tol) << "u = (" << a << ", " << b << ")"; }
        }
    Rng rng(1, 2);
    for (int i = 0; i < 20000; ++i) {
        Vec2 u{rng.next_float(), rng.next_float()};
        Vec2 v = invert(sample(u));
        EXPECT_NEAR(v.x, u.x, tol);
        if (!pole(u)) { EXPECT_LT(wrap_dist(v.y, u.y), tol); }
    }
}

TEST(WarpRoundTrip, UniformSphere) {
    check_sphere_round_trip(sample_uniform_sphere, invert_uniform_sphere,
                            [](Vec2 u) { return u.x < 1e-6f || u.x > 0.99999f; }, 2e-6);
}

TEST(WarpRoundTrip, UniformHemisphere) {
    check_sphere_round_trip(sample_uniform_hemisphere, invert_uniform_hemisphere,
                            [](Vec2 u) { return u.x > 0.99999f; }, 2e-6);
}

TEST(WarpRoundTrip, CosineHemisphere) {
    // The disk map is not periodic in u1 and has no pole except the centre; compare both coordinates.
    Rng rng(3, 4);
    for (int i = 0; i < 20000; ++i) {
        Vec2 u{rng.next_float(), rng.next_float()};
        Vec3 w = sample_cosine_hemisphere(u);
        expect_unit(w);
        EXPECT_GE(w.z, 0.0f);
        Vec2 v = invert_cosine_hemisphere(w);
        EXPECT_NEAR(v.x, u.x, 3e-6);
        EXPECT_NEAR(v.y, u.y, 3e-6);
    }
    for (float a : edge_and_interior_values())
        for (float b : edge_and_interior_values()) {
            Vec3 w = sample_cosine_hemisphere({a, b});
            expect_unit(w);
            Vec2 v = invert_cosine_hemisphere(w);
            EXPECT_NEAR(v.x, a, 3e-6) << a << ", " << b;
            EXPECT_NEAR(v.y, b, 3e-6) << a << ", " << b;
        }
}

TEST(WarpRoundTrip, ConcentricDisk) {
    for (float a : edge_and_interior_values())
        for (float b : edge_and_interior_values()) {
            Vec2 p = sample_concentric_disk({a, b});
            ASSERT_LE(p.x * p.x + p.y * p.y, 1.0f + 1e-6f);
            Vec2 v = invert_concentric_disk(p);
            EXPECT_NEAR(v.x, a, 2e-6) << a << ", " << b;
            EXPECT_NEAR(v.y, b, 2e-6) << a << ", " << b;
        }
}

TEST(WarpRoundTrip, UniformConeWideAndNarrow) {
    for (float cos_max : {-0.5f, 0.0f, 0.3f, 0.9f, 0.999f}) {
        Rng rng(5, 6);
        for (int i = 0; i < 5000; ++i) {
            Vec2 u{rng.next_float(), rng.next_float()};
            Vec3 w = sample_uniform_cone(u, cos_max);
            expect_unit(w);
            EXPECT_GE(w.z, cos_max - 1e-6f);
            Vec2 v = invert_uniform_cone(w, cos_max);
            // With a float cos_max, 1 - cos_max carries its rounding; relative to it the error grows
            // as the cone narrows: tolerance scaled accordingly.
            EXPECT_NEAR(v.x, u.x, 2e-6 / std::min(1.0f, 1.0f - cos_max) + 2e-6) << cos_max;
            if (u.x > 1e-5f) { EXPECT_LT(wrap_dist(v.y, u.y), 2e-5) << cos_max; }
        }
    }
}

TEST(WarpRoundTrip, UniformConeTinyViaOneMinusCos) {
    // A cone of 1 - cos_max = 2.5e-6 (the veach_mi lights) keeps full relative precision.
    for (float omc : {2.5e-6f, 1e-10f, 1e-20f}) {
        Rng rng(7, 8);
        for (int i = 0; i < 5000; ++i) {
            Vec2 u{rng.next_float(), rng.next_float()};
            Vec3 w = sample_uniform_cone(u, OneMinusCos{omc});
            expect_unit(w);
            // The polar angle is where the precision matters: 1 - cos(theta) must be u0 * omc.
            EXPECT_NEAR(one_minus_cos_theta(w) / omc, u.x, 4e-6) << omc;
            Vec2 v = invert_uniform_cone(w, OneMinusCos{omc});
            EXPECT_NEAR(v.x, u.x, 4e-6) << omc;
            if (u.x > 1e-4f) { EXPECT_LT(wrap_dist(v.y, u.y), 1e-5) << omc; }
        }
        EXPECT_FLOAT_EQ(uniform_cone_pdf(OneMinusCos{omc}), float(1.0 / (2.0 * M_PI * double(omc))));
    }
}

TEST(WarpRoundTrip, Triangle) {
    for (float a : edge_and_interior_values())
        for (float b : edge_and_interior_values()) {
            Vec2 bc = sample_uniform_triangle({a, b});
            EXPECT_GE(bc.x, 0.0f);
            EXPECT_GE(bc.y, 0.0f);
            EXPECT_LE(bc.x + bc.y, 1.0f);
            Vec2 v = invert_uniform_triangle(bc);
            EXPECT_NEAR(v.x, a, 1e-6) << a << ", " << b;
            EXPECT_NEAR(v.y, b, 1e-6) << a << ", " << b;
        }
}

// ---- inverses at the edges of their domains --------------------------------------------------------

void expect_in_unit_square(Vec2 v) {
    EXPECT_TRUE(std::isfinite(v.x) && std::isfinite(v.y));
    EXPECT_GE(v.x, 0.0f);
    EXPECT_LT(v.x, 1.0f);
    EXPECT_GE(v.y, 0.0f);
    EXPECT_LT(v.y, 1.0f);
}

TEST(WarpInvert, Edges) {
    // Poles and the horizon.
    Vec2 v = invert_uniform_sphere({0, 0, 1});
    expect_in_unit_square(v);
    EXPECT_EQ(v.x, 0.0f);
    v = invert_uniform_sphere({0, 0, -1});
    expect_in_unit_square(v);
    EXPECT_GT(v.x, 0.99999f);
    v = invert_uniform_hemisphere({1, 0, 0});
    expect_in_unit_square(v);
    EXPECT_EQ(v.x, 0.0f);
    EXPECT_EQ(v.y, 0.0f);
    v = invert_uniform_hemisphere({0, 0, 1});
    expect_in_unit_square(v);
    EXPECT_GT(v.x, 0.99999f);
    // Azimuth just below a full turn must stay below 1.
    v = invert_uniform_sphere(normalize({1, -1e-9f, 0}));
    expect_in_unit_square(v);
    // Disk centre and rim, cosine-hemisphere horizon.
    v = invert_concentric_disk({0, 0});
    EXPECT_EQ(v.x, 0.5f);
    EXPECT_EQ(v.y, 0.5f);
    for (Vec2 p : {Vec2{1, 0}, Vec2{-1, 0}, Vec2{0, 1}, Vec2{0, -1}, Vec2{0.70710678f, -0.70710678f}}) {
        v = invert_concentric_disk(p);
        expect_in_unit_square(v);
        Vec2 q = sample_concentric_disk(v);
        EXPECT_NEAR(q.x, p.x, 1e-6f);
        EXPECT_NEAR(q.y, p.y, 1e-6f);
    }
    v = invert_cosine_hemisphere({0, 1, 0});
    expect_in_unit_square(v);
    // Cone axis and rim.
    v = invert_uniform_cone({0, 0, 1}, 0.5f);
    EXPECT_EQ(v.x, 0.0f);
    v = invert_uniform_cone(Vec3(std::sqrt(0.75f), 0, 0.5f), 0.5f);
    expect_in_unit_square(v);
    EXPECT_GT(v.x, 0.99999f);
    // Triangle vertices.
    for (Vec2 b : {Vec2{0, 0}, Vec2{1, 0}, Vec2{0, 1}, Vec2{0.5f, 0.5f}}) expect_in_unit_square(invert_uniform_triangle(b));
    // Forward maps at the corners of [0,1)^2 give finite unit directions.
    for (Vec2 u : {Vec2{0, 0}, Vec2{0, kOneMinusEps}, Vec2{kOneMinusEps, 0}, Vec2{kOneMinusEps, kOneMinusEps}}) {
        expect_unit(sample_uniform_sphere(u));
        expect_unit(sample_uniform_hemisphere(u));
        expect_unit(sample_cosine_hemisphere(u));
        expect_unit(sample_uniform_cone(u, 0.3f));
        expect_unit(sample_uniform_cone(u, OneMinusCos{1e-12f}));
        expect_unit(sample_uniform_cone(u, OneMinusCos{0.0f}));
    }
    EXPECT_EQ(uniform_cone_pdf(1.0f), 0.0f);  // degenerate cone: no density, not Inf
}

// ---- PDFs integrate to one and equal the inverse Jacobian ------------------------------------------

TEST(WarpPdf, IntegratesToOne) {
    // integrate_sphere's grid has cell edges at z = 0 and z = 0.5, where these PDFs jump.
    EXPECT_NEAR(test::integrate_sphere([](Vec3) { return double(uniform_sphere_pdf()); }), 1.0, 1e-6);
    EXPECT_NEAR(test::integrate_sphere([](Vec3 w) { return w.z > 0 ? double(uniform_hemisphere_pdf()) : 0.0; }), 1.0,
                1e-6);
    EXPECT_NEAR(test::integrate_sphere([](Vec3 w) { return double(cosine_hemisphere_pdf(w.z)); }), 1.0, 1e-4);
    EXPECT_NEAR(test::integrate_sphere([](Vec3 w) { return w.z >= 0.5f ? double(uniform_cone_pdf(0.5f)) : 0.0; }),
                1.0, 1e-6);
    // A narrow cone, integrated in its own polar angle (midpoint rule in theta, exact in phi).
    for (float omc : {1e-3f, 2.5e-6f}) {
        double theta_max = std::acos(1.0 - double(omc)), sum = 0;
        const int n = 20000;
        for (int i = 0; i < n; ++i) {
            double theta = (i + 0.5) / n * theta_max;
            sum += double(uniform_cone_pdf(OneMinusCos{omc})) * std::sin(theta);
        }
        EXPECT_NEAR(sum * theta_max / n * 2 * M_PI, 1.0, 1e-5) << omc;
    }
}

// |d w/d u0 x d w/d u1| by central differences, in double on top of the float map.
double jacobian_area(const std::function<Vec3(Vec2)>& f, Vec2 u, double h) {
    auto d = [&](Vec2 a, Vec2 b) {
        Vec3 fa = f(a), fb = f(b);
        return std::array<double, 3>{(double(fb.x) - fa.x) / (2 * h), (double(fb.y) - fa.y) / (2 * h),
                                     (double(fb.z) - fa.z) / (2 * h)};
    };
    auto du = d({float(u.x - h), u.y}, {float(u.x + h), u.y});
    auto dv = d({u.x, float(u.y - h)}, {u.x, float(u.y + h)});
    double cx = du[1] * dv[2] - du[2] * dv[1], cy = du[2] * dv[0] - du[0] * dv[2], cz = du[0] * dv[1] - du[1] * dv[0];
    return std::sqrt(cx * cx + cy * cy + cz * cz);
}

TEST(WarpPdf, EqualsInverseJacobian) {
    const double h = 1e-3;
    Rng rng(9, 10);
    for (int i = 0; i < 2000; ++i) {
        // Interior points, away from the poles and from the seams of the piecewise maps, where a
        // central difference straddles a kink.
        Vec2 u{0.02f + 0.96f * rng.next_float(), 0.02f + 0.96f * rng.next_float()};
        float a = 2 * u.x - 1, b = 2 * u.y - 1;
        bool near_seam = std::abs(std::abs(a) - std::abs(b)) < 8 * h || std::abs(u.x - u.y) < 4 * h ||
                         (std::abs(a) < 8 * h && std::abs(b) < 8 * h);

        EXPECT_NEAR(jacobian_area(sample_uniform_sphere, u, h) * uniform_sphere_pdf(), 1.0, 2e-3);
        EXPECT_NEAR(jacobian_area(sample_uniform_hemisphere, u, h) * uniform_hemisphere_pdf(), 1.0, 2e-3);
        auto cone = [](Vec2 v) { return sample_uniform_cone(v, 0.2f); };
        EXPECT_NEAR(jacobian_area(cone, u, h) * uniform_cone_pdf(0.2f), 1.0, 2e-3);
        if (!near_seam) {
            Vec3 w = sample_cosine_hemisphere(u);
            if (w.z > 0.05f) {
                EXPECT_NEAR(jacobian_area(sample_cosine_hemisphere, u, h) * cosine_hemisphere_pdf(w.z), 1.0, 5e-3);
            }
            // The disk: area element pi du (pdf 1/pi per unit area); embed it in the plane z = 0.
            auto disk = [](Vec2 v) {
                Vec2 p = sample_concentric_disk(v);
                return Vec3(p.x, p.y, 0);
            };
            EXPECT_NEAR(jacobian_area(disk, u, h) / kPi, 1.0, 2e-3);
            // The triangle: barycentrics (b1, b2) cover area 1/2 uniformly, Jacobian 1/2.
            auto tri = [](Vec2 v) {
                Vec2 p = sample_uniform_triangle(v);
                return Vec3(p.x, p.y, 0);
            };
            EXPECT_NEAR(jacobian_area(tri, u, h) * 2.0, 1.0, 2e-3);
        }
        // The tiny cone, measured in (1 - cos theta, phi), where dOmega = d(1 - cos) d(phi):
        // float directions cannot resolve its z, but one_minus_cos_theta can.
        const float omc = 2.5e-6f;
        auto coords = [&](Vec2 v) {
            Vec3 d = sample_uniform_cone(v, OneMinusCos{omc});
            return std::array<double, 2>{double(one_minus_cos_theta(d)), std::atan2(double(d.y), double(d.x))};
        };
        if (u.y > 0.05f && u.y < 0.45f) {  // keep atan2 away from its branch cut at phi = pi
            auto a0 = coords({float(u.x - h), u.y}), a1 = coords({float(u.x + h), u.y});
            auto b0 = coords({u.x, float(u.y - h)}), b1 = coords({u.x, float(u.y + h)});
            double j = ((a1[0] - a0[0]) * (b1[1] - b0[1]) - (a1[1] - a0[1]) * (b1[0] - b0[0])) / (4 * h * h);
            EXPECT_NEAR(std::abs(j) * uniform_cone_pdf(OneMinusCos{omc}), 1.0, 2e-3);
        }
    }
}

// ---- upper_bound_index -----------------------------------------------------------------------------

// The branch-free search must answer exactly as std::upper_bound: every length up to 70 (odd, even,
// powers of two), runs of equal values, and queries below, between, on and above the elements.
TEST(UpperBoundIndex, AgreesWithStdUpperBound) {
    Rng rng(11, 12);
    for (size_t n = 0; n <= 70; ++n) {
        for (int trial = 0; trial < 20; ++trial) {
            std::vector<float> a(n);
            float v = 0;
            for (float& x : a) {
                v += rng.next_float() < 0.3f ? 0.0f : rng.next_float();  // about a third repeat the previous
                x = v;
            }
            std::vector<float> queries = {-1.0f, v + 1.0f, std::nanf("")};
            for (float x : a) queries.insert(queries.end(), {x, std::nextafter(x, -1e30f), std::nextafter(x, 1e30f)});
            for (int q = 0; q < 10; ++q) queries.push_back(rng.next_float() * (v + 1.0f));
            for (float x : queries) {
                const size_t want = std::isnan(x) ? 0 : size_t(std::upper_bound(a.begin(), a.end(), x) - a.begin());
                ASSERT_EQ(upper_bound_index(a.data(), n, x), want) << "n " << n << ", x " << x;
            }
        }
    }
    const std::vector<double> d = {0.0, 0.25, 0.25, 1.0};
    EXPECT_EQ(upper_bound_index(d.data(), d.size(), 0.25), 3u);
    EXPECT_EQ(upper_bound_index(d.data(), d.size(), 1.0), 4u);
}

// ---- Distribution1D --------------------------------------------------------------------------------

// Checks that sample() returns each index for exactly a pmf(i) share of [0,1) and that u_remapped
// runs uniformly through [0,1) inside each bin.
void check_distribution(const std::vector<float>& w) {
    Distribution1D d(w);
    double sum = 0;
    for (float x : w) sum += x;
    ASSERT_FALSE(d.empty());
    ASSERT_EQ(d.size(), w.size());
    double pmf_sum = 0;
    for (uint32_t i = 0; i < w.size(); ++i) {
        EXPECT_NEAR(d.pmf(i), w[i] / sum, 1e-7);
        pmf_sum += d.pmf(i);
    }
    EXPECT_NEAR(pmf_sum, 1.0, 1e-6);
    const int n = 1 << 20;
    std::vector<int> count(w.size(), 0);
    uint32_t last = 0;
    for (int k = 0; k < n; ++k) {
        float u = float((k + 0.5) / n);
        float r = -1;
        uint32_t i = d.sample(u, &r);
        ASSERT_LT(i, w.size());
        ASSERT_GT(w[i], 0.0f) << "zero-weight bin " << i << " chosen for u = " << u;
        ASSERT_GE(r, 0.0f);
        ASSERT_LT(r, 1.0f);
        ASSERT_GE(i, last) << "sample() must be monotone in u";
        last = i;
        ++count[i];
    }
    for (uint32_t i = 0; i < w.size(); ++i) EXPECT_NEAR(count[i] / double(n), d.pmf(i), 2.0 / n + 1e-7) << i;
    // Edges of [0, 1): first and last positive bins, remapped values in [0, 1).
    for (float u : {0.0f, kOneMinusEps, 1.0f, -0.5f}) {
        float r = -1;
        uint32_t i = d.sample(u, &r);
        EXPECT_GT(w[i], 0.0f);
        EXPECT_GE(r, 0.0f);
        EXPECT_LT(r, 1.0f);
    }
}

TEST(Distribution1D, PmfMatchesSampling) {
    check_distribution({1, 2, 3, 4});
    check_distribution({0, 0, 5, 0, 1e-3f, 0, 2, 0, 0});  // leading, inner and trailing zeros
    check_distribution({7});
    check_distribution({0, 1e-30f, 0});
    std::vector<float> many(1000);
    for (int i = 0; i < 1000; ++i) many[i] = float((i * 7919) % 13);
    check_distribution(many);
}

TEST(Distribution1D, SingleBinRemapsIdentically) {
    Distribution1D d({3.0f});
    for (float u : {0.0f, 0.25f, 0.5f, 0.75f, kOneMinusEps}) {
        float r = -1;
        EXPECT_EQ(d.sample(u, &r), 0u);
        EXPECT_EQ(r, u);
    }
    EXPECT_EQ(d.pmf(0), 1.0f);
}

TEST(Distribution1D, RemappedUIsPositionInBin) {
    Distribution1D d({1, 3});  // bins [0, 0.25), [0.25, 1)
    float r = -1;
    EXPECT_EQ(d.sample(0.125f, &r), 0u);
    EXPECT_FLOAT_EQ(r, 0.5f);
    EXPECT_EQ(d.sample(0.25f, &r), 1u);  // a bin boundary belongs to the upper bin
    EXPECT_EQ(r, 0.0f);
    EXPECT_EQ(d.sample(0.625f, &r), 1u);
    EXPECT_FLOAT_EQ(r, 0.5f);
    EXPECT_EQ(d.sample(kOneMinusEps, &r), 1u);
    EXPECT_LT(r, 1.0f);
}

TEST(Distribution1D, EmptyAndAllZero) {
    Distribution1D none;
    EXPECT_TRUE(none.empty());
    EXPECT_EQ(none.size(), 0u);
    EXPECT_EQ(none.pmf(0), 0.0f);
    EXPECT_EQ(none.sample(0.5f), 0u);
    Distribution1D zero({0, 0, 0});
    EXPECT_TRUE(zero.empty());
    EXPECT_EQ(zero.size(), 3u);
    for (uint32_t i = 0; i < 3; ++i) EXPECT_EQ(zero.pmf(i), 0.0f);
    float r = -1;
    zero.sample(0.5f, &r);
    EXPECT_GE(r, 0.0f);
    EXPECT_LT(r, 1.0f);
    Distribution1D empty_vec(std::vector<float>{});
    EXPECT_TRUE(empty_vec.empty());
    EXPECT_EQ(Distribution1D({1, 2}).pmf(5), 0.0f);  // out of range: probability 0
}

TEST(Distribution1D, RejectsInvalidWeights) {
    EXPECT_THROW(Distribution1D({1, -1}), std::invalid_argument);
    EXPECT_THROW(Distribution1D({1, std::nanf("")}), std::invalid_argument);
    EXPECT_THROW(Distribution1D({1, kInf}), std::invalid_argument);
}

TEST(Distribution1D, LargeTableKeepsTinyBins) {
    // A million bins: in a float CDF the last bins would have widths quantised to ULP(1) = 6e-8
    // (and a bin of 1e-7 relative weight would be lost); the double CDF keeps them exact.
    std::vector<float> w(1000000, 1.0f);
    w.back() = 0.25f;
    w[500000] = 0.0f;
    Distribution1D d(w);
    EXPECT_NEAR(d.pmf(999999), 0.25 / 999998.25, 1e-13);
    EXPECT_EQ(d.sample(kOneMinusEps), 999999u);
    EXPECT_EQ(d.sample(float(1.0 - 0.2 / 999998.25)), 999999u);
    EXPECT_EQ(d.sample(float(1.0 - 0.3 / 999998.25)), 999998u);
    // The zero bin in the middle is never chosen, even for u at its CDF position.
    float u_at = float(500000.0 / 999998.25);
    for (float u = std::nextafter(u_at, 0.0f), k = 0; k < 8; ++k, u = std::nextafter(u, 1.0f))
        EXPECT_NE(d.sample(u), 500000u);
}


// owen_sobol_2d: for any scramble, the first 2^k points form a (0,k,2)-net (one point in every
// elementary interval of area 2^-k), which is what makes a progressive render's prefix stratified.
TEST(OwenSobol, PrefixesAreZeroNets) {
    for (uint64_t scramble : {uint64_t(0), uint64_t(0x9e3779b97f4a7c15ULL), mix64(7), mix64(12345)}) {
        for (int k = 1; k <= 10; ++k) {
            const uint32_t n = 1u << k;
            for (int a = 0; a <= k; ++a) {
                // 2^a columns x 2^(k-a) rows.
                std::vector<int> count(n, 0);
                for (uint32_t i = 0; i < n; ++i) {
                    const Vec2 p = owen_sobol_2d(i, scramble);
                    ASSERT_TRUE(p.x >= 0 && p.x < 1 && p.y >= 0 && p.y < 1);
                    const uint32_t cx = uint32_t(p.x * float(1u << a)), cy = uint32_t(p.y * float(1u << (k - a)));
                    ++count[(cy << a) | cx];
                }
                for (uint32_t c = 0; c < n; ++c)
                    ASSERT_EQ(count[c], 1) << "scramble " << scramble << ", 2^" << k << " points, 2^" << a << " columns, cell " << c;
            }
        }
    }
}

// Over random scrambles a single point is uniform: each coordinate's histogram over 16 bins, for a fixed
// index, is flat within 5 standard deviations; and the two coordinates are scrambled independently
// (their correlation over scrambles is near zero).
TEST(OwenSobol, EachPointIsUniformOverScrambles) {
    constexpr int kScrambles = 1 << 16, kBins = 16;
    for (uint32_t index : {0u, 1u, 5u, 1000u}) {
        std::vector<int> hx(kBins, 0), hy(kBins, 0);
        double sxy = 0, sx = 0, sy = 0;
        for (int s = 0; s < kScrambles; ++s) {
            const Vec2 p = owen_sobol_2d(index, mix64(uint64_t(s) + 0x1234));
            ++hx[int(p.x * kBins)];
            ++hy[int(p.y * kBins)];
            sxy += double(p.x) * p.y;
            sx += p.x;
            sy += p.y;
        }
        const double expect = double(kScrambles) / kBins, sd = std::sqrt(expect * (1 - 1.0 / kBins));
        for (int b = 0; b < kBins; ++b) {
            EXPECT_LT(std::abs(hx[b] - expect), 5 * sd) << "index " << index << ", x bin " << b;
            EXPECT_LT(std::abs(hy[b] - expect), 5 * sd) << "index " << index << ", y bin " << b;
        }
        const double cov = sxy / kScrambles - (sx / kScrambles) * (sy / kScrambles);
        EXPECT_LT(std::abs(cov), 5 * (1.0 / 12) / std::sqrt(double(kScrambles))) << "index " << index;
    }
}

// Two sequences with different scrambles (render_image's pixel position and first-bounce samples) must
// not move together: for each pair of scrambles, over the first 256 points, how often both x lie in the
// same half. Independently paired that is 0.5 on average with a spread of 1/32; sequences paired digit
// by digit (scrambled points without a shuffled index) agree on every point or on none.
TEST(OwenSobol, SequencesWithDifferentScramblesAreNotPairedDigitByDigit) {
    constexpr int kPairs = 400, kPoints = 256;
    int all_or_none = 0;
    double sum = 0;
    for (int p = 0; p < kPairs; ++p) {
        const uint64_t a = mix64(uint64_t(2 * p) + 99), b = mix64(uint64_t(2 * p + 1) + 99);
        int same = 0;
        for (uint32_t i = 0; i < kPoints; ++i) same += (owen_sobol_2d(i, a).x < 0.5f) == (owen_sobol_2d(i, b).x < 0.5f);
        all_or_none += same == 0 || same == kPoints;
        sum += double(same) / kPoints;
    }
    EXPECT_EQ(all_or_none, 0);
    EXPECT_NEAR(sum / kPairs, 0.5, 5 * (1.0 / 32) / std::sqrt(double(kPairs)));
}

}  // namespace
}  // namespace iris
