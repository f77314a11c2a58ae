// Exact (non-statistical) checks of the equal-area octahedral map and the cache's spherical density
// map: round trips, equal texel areas, fold topology, mass conservation of splat and filter, the floor,
// and the sample/pdf/invert trio. The chi-square tests of the sampler are in
// tests/statistical/test_spheremap_chi2.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <vector>

#include "libcommon/rng.h"
#include "libcommon/spheremap.h"
#include "support/chi2.h"

namespace iris {
namespace {

constexpr double kFourPi = 4.0 * M_PI;

double angle_between(Vec3 a, Vec3 b) {
    // 2 asin(|a - b| / 2) in double: accurate for small angles.
    double dx = double(a.x) - b.x, dy = double(a.y) - b.y, dz = double(a.z) - b.z;
    return 2.0 * std::asin(std::min(1.0, 0.5 * std::sqrt(dx * dx + dy * dy + dz * dz)));
}

Vec3 unit(double x, double y, double z) {
    double l = std::sqrt(x * x + y * y + z * z);
    return Vec3(float(x / l), float(y / l), float(z / l));
}

// Directions that stress the map: poles, axes (with both signed zeros), octant seams, the equator,
// points a hair away from the poles and from the seams.
std::vector<Vec3> special_directions() {
    std::vector<Vec3> d;
    for (float s : {1.0f, -1.0f}) {
        d.push_back({s, 0, 0});
        d.push_back({0, s, 0});
        d.push_back({0, 0, s});
        d.push_back({s, -0.0f, 0});
        d.push_back({-0.0f, s, -0.0f});
        d.push_back({-0.0f, -0.0f, s});
    }
    for (int sx : {-1, 1})
        for (int sy : {-1, 1})
            for (int sz : {-1, 0, 1}) {
                d.push_back(unit(sx, sy, sz));          // octant centres and equator diagonals
                d.push_back(unit(sx, 0, sz + 0.0));     // on the y = 0 seam
                d.push_back(unit(0, sy, sz + 0.0));     // on the x = 0 seam
                for (double eps : {1e-7, 1e-5, 1e-3}) {
                    d.push_back(unit(sx * eps, sy * eps, sz == 0 ? 1 : sz));  // near the poles
                    d.push_back(unit(sx, sy * eps, sz * 0.5));                // near the seams
                    d.push_back(unit(sx, sy, sz * eps));                      // near the equator
                }
            }
    return d;
}

// A unit direction from a uniform 2-D sample (independent of the map under test).
Vec3 uniform_direction(Rng& rng) {
    double z = 1.0 - 2.0 * rng.next_double(), phi = 2.0 * M_PI * rng.next_double();
    double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return unit(r * std::cos(phi), r * std::sin(phi), z);
}

// ---- the map ------------------------------------------------------------------------------------------

TEST(OctaMap, AzimuthPolynomialsMatchLibm) {
    // atan_unit_fraction and quadrant_cos_sin replace atan2 and sin/cos in the map: against double libm
    // over a dense grid of their whole domains (endpoints included), within a few float ULPs of 1.
    double worst_atan = 0, worst_trig = 0, worst_norm = 0;
    const int n = 200000;
    for (int i = 0; i <= n; ++i) {
        const float t = float(i) / n;
        worst_atan = std::max(worst_atan, std::abs(atan_unit_fraction(t) - std::atan(double(t)) * 2 / M_PI));
        const float tt = 2 * t - 1;
        float c, s;
        quadrant_cos_sin(tt, &c, &s);
        const double phi = (double(tt) + 1) * M_PI / 4;
        worst_trig = std::max({worst_trig, std::abs(c - std::cos(phi)), std::abs(s - std::sin(phi))});
        worst_norm = std::max(worst_norm, std::abs(double(c) * c + double(s) * s - 1));
    }
    // Measured 1.03e-7, 1.49e-7 and 3.0e-7 (gcc 12, x86-64): the fit's 2.7e-8 plus float rounding,
    // 2-3 ULPs of 1, as float libm calls would give within a factor of two.
    EXPECT_EQ(atan_unit_fraction(0.0f), 0.0f);
    EXPECT_LE(worst_atan, 2e-7);
    EXPECT_LE(worst_trig, 3e-7);
    EXPECT_LE(worst_norm, 6e-7);
}

TEST(OctaMap, SpecialPointsLandWhereExpected) {
    auto near = [](Vec3 a, Vec3 b) { return angle_between(a, b) < 1e-6; };
    EXPECT_TRUE(near(square_to_sphere({0.5f, 0.5f}), {0, 0, 1}));
    for (Vec2 c : {Vec2{0, 0}, Vec2{1, 0}, Vec2{0, 1}, Vec2{1, 1}}) EXPECT_TRUE(near(square_to_sphere(c), {0, 0, -1}));
    EXPECT_TRUE(near(square_to_sphere({1.0f, 0.5f}), {1, 0, 0}));
    EXPECT_TRUE(near(square_to_sphere({0.0f, 0.5f}), {-1, 0, 0}));
    EXPECT_TRUE(near(square_to_sphere({0.5f, 1.0f}), {0, 1, 0}));
    EXPECT_TRUE(near(square_to_sphere({0.5f, 0.0f}), {0, -1, 0}));
    // The diamond |u'| + |v'| = 1 is the equator; its quadrant midpoints are the 45-degree azimuths.
    EXPECT_TRUE(near(square_to_sphere({0.75f, 0.75f}), unit(1, 1, 0)));
    EXPECT_TRUE(near(square_to_sphere({0.25f, 0.25f}), unit(-1, -1, 0)));
    // The square's border folds: mirror images about an edge midpoint are the same direction.
    for (float t : {0.0f, 0.1f, 0.3f, 0.45f}) {
        EXPECT_TRUE(near(square_to_sphere({t, 1.0f}), square_to_sphere({1.0f - t, 1.0f})));
        EXPECT_TRUE(near(square_to_sphere({t, 0.0f}), square_to_sphere({1.0f - t, 0.0f})));
        EXPECT_TRUE(near(square_to_sphere({0.0f, t}), square_to_sphere({0.0f, 1.0f - t})));
        EXPECT_TRUE(near(square_to_sphere({1.0f, t}), square_to_sphere({1.0f, 1.0f - t})));
    }
}

TEST(OctaMap, SquareToSphereToSquareRoundTrip) {
    // A dense grid including the border, the axes (u or v = 1/2), the diamond and the corners.
    const int n = 1201;
    double worst = 0;
    for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) {
            Vec2 p{float(a) / (n - 1), float(b) / (n - 1)};
            Vec3 w = square_to_sphere(p);
            ASSERT_TRUE(is_finite(w));
            ASSERT_NEAR(length(w), 1.0f, 1e-6f);
            Vec2 q = sphere_to_square(w);
            ASSERT_TRUE(std::isfinite(q.x) && std::isfinite(q.y));
            const bool border_u = a == 0 || a == n - 1, border_v = b == 0 || b == n - 1;
            if (border_u && border_v) {
                // Corners: all four are -z.
                EXPECT_TRUE((q.x == 0 || q.x == 1) && (q.y == 0 || q.y == 1)) << q.x << " " << q.y;
                continue;
            }
            double e;
            if (border_v)  // (u, 0) ~ (1 - u, 0): either preimage is right
                e = std::min(std::abs(q.x - p.x), std::abs(q.x - (1 - p.x))) + std::abs(q.y - p.y);
            else if (border_u)
                e = std::min(std::abs(q.y - p.y), std::abs(q.y - (1 - p.y))) + std::abs(q.x - p.x);
            else
                e = std::max(std::abs(q.x - p.x), std::abs(q.y - p.y));
            worst = std::max(worst, e);
            ASSERT_LE(e, 1e-5) << "at (" << p.x << ", " << p.y << ")";
        }
    // Measured 1.2e-7: the edge margin of SphereDistribution::sample relies on this being << 1e-5.
    EXPECT_LE(worst, 1e-6);
}

TEST(OctaMap, SphereToSquareToSphereRoundTrip) {
    std::vector<Vec3> dirs = special_directions();
    const int nt = 400, np = 800;
    for (int i = 0; i <= nt; ++i)
        for (int j = 0; j < np; ++j) {
            double th = M_PI * i / nt, ph = 2 * M_PI * j / np;
            dirs.push_back(unit(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)));
        }
    Rng rng(11, 3);
    for (int i = 0; i < 200000; ++i) dirs.push_back(uniform_direction(rng));
    double worst = 0;
    for (Vec3 w : dirs) {
        Vec2 q = sphere_to_square(w);
        ASSERT_TRUE(q.x >= 0 && q.x <= 1 && q.y >= 0 && q.y <= 1) << w.x << " " << w.y << " " << w.z;
        Vec3 w2 = square_to_sphere(q);
        double e = angle_between(w, w2);
        worst = std::max(worst, e);
        ASSERT_LE(e, 1e-5) << "w = (" << w.x << ", " << w.y << ", " << w.z << ")";
    }
    EXPECT_LE(worst, 2e-6);
}

