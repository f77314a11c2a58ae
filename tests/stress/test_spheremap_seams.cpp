// Stress: the equal-area octahedral sphere map (libcommon/spheremap.h) exactly on its seams, edges,
// folds and poles, at every map resolution 1..64.
//
// Guards the guided renderer's hot path against the inputs that float rounding produces in practice
// and that random tests almost never hit: the six axis directions, directions on the octahedron's
// edges (the equator and the x = 0 / y = 0 meridians, whose lower halves are the square's fold lines),
// directions one ULP off them, signed zeros and subnormal components, map coordinates exactly 0, 0.5,
// 1 and 1 - ulp, and sample inputs u = 0 and u = 1 - ulp. A texel index out of range there reads
// outside an atlas row; a NaN or a zero density there is a NaN or an infinite weight in an image.
// Checks: indices in range, direction -> map -> direction round trips, densities finite and > 0 with a
// floor, samples unit with the density pdf() reports, and splats conserve their mass.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "libcommon/rng.h"
#include "libcommon/spheremap.h"

using namespace iris;

namespace {

constexpr float kOneMinusUlp = 0x1.fffffep-1f;
const float kTiny = std::numeric_limits<float>::denorm_min();

double angle_between(Vec3 a, Vec3 b) {
    const double ax = a.x, ay = a.y, az = a.z, bx = b.x, by = b.y, bz = b.z;
    const double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
    return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz);
}

Vec3 unit(double x, double y, double z) {
    const double l = std::sqrt(x * x + y * y + z * z);
    return Vec3(float(x / l), float(y / l), float(z / l));
}

std::string str(Vec3 w) {
    char b[160];
    std::snprintf(b, sizeof b, "(%a, %a, %a)", w.x, w.y, w.z);
    return b;
}

// Directions on every seam of the layout, plus their one-ULP neighbours and signed-zero variants.
std::vector<Vec3> seam_directions() {
    std::vector<Vec3> base;
    // The six axes and the eight octant centres.
    for (int a = 0; a < 3; ++a)
        for (float s : {1.0f, -1.0f}) {
            Vec3 w(0.0f);
            w[a] = s;
            base.push_back(w);
        }
    for (int sx : {-1, 1})
        for (int sy : {-1, 1})
            for (int sz : {-1, 1}) base.push_back(unit(sx, sy, sz));
    // Edges of the octahedron: the equator (z = 0), the meridians x = 0 and y = 0 (lower halves: folds).
    for (int k = 0; k < 48; ++k) {
        const double t = 2 * M_PI * k / 48.0;
        base.push_back(unit(std::cos(t), std::sin(t), 0));
        base.push_back(unit(0, std::cos(t), std::sin(t)));
        base.push_back(unit(std::cos(t), 0, std::sin(t)));
    }
    // Next to the poles: tiny and subnormal tangential components.
    for (float e : {kTiny, 1e-30f, 1e-20f, 1e-12f, 1e-7f, 3e-4f})
        for (float z : {1.0f, -1.0f}) {
            base.push_back(Vec3(e, 0.0f, z));
            base.push_back(Vec3(0.0f, -e, z));
            base.push_back(Vec3(-e, e, z));
        }
    std::vector<Vec3> out;
    for (Vec3 w : base) {
        out.push_back(w);
        // Signed zeros: -0 must behave as +0 (same texel for equal directions).
        Vec3 m = w;
        for (int c = 0; c < 3; ++c)
            if (m[c] == 0.0f) m[c] = -0.0f;
        out.push_back(m);
        // One ULP either way on each component (still unit to float rounding).
        for (int c = 0; c < 3; ++c)
            for (float dir : {-2.0f, 2.0f}) {
                Vec3 p = w;
                p[c] = std::nextafter(p[c], dir);
                out.push_back(p);
            }
    }
    return out;
}

const std::vector<int>& resolutions() {
    static const std::vector<int> r = [] {
        std::vector<int> v;
        for (int R = 1; R <= 64; ++R) v.push_back(R);
        return v;
    }();
    return r;
}

// A map with structure (a peak, zeros) at resolution R, floored with fraction f.
SphereMap floored_map(int R, float f, uint64_t seed) {
    SphereMap m(R);
    Rng rng = Rng::for_index(seed, Stream::Test, uint64_t(R));
    for (int k = 0; k < m.size(); ++k) m.data()[k] = rng.next_float() < 0.5f ? 0.0f : rng.next_float() * rng.next_float();
    m.data()[0] = 50.0f;  // a peak in a corner texel (-z)
    m.normalise_floor(f);
    return m;
}

}  // namespace

