// The renderer's side of the cache atlas (libguide/guide.h) and the per-cache BSDF fraction
// (libguide/bsdf_fraction.h):
//   - the packed maps the guide samples are exact distributions within their quantisation of the atlas's;
//   - the guide's compile-time R = 32 path samples and evaluates bit for bit as the generic packed map;
//   - the lookup takes its grid cell's answer for the vertex's normal axis (the cache nearest the cell's
//     centre that serves some point of the cell) or, outside the grid, the nearest cache serving the
//     vertex, guiding or not, compared against brute force;
//   - the BSDF fraction: a cache whose distribution is the cosine gains nothing and is not used, a
//     peaked one gets a small alpha and a large predicted gain;
//   - hybrid caches' path samples: their effective count is their number where they are alike, and
//     about one where a single heavy sample carries the total.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

#include "libguide/bsdf_fraction.h"
#include "libguide/packed_map.h"
#include "libcommon/rng.h"
#include "libcommon/sampling.h"
#include "libcommon/spheremap.h"
#include "libguide/guide.h"

namespace iris {
namespace {

// Weights with exact zeros (10 %), a varying background and a few texels 50x brighter.
std::vector<float> lumpy_weights(int R, uint64_t seed) {
    Rng rng(seed, 1);
    std::vector<float> w(size_t(R * R));
    for (float& v : w) v = rng.next_float() < 0.1f ? 0.0f : 0.01f + rng.next_float();
    for (int i = 0; i < 3; ++i) w[size_t(rng.next_float() * float(R * R)) % w.size()] += 50.0f;
    return w;
}

// The packed map (libguide/packed_map.h) is an exact distribution of its own: its densities integrate
// to one, are zero exactly where the atlas's are, and its samples report exactly the density texel_pdf
// gives their direction. It stays within its rounding of the atlas's density: a row's count is within
// R counts of its exact share of 65535 (within one, except the largest row, which takes the rounding's
// total), and likewise a texel's count of its share of its row.
TEST(PackedMap, IsAnExactDistributionWithinItsRoundingOfTheAtlasMap) {
    for (int R : {1, 7, 16, 32, 256}) {
        SCOPED_TRACE("R " + std::to_string(R));
        const int N = R * R;
        const float per_sr = float(N) * kInv4Pi;
        std::vector<float> cdf(static_cast<size_t>(N)), pdf(static_cast<size_t>(N));
        SphereDistribution::build(lumpy_weights(R, uint64_t(R)).data(), R, cdf.data(), pdf.data());
        std::vector<unsigned char> storage(packed_map::bytes(R) + 64);
        unsigned char* map = storage.data() + (64 - reinterpret_cast<uintptr_t>(storage.data()) % 64) % 64;
        packed_map::encode(pdf.data(), R, map);
        const uint16_t* ends = packed_map::row_end(map);
        ASSERT_EQ(ends[R - 1], packed_map::kRowTotal);
        const double total = std::accumulate(pdf.begin(), pdf.end(), 0.0);
        for (int j = 0; j < R; ++j) {
            double row = 0;
            for (int i = 0; i < R; ++i) row += pdf[size_t(j * R + i)];
            const int count = int(ends[j]) - (j > 0 ? int(ends[j - 1]) : 0);
            ASSERT_GE(count, 0);
            EXPECT_EQ(count > 0, row > 0) << "row " << j;
            if (count > 0) {
                EXPECT_EQ(packed_map::texel_end(map, R, j)[R - 1], packed_map::kRowTotal) << "row " << j;
            }
            const double e_row = double(R) / (packed_map::kRowTotal * (row / total));
            for (int i = 0; i < R; ++i) {
                const int k = j * R + i;
                const float p = packed_map::texel_pdf(map, R, k, per_sr);
                EXPECT_EQ(p > 0, pdf[size_t(k)] > 0) << "texel " << k;
                if (!(pdf[size_t(k)] > 0)) continue;
                const double e_texel = double(R) / (packed_map::kRowTotal * (double(pdf[size_t(k)]) / row));
                const double ratio = double(p) / double(pdf[size_t(k)]);
                EXPECT_GE(ratio, std::max(0.0, 1 - e_row) * std::max(0.0, 1 - e_texel) * (1 - 1e-5)) << "texel " << k;
                EXPECT_LE(ratio, (1 + e_row) * (1 + e_texel) * (1 + 1e-5)) << "texel " << k;
            }
        }
        double sum = 0;
        for (int k = 0; k < N; ++k) sum += double(packed_map::texel_pdf(map, R, k, per_sr)) / double(per_sr);
        EXPECT_NEAR(sum, 1.0, 1e-5);

        Rng rng(99, 2);
        int zeros = 0;
        for (int s = 0; s < 20000; ++s) {
            // Include the ends of [0, 1) and values exactly on the rows' boundaries.
            Vec2 u{rng.next_float(), rng.next_float()};
            if (s % 97 == 0) u.x = float(ends[s % R]) / float(packed_map::kRowTotal);
            if (s == 1) u = {0.0f, 0.0f};
            if (s == 2) u = {0x1.fffffep-1f, 0x1.fffffep-1f};
            float p = -1;
            const Vec3 w = packed_map::sample(map, R, u, per_sr, &p);
            ASSERT_NEAR(length(w), 1.0f, 1e-5f);
            ASSERT_EQ(p, packed_map::texel_pdf(map, R, sphere_texel_of(w, R), per_sr)) << "u " << u.x << ", " << u.y;
            // Zero only where a point within kEdgeMargin of its texel's edge rounds across it into a zero
            // texel: u.x exactly on a row's start (the row's first positive texel at fx = 0) often does,
            // random u in a few in 10^4; a sampler that picked zero texels would give 10 %.
            zeros += p == 0 && s % 97 != 0 && s > 2;
        }
        EXPECT_LE(zeros, 20);
    }
}

// The SIMD count of cumulative counts at or below a threshold, against the plain loop: lengths that are
// and are not multiples of the vector width, thresholds on and beside entries, values past 32767 (where
// a signed 16-bit compare would go wrong).
TEST(PackedMap, CountAtOrBelowMatchesTheLoop) {
    Rng rng(5, 7);
    for (int n : {1, 3, 8, 13, 16, 32, 33, 64, 255}) {
        std::vector<uint16_t> a(static_cast<size_t>(n));
        uint32_t acc = 0;
        for (uint16_t& v : a) v = uint16_t(acc = std::min<uint32_t>(65535, acc + uint32_t(rng.next_float() * 700)));
        a.back() = 65535;
        for (int s = 0; s < 400; ++s) {
            uint32_t t = s % 3 == 0 ? a[size_t(s) % a.size()] : uint32_t(rng.next_float() * 65535);
            if (s % 3 == 1 && t > 0) --t;
            int expected = 0;
            for (uint16_t v : a) expected += v <= t;
            ASSERT_EQ(packed_map::count_at_or_below(a.data(), n, t), expected) << "n " << n << ", t " << t;
        }
    }
}

TEST(PackedMap, AllZeroDensityPacksAsUniform) {
    const int R = 8;
    std::vector<float> zero(size_t(R * R), 0.0f);
    std::vector<unsigned char> map(packed_map::bytes(R));
    packed_map::encode(zero.data(), R, map.data());
    // Each row's share of 65535 counts is 8191.875: seven get 8192, the first 8191; so do the texels of
    // each row.
    for (int k = 0; k < R * R; ++k)
        EXPECT_NEAR(packed_map::texel_pdf(map.data(), R, k, float(R * R) * kInv4Pi), kInv4Pi, kInv4Pi * 2.01 / 8192) << "texel " << k;
}

// An atlas of caches on two parallel planes facing each other (normals +z at z = 0, -z at z = 1),
// with varied radii; every map uniform.
CacheAtlas plane_atlas(size_t n, uint64_t seed) {
    Rng rng(seed, 3);
    CacheAtlas a;
    a.resolution = 4;
    a.k = 10;
    a.floor = 0.1;
    a.filter = "none";
    const size_t N = a.texels();
    for (size_t c = 0; c < n; ++c) {
        const bool top = c % 2 == 1;
        a.position.push_back({rng.next_float() * 10, rng.next_float() * 10, top ? 1.0f : 0.0f});
        a.normal.push_back({0, 0, top ? -1.0f : 1.0f});
        a.radius.push_back(0.05f + 0.5f * rng.next_float() * rng.next_float());
        a.photon_count.push_back(10);
        a.usable.push_back(c % 7 == 3 ? 0 : 1);  // some unusable: they claim vertices but never guide
    }
    std::vector<float> w(N, 1.0f);
    a.pdf.resize(n * N);
    a.cdf.resize(n * N);
    for (size_t c = 0; c < n; ++c) SphereDistribution::build(w.data(), a.resolution, &a.cdf[c * N], &a.pdf[c * N]);
    return a;
}

// The guide's per-vertex map functions see R = 32 as a compile-time constant (Guide::at_resolution);
// they must give bit for bit what the packed map gives for a resolution known only at run time: the
// same samples and densities, and the density of a sample's direction is the one it was drawn with.
TEST(GuideSampling, ConstantResolutionAgreesWithTheRuntimeOne) {
    volatile int runtime_r = 32;  // not foldable: the packed map's generic code
    const int R = runtime_r;
    const int N = R * R;
    const float per_sr = float(N) * kInv4Pi;
    CacheAtlas a = plane_atlas(4, 11);
    a.resolution = 32;
    a.pdf.assign(a.size() * size_t(N), 0.0f);
    a.cdf.assign(a.size() * size_t(N), 0.0f);
    for (size_t c = 0; c < a.size(); ++c) {
        a.usable[c] = 1;
        SphereDistribution::build(lumpy_weights(R, 100 + c).data(), R, &a.cdf[c * size_t(N)], &a.pdf[c * size_t(N)]);
    }
    const Guide guide(a, 0.25f);
    std::vector<unsigned char> storage(packed_map::bytes(R) + 64);
    unsigned char* map = storage.data() + (64 - reinterpret_cast<uintptr_t>(storage.data()) % 64) % 64;
    Rng rng(7, 2);
    for (int c = 0; c < int(a.size()); ++c) {
        packed_map::encode(a.pdf_row(size_t(c)), R, map);
        const Frame frame(a.normal[size_t(c)]);
        for (int s = 0; s < 2000; ++s) {
            const Vec2 u{rng.next_float(), rng.next_float()};
            float p_guide = 0, p_map = 0;
            const Vec3 w = guide.sample(c, u, &p_guide);
            const Vec3 expected = frame.to_world(packed_map::sample(map, R, u, per_sr, &p_map));
            ASSERT_EQ(guide.sample_row(c, u), packed_map::row_of(map, R, u.x)) << "cache " << c;
            ASSERT_EQ(w.x, expected.x);
            ASSERT_EQ(w.y, expected.y);
            ASSERT_EQ(w.z, expected.z);
            ASSERT_EQ(p_guide, p_map);
            ASSERT_EQ(guide.pdf(c, w), p_guide) << "cache " << c << " sample " << s;
            // A direction drawn elsewhere: its texel and density from the generic functions.
            const Vec3 d = sample_uniform_sphere({rng.next_float(), rng.next_float()});
            int i, j;
            sphere_texel_of(frame.to_local(d), R, &i, &j);
            const Guide::Texel t = guide.texel(c, d);
            ASSERT_EQ(t.i, i);
            ASSERT_EQ(t.j, j);
            ASSERT_EQ(guide.texel_pdf(c, t), packed_map::texel_pdf(map, R, i, j, per_sr));
        }
    }
}

TEST(GuideLookup, NormalClassIsTheNearestAxis) {
    EXPECT_EQ(Guide::normal_class({1, 0, 0}), 0);
    EXPECT_EQ(Guide::normal_class({-0.9f, 0.3f, 0.3f}), 1);
    EXPECT_EQ(Guide::normal_class({0.1f, 0.8f, -0.5f}), 2);
    EXPECT_EQ(Guide::normal_class({0, -1, 0}), 3);
    EXPECT_EQ(Guide::normal_class({0.5f, 0.5f, 0.7f}), 4);
    EXPECT_EQ(Guide::normal_class({0, 0, -1}), 5);
    // Ties (|z| = |y| = |x|, |y| = |x|) go to z, then to y; -0 counts as positive; NaN is class 0. Against
    // the plain definition on random and tied normals, every sign combination.
    auto plain = [](Vec3 n) {
        const float ax = std::abs(n.x), ay = std::abs(n.y), az = std::abs(n.z);
        if (az >= ax && az >= ay) return n.z < 0 ? 5 : 4;
        if (ay >= ax) return n.y < 0 ? 3 : 2;
        return n.x < 0 ? 1 : 0;
    };
    EXPECT_EQ(Guide::normal_class({0.5f, 0.5f, 0.5f}), 4);
    EXPECT_EQ(Guide::normal_class({-0.6f, -0.6f, 0.1f}), 3);
    EXPECT_EQ(Guide::normal_class({0.0f, 0.0f, -0.0f}), 4);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    EXPECT_EQ(Guide::normal_class({nan, nan, nan}), 0);
    Rng rng(5, 1);
    const float values[] = {0.0f, -0.0f, 0.3f, -0.3f, 0.8f, -0.8f};
    for (float x : values)
        for (float y : values)
            for (float z : values) EXPECT_EQ(Guide::normal_class({x, y, z}), plain({x, y, z})) << x << " " << y << " " << z;
    for (int i = 0; i < 10000; ++i) {
        const Vec3 n(2 * rng.next_float() - 1, 2 * rng.next_float() - 1, 2 * rng.next_float() - 1);
        ASSERT_EQ(Guide::normal_class(n), plain(n)) << n.x << " " << n.y << " " << n.z;
    }
}

TEST(GuideLookup, TakesItsFineOrCoarseCellsAnswerAndGuidesOnlyWhereItGuides) {
    const CacheAtlas atlas = plane_atlas(3000, 7);
    const Guide guide(atlas, 0.25f);  // constant fraction: every usable cache guides
    Rng rng(11, 4);
    const float slack = 1.5f, normal_cos = 0.7071f;
    // Brute force: among the `candidates` caches nearest p (usable or not), the first that serves some
    // point of the cube of side `width` centred on p (a single point for width 0) for normal n.
    auto nearest_serving = [&](Vec3 p, Vec3 n, size_t candidates, float width) {
        std::vector<std::pair<float, int>> by_distance;
        for (size_t c = 0; c < atlas.size(); ++c) by_distance.push_back({length_sq(atlas.position[c] - p), int(c)});
        std::partial_sort(by_distance.begin(), by_distance.begin() + candidates, by_distance.end());
        for (size_t i = 0; i < candidates; ++i) {
            const size_t c = size_t(by_distance[i].second);
            const Vec3 e = atlas.position[c] - p;
            const Vec3 d = vmax(Vec3(std::abs(e.x), std::abs(e.y), std::abs(e.z)) - Vec3(0.5f * width), Vec3(0.0f));
            const float r = atlas.radius[c] * slack;
            if (length_sq(d) <= r * r && dot(atlas.normal[c], n) >= normal_cos) return int(c);
        }
        return -1;
    };
    const Vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    int found = 0, none = 0, unusable_chosen = 0, outside = 0;
    std::map<float, int> by_width;  // queries answered per cell width: the fine grid's and the coarse one's
    for (int q = 0; q < 20000; ++q) {
        // Points on and near either plane, some between them and some far from both (in the coarse grid, or
        // farther than any cache serves);
        // normals up, down or tilted.
        const float z = q % 4 == 0 ? 0.0f : q % 4 == 1 ? 1.0f : q % 4 == 2 ? rng.next_float() : 6 * rng.next_float() - 2.5f;
        const Vec3 p{rng.next_float() * 14 - 2, rng.next_float() * 14 - 2, z + 0.02f * (rng.next_float() - 0.5f)};
        const Vec3 n = normalize(Vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, q % 2 ? 1.0f : -1.0f));
        Vec3 center;
        float width;
        int expect;
        if (guide.cell_center(p, &center, &width)) {
            // The cell's answer for n's axis, chosen for the cell.
            ++by_width[width];
            const Vec3 o = center - p;
            ASSERT_LE(std::max({std::abs(o.x), std::abs(o.y), std::abs(o.z)}), 0.5f * width * 1.0001f) << "query " << q;
            expect = nearest_serving(center, axes[Guide::normal_class(n)], Guide::kAnswerCandidates, width);
        } else {
            // In no cell: no cache serves p.
            ++outside;
            ASSERT_EQ(nearest_serving(p, n, atlas.size(), 0.0f), -1) << "query " << q;
            expect = -1;
        }
        unusable_chosen += expect >= 0 && !atlas.usable[size_t(expect)];
        if (expect >= 0 && !atlas.usable[size_t(expect)]) expect = -1;  // it claims the vertex, unguided
        const int c = guide.lookup(p, n);
        ASSERT_EQ(c, expect) << "query " << q;
        if (c < 0) {
            ++none;
            continue;
        }
        ++found;
        EXPECT_TRUE(atlas.usable[size_t(c)]);
    }
    // Every outcome occurs, so no branch went untested.
    EXPECT_GT(found, 1000);
    EXPECT_GT(none, 1000);
    EXPECT_GT(unusable_chosen, 100);
    ASSERT_EQ(by_width.size(), 2u);
    EXPECT_FLOAT_EQ(by_width.rbegin()->first, 4 * by_width.begin()->first);
    EXPECT_GT(by_width.begin()->second, 1000);   // fine cells
    EXPECT_GT(by_width.rbegin()->second, 1000);  // coarse cells
    EXPECT_GT(outside, 1000);
    EXPECT_EQ(guide.lookup(Vec3(1e30f, 0, 0), Vec3(0, 0, 1)), -1);
    EXPECT_EQ(guide.lookup(Vec3(std::nanf(""), 0, 0), Vec3(0, 0, 1)), -1);
}

// Densities per steradian of a map of R x R texels proportional to f(local direction), with floor.
std::vector<float> map_of(int R, double floor, float (*f)(Vec3)) {
    std::vector<float> w(size_t(R * R));
    for (int j = 0; j < R; ++j)
        for (int i = 0; i < R; ++i) {
            double s = 0;
            for (int b = 0; b < 8; ++b)
                for (int a = 0; a < 8; ++a)
                    s += f(square_to_sphere({(i + (a + 0.5f) / 8) / R, (j + (b + 0.5f) / 8) / R}));
            w[size_t(j * R + i)] = float(s);
        }
    SphereMap m(R);
    std::copy(w.begin(), w.end(), m.data());
    m.normalise_floor(float(floor));
    std::vector<float> cdf(w.size()), pdf(w.size());
    SphereDistribution::build(m.data(), R, cdf.data(), pdf.data());
    return pdf;
}

TEST(BsdfFraction, CosineMapGainsNothingAndPeakedMapGainsMuch) {
    const int R = 16;
    const double floor = 0.1;
    const BsdfFractionChooser chooser(R, floor, 0.2f);
    const std::vector<float> cosine = map_of(R, floor, [](Vec3 w) { return std::max(0.0f, w.z); });
    const BsdfFractionChoice c = chooser.choose(cosine.data());
    EXPECT_EQ(c.alpha, 1.0f);
    EXPECT_LT(c.gain, 1.05f);
    // Light from a ~20 degree cone 60 degrees off the normal: cosine sampling rarely hits it.
    const std::vector<float> peaked = map_of(R, floor, [](Vec3 w) {
        const Vec3 d = normalize(Vec3(std::sin(1.05f), 0.0f, std::cos(1.05f)));
        return dot(w, d) > std::cos(0.17f) ? 1.0f : 0.0f;
    });
    const BsdfFractionChoice p = chooser.choose(peaked.data());
    EXPECT_LE(p.alpha, 0.3f);
    EXPECT_GE(p.alpha, 0.2f);  // never below the defensive minimum
    EXPECT_GT(p.gain, 5.0f);
    EXPECT_THROW(BsdfFractionChooser(R, 1.0, 0.2f), std::invalid_argument);
    EXPECT_THROW(BsdfFractionChooser(R, 0.1, 0.0f), std::invalid_argument);
}

TEST(BsdfFraction, GuideSkipsCachesThatCannotBeatTheBsdf) {
    CacheAtlas a = plane_atlas(200, 5);
    const size_t N = a.texels();
    // Half the caches hold the cosine distribution, the others a peak: only the latter may guide.
    const std::vector<float> cosine = map_of(a.resolution, a.floor, [](Vec3 w) { return std::max(0.0f, w.z); });
    const std::vector<float> peak = map_of(a.resolution, a.floor, [](Vec3 w) { return w.x > 0.9f ? 1.0f : 0.0f; });
    for (size_t c = 0; c < a.size(); ++c) {
        const std::vector<float>& src = c % 2 ? peak : cosine;
        std::vector<float> cdf(N), pdf(N);
        // Rebuild from the densities so that the row's cdf matches.
        SphereDistribution::build(src.data(), a.resolution, cdf.data(), pdf.data());
        std::copy(cdf.begin(), cdf.end(), a.cdf.begin() + long(c * N));
        std::copy(pdf.begin(), pdf.end(), a.pdf.begin() + long(c * N));
    }
    size_t usable = 0, usable_peak = 0;
    for (size_t c = 0; c < a.size(); ++c) {
        usable += a.usable[c];
        usable_peak += a.usable[c] && c % 2;
    }
    const Guide guide(a, GuideOptions{});
    EXPECT_EQ(guide.summary().usable, usable);
    EXPECT_EQ(guide.summary().guiding, usable_peak);
    for (size_t c = 0; c < a.size(); ++c)
        EXPECT_EQ(guide.bsdf_fraction(int(c)) < 1.0f, a.usable[c] && c % 2 == 1) << "cache " << c;
}

// Product sampling with a glossy lobe (Guide::product): the product's density p = d_k e_K / Z integrates
// to one over the texels, each sample reports exactly the density product_pdf gives the texel its
// direction falls in (so MIS stays unbiased), and the samples are distributed as that density says (a
// chi-square test over the texels with expected counts of at least 5). Lumpy maps with exact zeros, lobe
// axes anywhere on the sphere, sharpness from 0 (the plain map) to 40.
TEST(GuideProduct, IsAnExactDistributionAndSamplesFollowIt) {
    constexpr int R = 32, N = R * R;
    CacheAtlas a = plane_atlas(3, 21);
    a.resolution = R;
    a.pdf.assign(a.size() * size_t(N), 0.0f);
    a.cdf.assign(a.size() * size_t(N), 0.0f);
    for (size_t c = 0; c < a.size(); ++c) {
        a.usable[c] = 1;
        SphereDistribution::build(lumpy_weights(R, 300 + c).data(), R, &a.cdf[c * size_t(N)], &a.pdf[c * size_t(N)]);
    }
    GuideOptions options;
    options.bsdf_fraction = 0.25f;
    options.product = true;
    const Guide guide(a, options);
    const double omega = 4.0 * M_PI / N;
    Rng rng(5, 9);
    int trials = 0;
    for (int c = 0; c < int(a.size()); ++c)
        for (float sharpness : {0.0f, 2.0f, 12.0f, 40.0f}) {
            const Vec3 axis = sample_uniform_sphere({rng.next_float(), rng.next_float()});
            Guide::Product p;
            ASSERT_TRUE(guide.product(c, axis, sharpness, &p));
            std::vector<double> expected(N);
            double total = 0;
            for (int k = 0; k < N; ++k) total += expected[size_t(k)] = double(guide.product_pdf(p, {k % R, k / R})) * omega;
            EXPECT_NEAR(total, 1.0, 1e-4) << "cache " << c << " sharpness " << sharpness;
            constexpr int kSamples = 200000;
            std::vector<double> count(N, 0.0);
            for (int s = 0; s < kSamples; ++s) {
                float pdf = 0;
                int texel = -1;
                guide.product_block(&p, rng.next_float());
                const Vec3 w = guide.sample_product(p, rng.next_float(), &pdf, &texel);
                const Guide::Texel t = guide.texel(c, w);
                ASSERT_EQ(texel, guide.texel_index(t));
                ASSERT_EQ(pdf, guide.product_pdf(p, t)) << "cache " << c << " sample " << s;
                ASSERT_GT(pdf, 0.0f);
                count[size_t(texel)] += 1;
            }
            // Chi-square over the texels expecting >= 5 samples (the rest pooled), against its 99.99 %
            // quantile (normal approximation for many degrees of freedom).
            double chi2 = 0, rest_expected = 0, rest_count = 0;
            int cells = 0;
            for (int k = 0; k < N; ++k) {
                const double e = expected[size_t(k)] * kSamples;
                if (e < 5) {
                    rest_expected += e;
                    rest_count += count[size_t(k)];
                    continue;
                }
                chi2 += (count[size_t(k)] - e) * (count[size_t(k)] - e) / e;
                ++cells;
            }
            if (rest_expected > 0) chi2 += (rest_count - rest_expected) * (rest_count - rest_expected) / rest_expected, ++cells;
            const double dof = cells - 1;
            EXPECT_LT(chi2, dof + 3.72 * std::sqrt(2 * dof)) << "cache " << c << " sharpness " << sharpness;
            ++trials;
        }
    EXPECT_EQ(trials, 12);
}

}  // namespace
}  // namespace iris