TEST(OctaMap, SignedZerosGiveTheSameSquarePoint) {
    // Equal directions (as real numbers) must land in the same texel, or pdf() of the "same"
    // direction could differ across a fold.
    for (float s : {1.0f, -1.0f})
        for (float z : {0.3f, -0.3f, -0.9f}) {
            float r = std::sqrt(1 - z * z);
            Vec2 a = sphere_to_square({0.0f, s * r, z}), b = sphere_to_square({-0.0f, s * r, z});
            EXPECT_EQ(a.x, b.x);
            EXPECT_EQ(a.y, b.y);
            a = sphere_to_square({s * r, 0.0f, z}), b = sphere_to_square({s * r, -0.0f, z});
            EXPECT_EQ(a.x, b.x);
            EXPECT_EQ(a.y, b.y);
        }
}

// Jacobian by central differences at points away from the map's creases (the axes u or v = 1/2 and
// the diamond, where it is only piecewise smooth): |dw/du x dw/dv| = 4 pi everywhere.
TEST(OctaMap, JacobianIsFourPi) {
    const double h = 1e-3;
    int checked = 0;
    for (int a = 1; a < 60; ++a)
        for (int b = 1; b < 60; ++b) {
            double u = a / 60.0 + 0.003, v = b / 60.0 + 0.0071;
            double cu = 2 * u - 1, cv = 2 * v - 1;
            if (std::abs(cu) < 3 * h || std::abs(cv) < 3 * h || std::abs(std::abs(cu) + std::abs(cv) - 1) < 6 * h ||
                u + h > 1 || v + h > 1)
                continue;
            auto W = [](double x, double y) {
                Vec3 w = square_to_sphere({float(x), float(y)});
                return std::array<double, 3>{w.x, w.y, w.z};
            };
            auto p1 = W(u + h, v), p0 = W(u - h, v), q1 = W(u, v + h), q0 = W(u, v - h);
            double du[3], dv[3];
            for (int k = 0; k < 3; ++k) {
                du[k] = (p1[k] - p0[k]) / (2 * h);
                dv[k] = (q1[k] - q0[k]) / (2 * h);
            }
            double cx = du[1] * dv[2] - du[2] * dv[1], cy = du[2] * dv[0] - du[0] * dv[2],
                   cz = du[0] * dv[1] - du[1] * dv[0];
            double jac = std::sqrt(cx * cx + cy * cy + cz * cz);
            EXPECT_NEAR(jac / kFourPi, 1.0, 1e-3) << "at (" << u << ", " << v << ")";
            ++checked;
        }
    EXPECT_GT(checked, 2500);
}

