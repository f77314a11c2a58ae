// Photon power is flux (DESIGN.md section 4.5): a photon carries Phi_light / (N p_select(light)) times
// its path throughput, lights chosen in proportion to their power (times Mitsuba's samplingWeight).
// Checked in closed scenes, where no photon escapes, against powers computed here by hand from the
// scene files (pi A L for one-sided area lights, 4 pi I for points), not by light_power():
//   - the furnace box traced to depth 1 (every photon a first hit): the photons' powers sum to the
//     light's power -- exactly, since one light is chosen with probability one;
//   - the furnace box at unlimited depth: the sum is Phi / (1 - rho) per channel (Russian roulette and
//     the cutoff must not bias it), and the photons flagged as stored after k bounces sum to Phi rho^k
//     (exactly Phi for k = 0: the first hits), tested against standard errors from independent batches;
//   - three closed rooms with one light each (area mesh, sphere with samplingWeight 2, point): per
//     room, the photon count follows the selection probability and the power sums to that light's flux.
// Seeds are fixed, so every run is the same; the 4.5- and 5-sigma bounds keep the family-wise false
// alarm rate of the ~20 comparisons below 1e-4 for any seed.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "formats/scene_xml.h"
#include "libcommon/scene.h"
#include "support/run_tool.h"
#include "tools/trace-photons/photon_tracer.h"