// Direction -> square -> direction on every seam: in range, unit, the same direction back, and the
// texel index in range for every resolution.
TEST(SphereMapSeams, SeamDirectionsRoundTripAndIndexInRange) {
    for (Vec3 w : seam_directions()) {
        const Vec2 uv = sphere_to_square(w);
        ASSERT_TRUE(uv.x >= 0 && uv.x <= 1 && uv.y >= 0 && uv.y <= 1) << str(w);
        const Vec3 back = square_to_sphere(uv);
        ASSERT_TRUE(std::isfinite(back.x) && std::isfinite(back.y) && std::isfinite(back.z)) << str(w);
        EXPECT_NEAR(length(back), 1.0, 1e-6) << str(w);
        EXPECT_LT(angle_between(back, w), 2e-6) << str(w) << " -> " << uv.x << ", " << uv.y << " -> " << str(back);
        // A direction and its signed-zero twin land on the same square point.
        Vec3 m = w;
        for (int c = 0; c < 3; ++c)
            if (m[c] == 0.0f) m[c] = -0.0f;
        const Vec2 uvm = sphere_to_square(m);
        EXPECT_EQ(uv.x, uvm.x) << str(w);
        EXPECT_EQ(uv.y, uvm.y) << str(w);
        for (int R : resolutions()) {
            const int k = sphere_texel_of(w, R);
            ASSERT_TRUE(k >= 0 && k < R * R) << str(w) << " R=" << R << " texel " << k;
            // The texel holds the direction: its centre is within the texel's angular extent. (Texels
            // are equal-area but stretched near the folds; 2.5 texel diagonals bound every one.)
            const Vec3 c = sphere_texel_center(k % R, k / R, R);
            const double extent = 2.5 * std::sqrt(2.0) * std::sqrt(4 * M_PI / (R * R)) + 1e-4;
            EXPECT_LT(angle_between(c, w), std::max(extent, 1e-3)) << str(w) << " R=" << R;
        }
    }
}

// Square -> direction -> square at coordinates exactly 0, 0.5, 1, 1 - ulp and their neighbours: the
// direction is unit and finite, and mapping it back gives the same direction (the point itself, or its
// mirror image across a fold: both are the same direction).
TEST(SphereMapSeams, ExactSquareCoordinatesRoundTrip) {
    const float cs[] = {0.0f, kTiny, 1e-30f, 1e-7f, 0.25f, std::nextafter(0.5f, 0.0f), 0.5f, std::nextafter(0.5f, 1.0f),
                        0.75f, 1 - 1e-7f, kOneMinusUlp, 1.0f};
    for (float u : cs)
        for (float v : cs) {
            const Vec3 w = square_to_sphere({u, v});
            ASSERT_TRUE(std::isfinite(w.x) && std::isfinite(w.y) && std::isfinite(w.z)) << u << ", " << v;
            EXPECT_NEAR(length(w), 1.0, 1e-6) << u << ", " << v;
            const Vec2 uv = sphere_to_square(w);
            ASSERT_TRUE(uv.x >= 0 && uv.x <= 1 && uv.y >= 0 && uv.y <= 1);
            const Vec3 again = square_to_sphere(uv);
            EXPECT_LT(angle_between(w, again), 2e-6) << "(" << u << ", " << v << ") -> " << str(w) << " -> (" << uv.x
                                                      << ", " << uv.y << ")";
            // Where the point is not on the border (no fold), the square point itself comes back.
            // (Within 1e-6 of the border counts as on it: rounding may put the point on either side of
            // the fold, and both are the same direction.)
            const bool border = std::min(std::min(u, 1 - u), std::min(v, 1 - v)) < 1e-6f;
            if (!border && angle_between(w, Vec3(0, 0, -1)) > 1e-3) {
                EXPECT_NEAR(uv.x, u, 2e-6) << u << ", " << v;
                EXPECT_NEAR(uv.y, v, 2e-6) << u << ", " << v;
            }
            for (int R : {1, 2, 3, 4, 7, 8, 16, 31, 32, 64}) {
                const int k = sphere_texel_of(w, R);
                ASSERT_TRUE(k >= 0 && k < R * R) << u << ", " << v << " R=" << R;
            }
        }
}

// Texel neighbours across folds and corners stay in range for every resolution and every step the
// filter and the splat can take.
TEST(SphereMapSeams, NeighbourIndicesStayInRange) {
    for (int R : resolutions())
        for (int i : {0, 1, R / 2, R - 2, R - 1})
            for (int j : {0, 1, R / 2, R - 2, R - 1}) {
                if (i < 0 || j < 0 || i >= R || j >= R) continue;
                for (int di = -1; di <= 1; ++di)
                    for (int dj = -1; dj <= 1; ++dj) {
                        const int k = sphere_texel_neighbour(i, j, di, dj, R);
                        ASSERT_TRUE(k >= 0 && k < R * R) << "R=" << R << " (" << i << "," << j << ")+(" << di << "," << dj << ")";
                    }
            }
}