// Signed solid angle of the spherical triangle (a, b, c) (Van Oosterom & Strackee 1983), in double.
double triangle_solid_angle(const std::array<double, 3>& a, const std::array<double, 3>& b,
                            const std::array<double, 3>& c) {
    double num = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                 a[2] * (b[0] * c[1] - b[1] * c[0]);
    auto d = [](const std::array<double, 3>& x, const std::array<double, 3>& y) {
        return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    };
    double den = 1 + d(a, b) + d(b, c) + d(c, a);
    return std::abs(2.0 * std::atan2(num, den));
}

// Equal area without Monte Carlo: each texel of an 8x8 grid, cut into 32x32 sub-squares, each split
// into two triangles along the diagonal that follows the map's crease (|u'| + |v'| = 1) so that no
// triangle straddles it; the sum of the spherical triangles' areas converges to the texel's solid
// angle (O(h^2)). Every texel must have 4 pi / 64 sr.
TEST(OctaMap, EveryTexelHasEqualSolidAngle) {
    const int R = 8, m = 32, n = R * m;
    auto P = [&](int a, int b) {
        Vec3 w = square_to_sphere({float(a) / n, float(b) / n});
        double l = std::sqrt(double(w.x) * w.x + double(w.y) * w.y + double(w.z) * w.z);
        return std::array<double, 3>{w.x / l, w.y / l, w.z / l};
    };
    double all = 0;
    for (int j = 0; j < R; ++j)
        for (int i = 0; i < R; ++i) {
            double sa = 0;
            for (int b = j * m; b < (j + 1) * m; ++b)
                for (int a = i * m; a < (i + 1) * m; ++a) {
                    // Quadrant of the sub-square's centre (in [-1,1]^2): the crease runs along the
                    // anti-diagonal in quadrants where u' v' > 0, along the diagonal otherwise.
                    double cu = 2.0 * (a + 0.5) / n - 1, cv = 2.0 * (b + 0.5) / n - 1;
                    auto p00 = P(a, b), p10 = P(a + 1, b), p01 = P(a, b + 1), p11 = P(a + 1, b + 1);
                    if (cu * cv > 0)
                        sa += triangle_solid_angle(p00, p10, p01) + triangle_solid_angle(p11, p01, p10);
                    else
                        sa += triangle_solid_angle(p00, p10, p11) + triangle_solid_angle(p00, p11, p01);
                }
            EXPECT_NEAR(sa / (kFourPi / (R * R)), 1.0, 1e-3) << "texel (" << i << ", " << j << ")";
            all += sa;
        }
    EXPECT_NEAR(all / kFourPi, 1.0, 1e-4);
    EXPECT_FLOAT_EQ(sphere_texel_solid_angle(R), float(kFourPi / 64));
}

// ---- texels and their neighbours -----------------------------------------------------------------------

TEST(SphereMapTexels, TexelOfCenterIsTheTexel) {
    for (int R : {1, 2, 3, 5, 16, 64})
        for (int j = 0; j < R; ++j)
            for (int i = 0; i < R; ++i) ASSERT_EQ(sphere_texel_of(sphere_texel_center(i, j, R), R), j * R + i);
}