namespace iris {
namespace {

Scene load(const std::string& rel) {
    SceneLoadOptions lo;
    std::vector<std::string> warnings;
    lo.warnings = &warnings;
    return load_scene(test::data_file(rel), lo);
}

PhotonMap trace(const Scene& scene, uint64_t paths, int max_depth, uint64_t seed) {
    PhotonOptions o;
    o.paths = paths;
    o.max_depth = max_depth;
    o.seed = seed;
    o.quiet = true;
    PhotonStats stats;
    PhotonMap map = trace_photons(scene, o, &stats);
    EXPECT_EQ(stats.nonfinite, 0u);
    return map;
}

// The furnace box (tests/data/render/furnace_box.xml): Mitsuba's cube scaled to 4 x 2 x 6 m, emitting
// radiance (1, 2, 0.5) from its whole inside, albedo (0.5, 0.25, 0.75).
constexpr double kFurnaceArea = 2 * (4 * 2 + 4 * 6 + 2 * 6);  // 88 m^2
const double kFurnaceL[3] = {1, 2, 0.5}, kFurnaceRho[3] = {0.5, 0.25, 0.75};

TEST(GuidingPhotonFlux, FurnaceFirstHitsSumToTheLightsPower) {
    Scene scene = load("render/furnace_box.xml");
    const uint64_t n = 20000;
    PhotonMap map = trace(scene, n, 1, 1);
    // Closed and diffuse everywhere: every path stores exactly one photon, at its first hit.
    ASSERT_EQ(map.size(), n);
    EXPECT_EQ(map.emitted_paths, n);
    double sum[3] = {0, 0, 0};
    for (const RGB& p : map.power)
        for (int c = 0; c < 3; ++c) sum[c] += p[c];
    for (int c = 0; c < 3; ++c) {
        const double phi = M_PI * kFurnaceArea * kFurnaceL[c];
        // No randomness: each photon carries Phi / N. Only float rounding of the per-photon value.
        EXPECT_NEAR(sum[c], phi, 1e-5 * phi) << "channel " << c;
    }
}

TEST(GuidingPhotonFlux, FurnaceAllBouncesSumToPowerOverOneMinusAlbedo) {
    Scene scene = load("render/furnace_box.xml");
    // Russian roulette from the 3rd bounce on (the default, set here explicitly): before it, every
    // path in the closed diffuse box stores exactly one photon per bounce k = 0, 1, 2 (the photon map's
    // `bounces`), each carrying Phi rho^k / N -- so those sums are exact. From bounce 3 on, roulette
    // makes them random: their total, Phi rho^3 / (1 - rho), and the grand total Phi / (1 - rho) are
    // tested against standard errors from independent batches (different seeds), which need no
    // knowledge of which photons belong to which path.
    const int batches = 50;
    const uint64_t n = 2000;
    double mean[2][3] = {}, m2[2][3] = {};  // [0]: all photons, [1]: bounces >= 3
    for (int b = 0; b < batches; ++b) {
        PhotonOptions o;
        o.paths = n;
        o.max_depth = -1;
        o.rr_depth = 3;
        o.seed = 100 + uint64_t(b);
        o.quiet = true;
        PhotonMap map = trace_photons(scene, o, nullptr);
        ASSERT_EQ(map.bounces.size(), map.size());
        double exact[3][3] = {}, sum[2][3] = {};
        uint64_t count[3] = {0, 0, 0};
        for (size_t i = 0; i < map.size(); ++i) {
            const int k = map.bounces[i];
            if (k < 3) ++count[k];
            for (int c = 0; c < 3; ++c) {
                sum[0][c] += map.power[i][c];
                (k < 3 ? exact[k][c] : sum[1][c]) += map.power[i][c];
            }
        }
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(count[k], n) << "photons after " << k << " bounces, batch " << b;
            for (int c = 0; c < 3; ++c) {
                const double expected = M_PI * kFurnaceArea * kFurnaceL[c] * std::pow(kFurnaceRho[c], k);
                // No randomness: only float rounding of the per-photon power (and of rho^k).
                EXPECT_NEAR(exact[k][c], expected, 1e-5 * expected) << "bounce " << k << ", batch " << b << ", channel " << c;
            }
        }
        for (int s = 0; s < 2; ++s)
            for (int c = 0; c < 3; ++c) {
                mean[s][c] += sum[s][c];
                m2[s][c] += sum[s][c] * sum[s][c];
            }
        if (HasFailure()) return;
    }
    for (int s = 0; s < 2; ++s)
        for (int c = 0; c < 3; ++c) {
            mean[s][c] /= batches;
            const double var = (m2[s][c] / batches - mean[s][c] * mean[s][c]) * batches / (batches - 1);
            const double se = std::sqrt(std::max(0.0, var) / batches);
            const double phi = M_PI * kFurnaceArea * kFurnaceL[c], rho = kFurnaceRho[c];
            const double expected = (s == 0 ? phi : phi * rho * rho * rho) / (1 - rho);
            // 5 standard errors: the estimate from 50 batches is Student-t with 49 degrees of freedom, for
            // which P(|t| > 5) is below 1e-5. The standard errors are below 0.4 % (total) and 2 % (bounces
            // >= 3) of the values, so roulette without its 1/q, or a cutoff that drops photons, fails.
            EXPECT_NEAR(mean[s][c], expected, 5 * se)
                << (s == 0 ? "all bounces" : "bounces >= 3") << ", channel " << c << ", standard error " << se;
            EXPECT_LT(se, (s == 0 ? 0.004 : 0.02) * expected) << "the test has lost its power";
        }
}

TEST(GuidingPhotonFlux, EachLightsFirstHitsCarryItsFlux) {
    Scene scene = load("guiding/three_rooms.xml");
    // Hand-computed powers (see the scene file) and selection weights: samplingWeight 2 for room B.
    const double phi[3][3] = {
        {M_PI * 0.36 * 4, M_PI * 0.36 * 2, M_PI * 0.36 * 1},                 // 0.6 x 0.6 m square
        {M_PI * 4 * M_PI * 0.04 * 1, M_PI * 4 * M_PI * 0.04 * 3, M_PI * 4 * M_PI * 0.04 * 2},  // r = 0.2
        {4 * M_PI * 0.5, 4 * M_PI * 0.4, 4 * M_PI * 0.3},                   // point
    };
    const double weight[3] = {1, 2, 1};
    double p[3], total = 0;
    for (int l = 0; l < 3; ++l)
        total += p[l] = weight[l] * luminance(RGB(float(phi[l][0]), float(phi[l][1]), float(phi[l][2])));
    for (double& v : p) v /= total;

    const uint64_t n = 1000000;
    PhotonMap map = trace(scene, n, 1, 7);
    ASSERT_EQ(map.size(), n) << "closed rooms, depth 1: one photon per path";
    long long count[3] = {0, 0, 0};
    double sum[3][3] = {};
    long long wrong_power = 0;
    for (size_t i = 0; i < map.size(); ++i) {
        const int room = int(std::lround(map.position[i].x / 5.0f));
        ASSERT_TRUE(room >= 0 && room < 3) << "photon " << i << " outside the rooms";
        ++count[room];
        for (int c = 0; c < 3; ++c) {
            sum[room][c] += map.power[i][c];
            // Every photon of light l carries exactly Phi_l / (N p_l) (float rounding aside).
            const double expected = phi[room][c] / (double(n) * p[room]);
            if (std::abs(map.power[i][c] - expected) > 1e-4 * expected) ++wrong_power;
        }
    }
    EXPECT_EQ(wrong_power, 0) << "photons whose power is not Phi_l / (N p_select)";
    for (int l = 0; l < 3; ++l) {
        // The count of light l's photons is binomial(N, p_l): selection in proportion to power x weight.
        const double sd = std::sqrt(double(n) * p[l] * (1 - p[l]));
        EXPECT_NEAR(double(count[l]), double(n) * p[l], 4.5 * sd) << "room " << l << ", p_select " << p[l];
        // Sum of power = count * Phi_l / (N p_l): unbiased for Phi_l with relative error
        // sqrt((1 - p) / (N p)) ~ 0.1 %, so 4.5 sigma (< 0.7 %) catches any wrong factor in the flux.
        for (int c = 0; c < 3; ++c) {
            const double sigma = phi[l][c] * std::sqrt((1 - p[l]) / (double(n) * p[l]));
            EXPECT_NEAR(sum[l][c], phi[l][c], 4.5 * sigma) << "room " << l << " channel " << c;
        }
    }
}

}  // namespace
}  // namespace iris