namespace iris {
namespace {

TEST(PathSamples, EffectiveCountIsTheNumberOfAlikeSamplesAndOneForASingleHeavyOne) {
    PathSamples s(3, 16);
    PathSamples::Writer w = s.writer();
    for (int i = 0; i < 100; ++i) w.add(0, i % 16, 2.5f);  // alike: worth their number
    EXPECT_EQ(s.count(0), 100u);
    EXPECT_NEAR(s.effective_count(0), 100.0, 1e-6);
    for (int i = 0; i < 99; ++i) w.add(1, 3, 0.01f);  // 99 light samples and one 1000x heavier
    w.add(1, 7, 10.0f);
    EXPECT_EQ(s.count(1), 100u);
    EXPECT_NEAR(s.effective_count(1), (99 * 0.01 + 10.0) / 10.0, 1e-6);
    w.add(2, 0, 0.0f);  // zero samples only (and NaN, counted as zero): worth nothing
    w.add(2, 1, std::nanf(""));
    EXPECT_EQ(s.count(2), 2u);
    EXPECT_EQ(s.effective_count(2), 0.0);
}

// Guide::refit weighs path samples by their effective count: one heavy sample among light ones barely
// moves a map of 100 photons (counted as their number, the 100 samples would have taken half of it, most
// of that in the heavy sample's texel), and a cache without photons guides only once its samples are
// worth kMinPathSamples.
TEST(HybridRefit, HeavyTailedSamplesAreWorthTheirEffectiveCount) {
    CacheAtlas a = plane_atlas(4, 21);  // maps uniform; cache 3 unusable
    for (auto& n : a.photon_count) n = 100;
    GuideOptions o;
    o.learn = true;
    Guide guide(a, o);
    ASSERT_EQ(guide.bsdf_fraction(3), 1.0f);
    PathSamples s(a.size(), a.texels());
    PathSamples::Writer w = s.writer();
    for (int i = 0; i < 99; ++i) w.add(0, 3, 0.01f);
    w.add(0, 7, 10.0f);
    for (int i = 0; i < 99; ++i) w.add(3, 3, 0.01f);  // cache 3: worth about one sample
    w.add(3, 7, 10.0f);
    const float uniform = guide.texel_pdf(0, 0);
    guide.refit(s);
    // Cache 0: lambda = 1.1 / 101, so texel 7 gains about 1 % of the map's mass (old weighting: ~45 %).
    const float floor_share = float(a.floor) / float(a.texels());
    const float before = (1 - float(a.floor)) / float(a.texels()) + floor_share;
    EXPECT_LT(guide.texel_pdf(0, 7), uniform * (1 + 0.02f / before));
    EXPECT_GT(guide.texel_pdf(0, 7), uniform);
    EXPECT_EQ(guide.bsdf_fraction(3), 1.0f) << "a map worth one sample guides";
    EXPECT_TRUE(guide.records(3));

    // 40 more alike samples in cache 3's texel 5: now worth 32 or more, it may guide (its map is one texel
    // on a floor, which the chooser predicts to gain).
    PathSamples more(a.size(), a.texels());
    PathSamples::Writer w2 = more.writer();
    for (int i = 0; i < 40; ++i) w2.add(3, 5, 1.0f);
    guide.refit(more);
    EXPECT_LT(guide.bsdf_fraction(3), 1.0f);
    EXPECT_GT(guide.texel_pdf(3, 5), 5 * guide.texel_pdf(3, 0));
}

}  // namespace
}  // namespace iris