TEST(SphereMapTexels, FoldsAcrossTheBorderByHand) {
    const int R = 4;
    auto idx = [&](int i, int j) { return j * R + i; };
    EXPECT_EQ(sphere_texel_neighbour(1, 3, 0, 1, R), idx(2, 3));   // across the top edge
    EXPECT_EQ(sphere_texel_neighbour(1, 0, 0, -1, R), idx(2, 0));  // across the bottom edge
    EXPECT_EQ(sphere_texel_neighbour(0, 1, -1, 0, R), idx(0, 2));  // across the left edge
    EXPECT_EQ(sphere_texel_neighbour(3, 0, 1, 0, R), idx(3, 3));   // across the right edge
    EXPECT_EQ(sphere_texel_neighbour(3, 3, 1, 1, R), idx(0, 0));   // across the -z corner
    EXPECT_EQ(sphere_texel_neighbour(0, 3, -1, 1, R), idx(3, 0));
    EXPECT_EQ(sphere_texel_neighbour(1, 3, 1, 1, R), idx(1, 3));   // (2, 4) folds onto (1, 3)
    EXPECT_EQ(sphere_texel_neighbour(2, 2, 1, -1, R), idx(3, 1));  // interior: plain offset
    // R = 1: every neighbour is the one texel.
    for (int di = -1; di <= 1; ++di)
        for (int dj = -1; dj <= 1; ++dj) EXPECT_EQ(sphere_texel_neighbour(0, 0, di, dj, 1), 0);
}

// The fold must follow the sphere: neighbouring texels' centres are close on the sphere, no farther
// apart than neighbours inside the square (for even R the fold is the mirror image, under z -> -z,
// of the crossing of the interior axes, so the bound is exact up to rounding), and the 8-neighbour
// relation is symmetric. A toroidal wrap fails this (it joins texels ~90-180 degrees apart).
TEST(SphereMapTexels, NeighboursAcrossFoldsAreCloseOnTheSphere) {
    for (int R : {2, 3, 4, 5, 8, 16, 64}) {
        double max_inside = 0, max_folded = 0;
        std::vector<std::set<int>> nb(size_t(R * R));
        for (int j = 0; j < R; ++j)
            for (int i = 0; i < R; ++i)
                for (int dj = -1; dj <= 1; ++dj)
                    for (int di = -1; di <= 1; ++di) {
                        if (!di && !dj) continue;
                        int k = sphere_texel_neighbour(i, j, di, dj, R);
                        ASSERT_GE(k, 0);
                        ASSERT_LT(k, R * R);
                        double a = angle_between(sphere_texel_center(i, j, R), sphere_texel_center(k % R, k / R, R));
                        bool folded = i + di < 0 || i + di >= R || j + dj < 0 || j + dj >= R;
                        (folded ? max_folded : max_inside) = std::max(folded ? max_folded : max_inside, a);
                        nb[size_t(j * R + i)].insert(k);
                    }
        for (int s = 0; s < R * R; ++s)
            for (int t : nb[size_t(s)])
                if (t != s) {
                    EXPECT_TRUE(nb[size_t(t)].count(s)) << "R=" << R << " " << s << " -> " << t;
                }
        if (R % 2 == 0)
            EXPECT_LE(max_folded, max_inside * (1 + 1e-5)) << "R=" << R;
        else
            EXPECT_LE(max_folded, max_inside * 1.5) << "R=" << R;
        // Absolute sanity: ~ a texel diagonal, sqrt(2 * 4 pi / R^2) with the map's distortion.
        EXPECT_LE(max_folded, 2.2 * std::sqrt(kFourPi / (R * R))) << "R=" << R;
    }
}

// ---- splat ----------------------------------------------------------------------------------------------

TEST(SphereMapSplat, BilinearSplatConservesTheTotal) {
    for (int R : {1, 2, 3, 16, 64}) {
        SphereMap m(R);
        Rng rng(5, uint64_t(R));
        double expected = 0;
        for (Vec3 w : special_directions()) {
            m.splat(w, 0.5f);
            expected += 0.5;
        }
        for (int i = 0; i < 20000; ++i) {
            float v = rng.next_float();
            m.splat(uniform_direction(rng), v);
            expected += v;
        }
        EXPECT_NEAR(m.total() / expected, 1.0, 1e-5) << "R=" << R;
        for (int k = 0; k < m.size(); ++k) EXPECT_GE(m[k], 0.0f);
    }
}

