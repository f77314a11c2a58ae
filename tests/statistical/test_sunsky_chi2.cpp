// Chi-square tests of sampling a sunsky environment light (libcommon/sky.h into lights.h's EnvMap):
// a sun disk of a few texels holding most of the power beside a sky of ~10^5 dim texels, the very
// peaked map the published scenes make. chi2.h's fixed grid cannot integrate such a density to the
// accuracy 10^6 samples need, so the bins here are the map's own texels (and, where the counts allow,
// 4 x 4 cells inside a texel, which checks that directions are uniform inside the texel they fall in),
// and the expected mass of a texel is written out from the sampling rule lights.h documents:
// luminance x sin(theta at the texel centre), normalised over the map, times the light's selection
// probability. Samples are binned by their direction, mapped back to the map's frame here. A second
// check asks light_pdf at every texel centre for the same density, so sampling and pdf agree.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <vector>

#include "libcommon/lights.h"
#include "libcommon/scene.h"
#include "libcommon/sky.h"
#include "support/chi2.h"

namespace iris {
namespace {

constexpr int kTests = 2;  // Sidak correction over the tests of this file
constexpr long long kSamples = 2000000;
constexpr int kSub = 4;  // sub-cells per texel side where a texel expects enough samples

struct Bin {
    double expected = 0;
    long long observed = 0;
};

// The scene: a sunsky light (params, toWorld), optionally beside a quad area light.
Scene sunsky_scene(const SunSkyParams& p, const Transform& to_world, bool with_quad) {
    Scene s;
    if (with_quad) {
        Mesh m;
        m.positions = {Vec3(-1, -1, 2), Vec3(1, -1, 2), Vec3(1, 1, 2), Vec3(-1, 1, 2)};
        m.indices = {0, 2, 1, 0, 3, 2};  // normal -z, facing the reference point at the origin
        m.light = 0;
        s.meshes.push_back(m);
        Light q;
        q.type = LightType::AreaMesh;
        q.shape = 0;
        q.radiance = RGB(0.5f);
        s.lights.push_back(q);
    }
    Light env;
    env.type = LightType::Envmap;
    env.envmap = make_sunsky_envmap(p, to_world);
    s.lights.push_back(env);
    s.bounds_min = Vec3(-3);
    s.bounds_max = Vec3(3);
    lights_prepare(s);
    return s;
}

void run(const SunSkyParams& p, const Transform& to_world, bool with_quad, uint64_t seed) {
    const Scene scene = sunsky_scene(p, to_world, with_quad);
    const uint32_t env_index = with_quad ? 1 : 0;
    const EnvMap& m = *scene.lights[env_index].envmap;
    const int w = m.width, h = m.height;
    const double p_env = light_selection_pmf(scene, env_index);
    ASSERT_GT(p_env, 0.0);

    // Expected mass of each texel by the documented rule, and light_pdf's density at its centre.
    std::vector<double> mass(size_t(w) * size_t(h));
    double total = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double v = double(luminance(m.texels[size_t(y * w + x)])) * std::sin(M_PI * (y + 0.5) / h);
            mass[size_t(y * w + x)] = v;
            total += v;
        }
    const Transform to_local = to_world.inverse();
    int pdf_mismatches = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double& mt = mass[size_t(y * w + x)];
            mt /= total;
            // Density per sr at the centre: the texel's mass spread uniformly over its (u, v) rectangle,
            // i.e. mass w h / (2 pi^2 sin theta) per sr at that direction.
            const Vec3 c = to_world.vector(sky_direction({M_PI * (y + 0.5) / h, 2 * M_PI * (x + 0.5) / w}));
            const Vec3 cl = to_local.vector(c);
            const double sin_c = std::sqrt(double(cl.x) * cl.x + double(cl.z) * cl.z);
            const double want = p_env * mt * w * h / (2 * M_PI * M_PI * sin_c);
            const double got = light_pdf(scene, env_index, 0, Vec3(0), Vec3(0), Vec3(0), normalize(c));
            if (std::abs(got - want) > 1e-4 * want + 1e-12 && ++pdf_mismatches <= 5)
                ADD_FAILURE() << "light_pdf at texel " << x << "," << y << ": " << got << ", rule says " << want;
        }
    EXPECT_EQ(pdf_mismatches, 0);