namespace iris {
namespace {

// The `caustic` flag marks photons whose path from the light passed a specular bounce (PhotonMap).
// The furnace box is diffuse everywhere: no photon is flagged. In the caustic box (a glass sphere under
// the light) some are, never a first hit (it has left no surface), and fill-caches turns the flags
// into each cache's caustic share of power, which is 0 in the furnace and positive under the sphere.
TEST(GuidingPhotonFlux, CausticFlagsMarkLightThatPassedASpecularBounce) {
    const PhotonMap furnace = trace(load("render/furnace_box.xml"), 5000, -1, 3);
    ASSERT_EQ(furnace.caustic.size(), furnace.size());
    for (uint8_t f : furnace.caustic) ASSERT_EQ(f, 0);

    const PhotonMap glass = trace(load("guiding/caustic_box.xml"), 20000, -1, 3);
    ASSERT_EQ(glass.caustic.size(), glass.size());
    size_t flagged = 0, flagged_after_flagged = 0;
    for (size_t i = 0; i < glass.size(); ++i) {
        ASSERT_LE(glass.caustic[i], 1);
        if (!glass.caustic[i]) continue;
        ++flagged;
        EXPECT_GE(glass.bounces[i], 1) << "photon " << i << " flagged without having left a surface";
        // The flag is kept for the rest of the path: the next photon of the same path (one more
        // bounce, stored next in path order) is flagged too.
        if (i + 1 < glass.size() && glass.bounces[i + 1] == glass.bounces[i] + 1) {
            EXPECT_EQ(glass.caustic[i + 1], 1) << "photon " << i + 1;
            ++flagged_after_flagged;
        }
    }
    EXPECT_GT(flagged, glass.size() / 100);
    EXPECT_LT(flagged, glass.size());
    EXPECT_GT(flagged_after_flagged, 0u);
}

}  // namespace
}  // namespace iris

#include <filesystem>
#include <fstream>

#include <unistd.h>

#include "formats/exr.h"