TEST(SphereMapSplat, SplatsFollowTheFolds) {
    const int R = 8;
    auto idx = [&](int i, int j) { return j * R + i; };
    {  // -z: the four corner texels, a quarter each
        SphereMap m(R);
        m.splat({0, 0, -1}, 1.0f);
        for (int k : {idx(0, 0), idx(R - 1, 0), idx(0, R - 1), idx(R - 1, R - 1)}) EXPECT_NEAR(m[k], 0.25f, 1e-6f);
    }
    {  // +z: the four centre texels, a quarter each
        SphereMap m(R);
        m.splat({0, 0, 1}, 1.0f);
        for (int k : {idx(3, 3), idx(4, 3), idx(3, 4), idx(4, 4)}) EXPECT_NEAR(m[k], 0.25f, 1e-6f);
    }
    {  // +y (top edge midpoint): the two edge texels on either side, half each
        SphereMap m(R);
        m.splat({0, 1, 0}, 1.0f);
        EXPECT_NEAR(m[idx(3, R - 1)], 0.5f, 1e-6f);
        EXPECT_NEAR(m[idx(4, R - 1)], 0.5f, 1e-6f);
    }
    {  // a texel centre: all of it in that texel (up to the round trip's rounding)
        SphereMap m(R);
        m.splat(sphere_texel_center(2, 6, R), 1.0f);
        EXPECT_NEAR(m[idx(2, 6)], 1.0f, 1e-5f);
    }
    {  // just inside the top edge, near its left end: a quarter-ish goes to the folded mirror texel
        SphereMap m(R);
        Vec3 w = square_to_sphere({1.0f / R, 1.0f - 0.01f / R});
        m.splat(w, 1.0f);
        // Continuous coords: x = 0.5 (between texels 0 and 1), y = R - 0.51 (above texel R-1's centre):
        // the upper half of the stencil folds onto texels and.
        EXPECT_NEAR(m[idx(0, R - 1)] + m[idx(1, R - 1)], 0.51f, 1e-4f);
        EXPECT_NEAR(m[idx(R - 1, R - 1)] + m[idx(R - 2, R - 1)], 0.49f, 1e-4f);
        EXPECT_NEAR(m[idx(0, 0)] + m[idx(1, 0)], 0.0f, 0.0f);  // a toroidal wrap would put it here
    }
}

// ---- Gaussian filter --------------------------------------------------------------------------------------

TEST(SphereFilterTest, ConservesTheTotal) {
    for (int R : {1, 2, 3, 16, 64})
        for (float sigma : {0.0f, 0.02f, 0.1f, 0.3f, 1.5f}) {
            if (R == 64 && sigma > 0.5f) continue;  // N^2 taps: fine, but slow for a unit test
            SphereMap m(R);
            Rng rng(9, uint64_t(R));
            for (int i = 0; i < 3000; ++i) m.splat(uniform_direction(rng), rng.next_float());
            for (int i = 0; i < 200; ++i) m.splat({0, 0, -1}, 1.0f);  // a peak at the corners
            double before = m.total();
            SphereFilter f(R, sigma);
            m.filter(f);
            EXPECT_NEAR(m.total() / before, 1.0, 2e-6) << "R=" << R << " sigma=" << sigma;
            for (int k = 0; k < m.size(); ++k) ASSERT_GE(m[k], 0.0f);
        }
}

TEST(SphereFilterTest, ZeroSigmaIsTheIdentity) {
    SphereMap m(16), orig(16);
    Rng rng(1, 1);
    for (int k = 0; k < m.size(); ++k) orig[k] = m[k] = rng.next_float();
    m.gaussian_filter(0.0f);
    for (int k = 0; k < m.size(); ++k) EXPECT_EQ(m[k], orig[k]);
}

// A delta's filtered image depends only on angular distance from it: out_t = g(theta_st) / W_s.
TEST(SphereFilterTest, DeltaSpreadsAsAGaussianOfAngle) {
    const int R = 16;
    const float sigma = 0.2f;
    SphereFilter f(R, sigma);
    for (int s : {0, 5 * R + 15, 8 * R + 8, 15 * R + 3, 7 * R + 0}) {
        std::vector<float> in(size_t(R * R), 0.0f), out(in.size());
        in[size_t(s)] = 1.0f;
        f.apply(in.data(), out.data());
        Vec3 cs = sphere_texel_center(s % R, s / R, R);
        double norm = out[size_t(s)];  // = 1 / W_s
        for (int t = 0; t < R * R; ++t) {
            double th = angle_between(cs, sphere_texel_center(t % R, t / R, R));
            double expect = th <= 3 * sigma ? norm * std::exp(-th * th / (2.0 * sigma * sigma)) : 0.0;
            EXPECT_NEAR(out[size_t(t)], expect, 1e-6 + 1e-4 * expect) << "s=" << s << " t=" << t;
        }
    }
}