    // Bins: a texel that expects >= 20 samples in each of kSub x kSub cells is split into them (the sun's
    // texels: checks directions are uniform inside a texel); the other texels are pooled in blocks of
    // kBlock x kBlock (the sky: few, well-filled bins keep the test sensitive to an error in the sun's
    // share). One more bin holds the quad light's samples (expected: its selection probability).
    const double n = double(kSamples);
    constexpr int kBlock = 8;
    const int bw = (w + kBlock - 1) / kBlock, bh = (h + kBlock - 1) / kBlock;
    std::vector<int> first_cell(size_t(w) * size_t(h), -1);
    std::vector<bool> split(size_t(w) * size_t(h), false);
    std::vector<Bin> bins(size_t(bw) * size_t(bh));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const size_t t = size_t(y * w + x);
            const double e = n * p_env * mass[t];
            split[t] = e >= 20.0 * kSub * kSub;
            if (split[t]) {
                first_cell[t] = int(bins.size());
                for (int i = 0; i < kSub * kSub; ++i) bins.push_back({e / (kSub * kSub), 0});
            } else {
                first_cell[t] = (y / kBlock) * bw + x / kBlock;
                bins[size_t(first_cell[t])].expected += e;
            }
        }
    const size_t quad_bin = bins.size();
    bins.push_back({with_quad ? n * light_selection_pmf(scene, 0) : 0.0, 0});

    Rng rng(seed, 3);
    long long failed = 0;  // sample_light found no direction
    long long stray = 0;   // directions in a texel of zero mass (still binned: the statistic counts them)
    for (long long i = 0; i < kSamples; ++i) {
        LightSample s;
        const float u_sel = rng.next_float();
        const Vec2 u{rng.next_float(), rng.next_float()};
        if (!sample_light(scene, Vec3(0), u_sel, u, &s)) {
            ++failed;
            continue;
        }
        if (s.light != env_index) {
            ++bins[quad_bin].observed;
            continue;
        }
        // Map coordinates of the direction, Mitsuba's latlong written out: u = atan2(x, -z) / 2 pi,
        // v = acos(y) / pi in the map's frame.
        const Vec3 d = to_local.vector(s.wi);
        double uu = std::atan2(double(d.x), -double(d.z)) / (2 * M_PI);
        if (uu < 0) uu += 1;
        const double vv = std::acos(std::max(-1.0, std::min(1.0, double(d.y) / double(length(d))))) / M_PI;
        const int x = std::min(w - 1, int(uu * w)), y = std::min(h - 1, int(vv * h));
        const int b = first_cell[size_t(y * w + x)];
        if (mass[size_t(y * w + x)] <= 0) ++stray;
        if (split[size_t(y * w + x)]) {
            const int sx = std::min(kSub - 1, int((uu * w - x) * kSub)), sy = std::min(kSub - 1, int((vv * h - y) * kSub));
            ++bins[size_t(b + sy * kSub + sx)].observed;
        } else {
            ++bins[size_t(b)].observed;
        }
    }
    EXPECT_EQ(failed, 0) << "samples without a direction";
    // A direction on a texel's edge can round into the black neighbour (the horizon's row) when it is
    // turned by toWorld and back here: a handful in 10^6, not a share.
    EXPECT_LE(stray, kSamples / 100000) << "directions in black texels";

    // Pool consecutive bins below 5 expected, then Pearson's statistic.
    std::vector<Bin> pooled;
    Bin acc;
    for (const Bin& b : bins) {
        if (b.expected <= 0 && b.observed == 0) continue;
        acc.expected += b.expected;
        acc.observed += b.observed;
        if (acc.expected >= 5) {
            pooled.push_back(acc);
            acc = Bin();
        }
    }
    if (acc.expected > 0 || acc.observed > 0) {
        if (pooled.empty()) pooled.push_back(acc);
        else {
            pooled.back().expected += acc.expected;
            pooled.back().observed += acc.observed;
        }
    }
    double stat = 0;
    for (const Bin& b : pooled) stat += (b.observed - b.expected) * (b.observed - b.expected) / b.expected;
    const int dof = int(pooled.size()) - 1;
    const double p_value = test::gamma_q(dof / 2.0, stat / 2.0);
    const double alpha = 1.0 - std::pow(1.0 - 0.01, 1.0 / kTests);
    // How peaked the map is: the share of the samples the brightest texel takes.
    double top = 0;
    for (double mt : mass) top = std::max(top, mt);
    std::printf("    chi2 %.1f, dof %d, p %.4f; %zu bins; brightest texel %.3f of the map's samples\n", stat, dof, p_value,
                pooled.size(), top);
    EXPECT_GT(p_value, alpha) << "chi2 " << stat << " with " << dof << " dof";
}

TEST(SunskyChi2, TorusSunskyRotatedAtFullResolution) {
    // The improved-path-guiding torus' emitter: toWorld rotate y -30 then x 90 (its sky's up is world
    // +z), 9 am, turbidity 5, sunRadiusScale 4, the default 512 x 256 map.
    SunSkyParams p;
    p.sun = sun_position({2010, 7, 10, 9, 0, 0}, {});
    p.turbidity = 5;
    p.sun_radius_scale = 4;
    const Transform to_world = Transform::rotate(Vec3(1, 0, 0), 90) * Transform::rotate(Vec3(0, 1, 0), -30);
    run(p, to_world, false, 11);
}

TEST(SunskyChi2, LowSunBesideAnAreaLight) {
    // The bathroom's evening sun (1.6 degrees high, its disk partly below the horizon), the true disk
    // size (one or two texels of a 1024 x 512 map), scaled sun and sky, mixed with a quad light.
    SunSkyParams p;
    p.sun = sun_position({2019, 9, 20, 17, 30, 0}, {});
    p.resolution = 1024;
    p.sky_scale = 8;
    p.sun_scale = 8;
    run(p, Transform(), true, 12);
}

}  // namespace
}  // namespace iris