namespace iris {
namespace {

// Furnace-style checks of the lights outside the scene: a diffuse unit sphere alone under a constant
// environment L, an environment map, or a directional light E. Every line that meets the sphere crosses
// the photons' emission disk, so the first hits' powers must sum to the flux onto the sphere, by hand:
//   constant:    pi r^2 * 4 pi L (projected area pi r^2 from every direction; irradiance pi L at
//                every point: 4 pi r^2 * pi L, the same);
//   envmap:      pi r^2 * (the integral of the map's radiance over the sphere), summed by hand here
//                from its texels (a map of two values: rows above / below the horizon);
//   directional: pi r^2 E.
// The bounding sphere has radius sqrt(3) r, so a third of the photons hit; each test compares the
// sum against 5 standard errors estimated from the paths' own powers.
std::string sphere_scene(const std::string& emitter) {
    return R"(<?xml version="1.0"?>
<scene version="0.5.0">
  <integrator type="path"/>
  <shape type="sphere"><float name="radius" value="1"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf></shape>
  )" + emitter + R"(
  <sensor type="perspective">
    <transform name="toWorld"><lookAt origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
  </sensor>
</scene>
)";
}

void check_first_hit_flux(const std::string& emitter, const double expect[3], const std::filesystem::path& dir) {
    const std::filesystem::path xml = dir / "scene.xml";
    std::ofstream(xml) << sphere_scene(emitter);
    SceneLoadOptions lo;
    std::vector<std::string> warnings;
    lo.warnings = &warnings;
    const Scene scene = load_scene(xml.string(), lo);
    const uint64_t n = 200000;
    const PhotonMap map = trace(scene, n, 1, 7);
    EXPECT_GT(map.size(), n / 4);
    EXPECT_LT(map.size(), n / 2);
    for (int c = 0; c < 3; ++c) {
        double sum = 0, sum2 = 0;
        for (const RGB& p : map.power) {
            const double v = c == 0 ? p.r : c == 1 ? p.g : p.b;
            sum += v;
            sum2 += v * v;
        }
        // Per path: x = power (or 0 for a path that missed); the sum's standard error is sqrt(n var(x)).
        const double mean = sum / double(n), var = sum2 / double(n) - mean * mean;
        const double sigma = std::sqrt(double(n) * var);
        EXPECT_NEAR(sum, expect[c], 5 * sigma) << emitter << " channel " << c;
        EXPECT_LT(sigma, 0.01 * expect[c]) << "too few photons for a sharp test";
    }
}

TEST(GuidingPhotonFlux, EnvironmentAndDirectionalPhotonsBringTheirFluxOntoASphere) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                      ("iris-env-flux-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const double pi = 3.14159265358979323846;
    {
        const double e[3] = {pi * 4 * pi * 1.0, pi * 4 * pi * 2.0, pi * 4 * pi * 0.5};
        check_first_hit_flux(R"(<emitter type="constant"><rgb name="radiance" value="1, 2, 0.5"/></emitter>)", e, dir);
    }
    {
        // 8 x 4 map: upper two rows (the upper hemisphere, +y) radiance (3, 1, 2), lower rows (0.5, 0.5, 0):
        // each hemisphere spans 2 pi sr. A scale of 2 doubles it.
        Image img;
        img.width = 8;
        img.height = 4;
        for (const char* c : {"R", "G", "B"}) img.add_channel(c);  // (sized width x height, zeroed)
        for (int y = 0; y < 4; ++y)
            for (int x = 0; x < 8; ++x) {
                img.data[0][size_t(y * 8 + x)] = y < 2 ? 3.0f : 0.5f;
                img.data[1][size_t(y * 8 + x)] = y < 2 ? 1.0f : 0.5f;
                img.data[2][size_t(y * 8 + x)] = y < 2 ? 2.0f : 0.0f;
            }
        write_exr((dir / "sky.exr").string(), img);
        const double e[3] = {pi * 2 * 2 * pi * (3 + 0.5), pi * 2 * 2 * pi * (1 + 0.5), pi * 2 * 2 * pi * 2};
        check_first_hit_flux(R"(<emitter type="envmap"><string name="filename" value="sky.exr"/>
            <float name="scale" value="2"/>
            <transform name="toWorld"><rotate x="1" angle="70"/></transform></emitter>)", e, dir);
    }
    {
        const double e[3] = {pi * 4, pi * 1, pi * 2};
        check_first_hit_flux(R"(<emitter type="directional"><vector name="direction" x="1" y="-2" z="0.5"/>
            <rgb name="irradiance" value="4, 1, 2"/></emitter>)", e, dir);
    }
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace iris