// Mirror symmetries of the octahedral layout, as texel permutations (R even): x -> -x is i -> R-1-i,
// x <-> y is the transpose, and z -> -z maps the inner diamond onto the corner triangles — the fold of
// the square's border onto the interior axes. Filtering must commute with all of them: a delta near
// the border (or at -z, where the four corners meet) spreads exactly like its mirror image in the
// interior. Found via directions so the test does not trust the index formulas.
TEST(SphereFilterTest, FilterCommutesWithTheSpheresMirrorSymmetries) {
    const int R = 16;
    SphereFilter f(R, 0.15f);
    auto permutation = [&](auto mirror) {
        std::vector<int> p(size_t(R * R));
        for (int k = 0; k < R * R; ++k) p[size_t(k)] = sphere_texel_of(mirror(sphere_texel_center(k % R, k / R, R)), R);
        std::set<int> distinct(p.begin(), p.end());
        EXPECT_EQ(int(distinct.size()), R * R);  // a true permutation of texels
        return p;
    };
    std::vector<std::vector<int>> perms = {
        permutation([](Vec3 w) { return Vec3(-w.x, w.y, w.z); }),
        permutation([](Vec3 w) { return Vec3(w.y, w.x, w.z); }),
        permutation([](Vec3 w) { return Vec3(w.x, w.y, -w.z); }),
    };
    auto idx = [&](int i, int j) { return j * R + i; };
    // Deltas: at the -z corner texel, next to the top edge, next to a corner, at a random spot; and a
    // random map.
    std::vector<std::vector<float>> inputs;
    for (int s : {idx(0, 0), idx(5, R - 1), idx(R - 1, 1), idx(6, 9)}) {
        std::vector<float> d(size_t(R * R), 0.0f);
        d[size_t(s)] = 1.0f;
        inputs.push_back(d);
    }
    Rng rng(3, 3);
    std::vector<float> rnd(size_t(R * R));
    for (float& v : rnd) v = rng.next_float();
    inputs.push_back(rnd);
    for (const auto& p : perms)
        for (const auto& in : inputs) {
            std::vector<float> mirrored_in(in.size()), out(in.size()), out_of_mirrored(in.size());
            for (int k = 0; k < R * R; ++k) mirrored_in[size_t(p[size_t(k)])] = in[size_t(k)];
            f.apply(in.data(), out.data());
            f.apply(mirrored_in.data(), out_of_mirrored.data());
            for (int k = 0; k < R * R; ++k)
                ASSERT_NEAR(out_of_mirrored[size_t(p[size_t(k)])], out[size_t(k)], 1e-6f + 1e-5f * out[size_t(k)]);
        }
}

// Across the square's top edge, a delta reaches the folded mirror texel (a direct neighbour on the
// sphere, about one texel spacing away) with the Gaussian weight of its angle, relative to the interior
// neighbour below it; nothing reaches the opposite edge (where a toroidal wrap would put mass).
TEST(SphereFilterTest, DeltaCrossesTheBorderLikeTheInterior) {
    const int R = 16;
    const float sigma = 0.12f;
    auto idx = [&](int i, int j) { return j * R + i; };
    SphereMap m(R);
    m.at(5, R - 1) = 1.0f;
    m.gaussian_filter(sigma);
    const float across = m[idx(R - 1 - 5, R - 1)], below = m[idx(5, R - 2)];
    const Vec3 cs = sphere_texel_center(5, R - 1, R);
    const double th_across = angle_between(cs, sphere_texel_center(R - 1 - 5, R - 1, R));
    const double th_below = angle_between(cs, sphere_texel_center(5, R - 2, R));
    EXPECT_LE(th_across, 1.2 * std::sqrt(kFourPi / (R * R)));  // a neighbour on the sphere
    EXPECT_GT(across, 0.01f);
    EXPECT_NEAR(across / below, std::exp((th_below * th_below - th_across * th_across) / (2.0 * sigma * sigma)), 1e-4);
    for (int i = 0; i < R; ++i) EXPECT_EQ(m[idx(i, 0)], 0.0f);
    // Around -z: from a delta in one corner texel, the two corner texels across the folds (mirror
    // images of each other under x <-> y) receive the same, and the diagonal one receives some too.
    SphereMap c(R);
    c.at(0, 0) = 1.0f;
    c.gaussian_filter(0.2f);
    EXPECT_NEAR(c[idx(R - 1, 0)], c[idx(0, R - 1)], 1e-6f);
    EXPECT_GT(c[idx(R - 1, R - 1)], 0.0f);
}

// ---- floor and distribution -------------------------------------------------------------------------

TEST(SphereMapFloor, FloorMakesEveryTexelPositive) {
    for (int R : {1, 2, 3, 16, 64}) {
        SphereMap m(R);
        m.splat(unit(0.3, -0.2, 0.9), 7.0f);
        const float f = 0.02f;
        m.normalise_floor(f);
        EXPECT_NEAR(m.total(), 1.0, 1e-6);
        for (int k = 0; k < m.size(); ++k) ASSERT_GE(m[k], f / m.size() * (1 - 1e-6f)) << "R=" << R;
        SphereDistribution d(m);
        for (int k = 0; k < m.size(); ++k) ASSERT_GT(d.pmf(k), 0.0f);
    }
    SphereMap empty(8);
    empty.normalise_floor(0.0f);  // no information: uniform
    for (int k = 0; k < empty.size(); ++k) EXPECT_FLOAT_EQ(empty[k], 1.0f / 64);
    EXPECT_THROW(empty.normalise_floor(-0.1f), std::invalid_argument);
    EXPECT_THROW(empty.normalise_floor(1.5f), std::invalid_argument);
}