// Splatting exactly on seams keeps every weight in range and conserves the splatted mass.
TEST(SphereMapSeams, SplatsOnSeamsConserveMass) {
    const std::vector<Vec3> dirs = seam_directions();
    for (int R : resolutions()) {
        SphereMap m(R);
        for (Vec3 w : dirs) m.splat(w, 1.0f);
        double total = 0;
        for (int k = 0; k < m.size(); ++k) {
            ASSERT_TRUE(std::isfinite(m.data()[k]) && m.data()[k] >= 0) << "R=" << R << " texel " << k;
            total += m.data()[k];
        }
        EXPECT_NEAR(total, double(dirs.size()), 1e-4 * dirs.size()) << "R=" << R;
    }
}

// With a floor, the density is finite and positive in every seam direction, at every resolution; the
// u that inverts it is in [0, 1)^2.
TEST(SphereMapSeams, FlooredDensityPositiveOnSeams) {
    const std::vector<Vec3> dirs = seam_directions();
    for (int R : resolutions()) {
        const SphereDistribution d(floored_map(R, 0.1f, 5));
        // The floor is f / (4 pi) per sr, up to the rounding of the float cdf: a texel's probability f / N
        // can lose up to two ULPs of the cdf near 1 (2 * 2^-24), i.e. a density of 2 * 2^-24 * N / (4 pi).
        const float min_pdf = float((0.1 - 2.0 * 0x1p-24 * R * R) / (4 * M_PI));
        for (Vec3 w : dirs) {
            const float p = d.pdf(w);
            ASSERT_TRUE(std::isfinite(p) && p >= min_pdf) << "R=" << R << " w=" << str(w) << " pdf " << p;
            const Vec2 u = d.invert(w);
            ASSERT_TRUE(u.x >= 0 && u.x < 1 && u.y >= 0 && u.y < 1) << "R=" << R << " w=" << str(w);
        }
    }
}

// Sampling with the extreme inputs u = 0, 1 - ulp (and out-of-range and NaN inputs, which must be
// clamped) returns unit directions whose reported density is exactly pdf() of the direction, > 0.
// Also without a floor (zero-probability texels at both ends of the table).
TEST(SphereMapSeams, ExtremeSampleInputsGiveUnitDirectionsWithMatchingPdf) {
    const float us[] = {0.0f, kTiny, 1e-7f, 0.5f, 1 - 1e-7f, kOneMinusUlp, 1.0f, -0.0f, -1.0f, 2.0f,
                        std::numeric_limits<float>::quiet_NaN()};
    for (int R : resolutions())
        for (int variant = 0; variant < 2; ++variant) {
            SphereMap m(R);
            if (variant == 0) {
                m = floored_map(R, 0.05f, 9);
            } else {
                // No floor: only texels strictly inside the table have weight (first and last are 0).
                if (R < 2) continue;
                for (int k = 1; k + 1 < m.size(); k += 2) m.data()[k] = 1.0f + float(k % 7);
            }
            const SphereDistribution d(m);
            for (float ux : us)
                for (float uy : us) {
                    float p = -1;
                    const Vec3 w = d.sample({ux, uy}, &p);
                    ASSERT_TRUE(std::isfinite(w.x) && std::isfinite(w.y) && std::isfinite(w.z))
                        << "R=" << R << " u=(" << ux << ", " << uy << ")";
                    EXPECT_NEAR(length(w), 1.0, 1e-6) << "R=" << R;
                    // With a floor the density is positive. Without one, 0 is allowed next to a zero
                    // texel: it is the documented "no sample" answer (the integrator stops the path).
                    EXPECT_TRUE(std::isfinite(p) && (p > 0 || (variant == 1 && p == 0)))
                        << "R=" << R << " variant " << variant << " u=(" << ux << ", " << uy << ") pdf " << p;
                    EXPECT_EQ(p, d.pdf(w)) << "R=" << R << " variant " << variant << " u=(" << ux << ", " << uy
                                           << ") w=" << str(w);
                }
        }
}

// The stored pdf table integrates to one at every resolution (texels cover exactly 4 pi / N sr), and
// the cdf ends at exactly 1.
TEST(SphereMapSeams, TablesIntegrateToOneAtEveryResolution) {
    for (int R : resolutions()) {
        const SphereDistribution d(floored_map(R, 0.1f, 3));
        double integral = 0;
        for (float p : d.pdf_table()) integral += double(p) * 4 * M_PI / double(R * R);
        EXPECT_NEAR(integral, 1.0, 1e-4) << "R=" << R;
        EXPECT_EQ(d.cdf().back(), 1.0f) << "R=" << R;
    }
}