// A peaky map as fill-caches makes them: a few clusters of splats, filtered, floored.
SphereMap peaky_map(int R, uint64_t seed, float floor = 0.01f) {
    SphereMap m(R);
    Rng rng(seed, 17);
    for (int c = 0; c < 3; ++c) {
        Vec3 centre = uniform_direction(rng);
        for (int p = 0; p < 300; ++p) {
            Vec3 w = normalize(centre + 0.15f * Vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
            m.splat(w, 1.0f + 3.0f * c);
        }
    }
    m.splat({0, 0, -1}, 40.0f);  // and some at the corner pole
    m.gaussian_filter(0.08f);
    m.normalise_floor(floor);
    return m;
}

TEST(SphereDistributionTest, TablesAreConsistent) {
    for (int R : {1, 2, 3, 16, 64}) {
        SphereDistribution d(peaky_map(R, 1));
        const int n = d.size();
        const auto& cdf = d.cdf();
        const auto& pdf = d.pdf_table();
        EXPECT_EQ(cdf[size_t(n - 1)], 1.0f);
        double mass = 0;
        for (int k = 0; k < n; ++k) {
            if (k) {
                ASSERT_GE(cdf[size_t(k)], cdf[size_t(k - 1)]);
            }
            ASSERT_TRUE(std::isfinite(pdf[size_t(k)]));
            ASSERT_GT(pdf[size_t(k)], 0.0f);
            mass += double(pdf[size_t(k)]) * kFourPi / n;  // density x texel solid angle
        }
        EXPECT_NEAR(mass, 1.0, 1e-5) << "R=" << R;
        // By quadrature over the sphere (independent of the texel bookkeeping).
        EXPECT_NEAR(test::integrate_sphere([&](Vec3 w) { return d.pdf(w); }, 400, 800), 1.0, 5e-3) << "R=" << R;
    }
}

TEST(SphereDistributionTest, ZeroWeightTexelsAreNeverSampled) {
    const int R = 4;
    std::vector<float> w(16, 0.0f);
    w[0] = 0.0f;
    w[5] = 1.0f;
    w[6] = 3.0f;  // last positive; texels 7.. are zero
    SphereDistribution d(w.data(), R);
    for (int k = 0; k < 16; ++k) EXPECT_EQ(d.pmf(k) > 0, k == 5 || k == 6) << k;
    EXPECT_FLOAT_EQ(d.pmf(5), 0.25f);
    Rng rng(2, 2);
    for (int i = 0; i < 100000; ++i) {
        float p;
        Vec3 s = d.sample({rng.next_float(), rng.next_float()}, &p);
        int k = sphere_texel_of(s, R);
        ASSERT_TRUE(k == 5 || k == 6 || p == 0.0f);
        ASSERT_EQ(p, d.pdf(s));
    }
    // All zero: uniform.
    std::vector<float> z(16, 0.0f);
    SphereDistribution u(z.data(), R);
    for (int k = 0; k < 16; ++k) EXPECT_NEAR(u.pdf_table()[size_t(k)], kInv4Pi, 1e-6f);
    std::vector<float> bad(16, 1.0f);
    bad[3] = -1.0f;
    EXPECT_THROW(SphereDistribution(bad.data(), R), std::invalid_argument);
    bad[3] = NAN;
    EXPECT_THROW(SphereDistribution(bad.data(), R), std::invalid_argument);
}

// The density sample() reports is bit-for-bit what pdf() says for the returned direction, for random
// u, for a stratified grid, and for u that put the point exactly on texel edges, the square's border
// and the poles (where the edge margin re-derives the texel).
TEST(SphereDistributionTest, SampleReportsExactlyThePdf) {
    for (int R : {1, 2, 3, 16, 64}) {
        SphereDistribution d(peaky_map(R, 7));
        const auto& cdf = d.cdf();
        std::vector<Vec2> us;
        Rng rng(4, uint64_t(R));
        for (int i = 0; i < 200000; ++i) us.push_back({rng.next_float(), rng.next_float()});
        for (int a = 0; a < 300; ++a)
            for (int b = 0; b < 300; ++b) us.push_back({(a + 0.5f) / 300, (b + 0.5f) / 300});
        for (int k = 0; k < d.size(); ++k) {
            float lo = k ? cdf[size_t(k - 1)] : 0.0f;
            for (float ux : {lo, std::nextafter(cdf[size_t(k)], 0.0f), 0.5f * (lo + cdf[size_t(k)])})
                for (float uy : {0.0f, 0.5f, 0x1.fffffep-1f, 1e-7f}) us.push_back({ux, uy});
        }
        us.push_back({1.0f, 1.0f});  // out of range: clamped
        us.push_back({-0.0f, 0.0f});
        for (Vec2 u : us) {
            float p = -1;
            Vec3 w = d.sample(u, &p);
            ASSERT_TRUE(is_finite(w));
            ASSERT_NEAR(length(w), 1.0f, 1e-5f);
            ASSERT_EQ(p, d.pdf(w)) << "R=" << R << " u=(" << u.x << ", " << u.y << ")";
            ASSERT_GT(p, 0.0f);
            // Null pdf pointer is allowed and gives the same direction.
            Vec3 w2 = d.sample(u, nullptr);
            ASSERT_EQ(w.x, w2.x);
            ASSERT_EQ(w.z, w2.z);
        }
    }
}

// The branch-free cdf search is std::upper_bound, including at exact cdf values and zero-width runs.
TEST(SphereDistributionTest, CdfSearchIsUpperBound) {
    Rng rng(12, 12);
    for (int R : {1, 2, 3, 4, 16, 64}) {
        const int n = R * R;
        std::vector<float> w(static_cast<size_t>(n));
        for (int k = 0; k < n; ++k) w[size_t(k)] = rng.next_float() < 0.3f ? 0.0f : rng.next_float();
        w[0] = 0.0f;
        w[size_t(n - 1)] = 1.0f;
        SphereDistribution d(w.data(), R);
        const float* cdf = d.cdf().data();
        std::vector<float> us = {0.0f, 0x1.fffffep-1f};
        for (int k = 0; k < n; ++k) {
            us.push_back(cdf[k]);
            us.push_back(std::nextafter(cdf[k], 0.0f));
        }
        for (int i = 0; i < 10000; ++i) us.push_back(rng.next_float());
        for (float u : us) {
            if (!(u < 1.0f)) continue;
            ASSERT_EQ(SphereDistribution::search_cdf(cdf, n, u), int(std::upper_bound(cdf, cdf + n, u) - cdf))
                << "R=" << R << " u=" << u;
        }
    }
}

TEST(SphereDistributionTest, InvertRoundTrips) {
    for (int R : {1, 3, 16, 64}) {
        SphereDistribution d(peaky_map(R, 3, 0.05f));
        Rng rng(8, uint64_t(R));
        int checked = 0;
        for (int i = 0; i < 100000; ++i) {
            Vec2 u{rng.next_float(), rng.next_float()};
            Vec3 w = d.sample(u, nullptr);
            // Skip points within rounding of a texel edge (they may invert into the neighbour).
            Vec2 q = sphere_to_square(w);
            float fx = q.x * R - std::floor(q.x * R), fy = q.y * R - std::floor(q.y * R);
            if (std::min({fx, 1 - fx, fy, 1 - fy}) < 1e-3f) continue;
            Vec2 v = d.invert(w);
            // u.x's error is the square's round-trip error times the texel's pmf times R.
            ASSERT_NEAR(v.x, u.x, 1e-5f) << "R=" << R;
            ASSERT_NEAR(v.y, u.y, 1e-4f) << "R=" << R;
            ++checked;
        }
        EXPECT_GT(checked, 90000);
    }
}

TEST(SphereDistributionTest, SpecialDirectionsHaveFinitePositivePdf) {
    for (int R : {1, 2, 3, 16, 64}) {
        SphereDistribution d(peaky_map(R, 5));
        for (Vec3 w : special_directions()) {
            float p = d.pdf(w);
            EXPECT_TRUE(std::isfinite(p) && p > 0) << "R=" << R << " w=(" << w.x << ", " << w.y << ", " << w.z << ")";
            Vec2 u = d.invert(w);
            EXPECT_TRUE(u.x >= 0 && u.x < 1 && u.y >= 0 && u.y < 1);
        }
    }
}

// The static overloads on raw tables (how the renderer reads an atlas) agree with the object.
TEST(SphereDistributionTest, FlatTablesMatchTheObject) {
    const int R = 16, n = R * R;
    SphereMap m = peaky_map(R, 9);
    SphereDistribution d(m);
    // An "atlas" of three caches in one flat array; ours is the middle one.
    std::vector<float> cdf(3 * size_t(n), -1.0f), pdf(3 * size_t(n), -1.0f);
    SphereDistribution::build(m.data(), R, cdf.data() + n, pdf.data() + n);
    for (int k = 0; k < n; ++k) {
        ASSERT_EQ(cdf[size_t(n + k)], d.cdf()[size_t(k)]);
        ASSERT_EQ(pdf[size_t(n + k)], d.pdf_table()[size_t(k)]);
    }
    Rng rng(6, 6);
    for (int i = 0; i < 10000; ++i) {
        Vec2 u{rng.next_float(), rng.next_float()};
        float p0, p1;
        Vec3 a = d.sample(u, &p0), b = SphereDistribution::sample(cdf.data() + n, pdf.data() + n, R, u, &p1);
        ASSERT_EQ(a.x, b.x);
        ASSERT_EQ(a.y, b.y);
        ASSERT_EQ(a.z, b.z);
        ASSERT_EQ(p0, p1);
        ASSERT_EQ(SphereDistribution::pdf(pdf.data() + n, R, b), p1);
    }
}

TEST(SphereMapTest, RejectsBadResolutionsAndMismatchedFilters) {
    EXPECT_THROW(SphereMap(0), std::invalid_argument);
    EXPECT_THROW(SphereMap(257), std::invalid_argument);
    SphereMap m(8);
    SphereFilter f(16, 0.1f);
    EXPECT_THROW(m.filter(f), std::invalid_argument);
}

}  // namespace
}  // namespace iris
