// The environment map, spot and directional lights: Mitsuba 0.5's latlong convention, pdf and radiance
// as sample_light reports them equal to light_pdf / light_emitted (the MIS contract), the density
// integrating to one, black maps and rows without NaN, bad maps refused, the spot's falloff and power,
// the directional light's delta, and photon emission's mean flux equal to the light's power.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "libcommon/emission.h"
#include "libcommon/lights.h"
#include "libcommon/rng.h"
#include "libcommon/sampling.h"
#include "libcommon/scene.h"
#include "tools/render/connections.h"

namespace iris {
namespace {

// Mitsuba 0.5's latlong direction of map coordinates (u, v), written out independently of lights.cpp.
Vec3 latlong(double u, double v) {
    const double phi = 2 * M_PI * u, theta = M_PI * v;
    return Vec3(float(std::sin(phi) * std::sin(theta)), float(std::cos(theta)), float(-std::cos(phi) * std::sin(theta)));
}

std::vector<RGB> one_texel(int w, int h, int x, int y, RGB value) {
    std::vector<RGB> t(size_t(w * h), RGB(0));
    t[size_t(y * w + x)] = value;
    return t;
}

Scene env_scene(std::shared_ptr<const EnvMap> map) {
    Scene s;
    Light l;
    l.type = LightType::Envmap;
    l.envmap = std::move(map);
    s.lights.push_back(l);
    s.bounds_min = Vec3(-1);
    s.bounds_max = Vec3(1);
    lights_prepare(s);
    return s;
}

TEST(EnvLights, LatlongConventionIsMitsubas) {
    // One bright texel (column 5 of 8, row 1 of 4): every sample lies in it, and its centre direction
    // by Mitsuba's formula evaluates to it.
    const RGB sun(7, 5, 3);
    auto map = make_envmap(8, 4, one_texel(8, 4, 5, 1, sun), Transform());
    const Vec3 centre = latlong(5.5 / 8, 1.5 / 4);
    EXPECT_EQ(envmap_eval(*map, centre).r, sun.r);
    EXPECT_EQ(envmap_eval(*map, Vec3(0, 1, 0)).r, 0.0f);    // the top row (up is +y)
    EXPECT_EQ(envmap_eval(*map, latlong(1.5 / 8, 1.5 / 4)).r, 0.0f);
    Rng rng(3, 1);
    for (int i = 0; i < 2000; ++i) {
        Vec3 d;
        float pdf;
        ASSERT_TRUE(envmap_sample(*map, {rng.next_float(), rng.next_float()}, &d, &pdf));
        // u = atan2(d.x, -d.z) / 2 pi in [5/8, 6/8), v = acos(d.y) / pi in [1/4, 2/4).
        double u = std::atan2(double(d.x), -double(d.z)) / (2 * M_PI);
        if (u < 0) u += 1;
        const double v = std::acos(double(d.y)) / M_PI;
        EXPECT_GE(u, 5.0 / 8 - 1e-6);
        EXPECT_LE(u, 6.0 / 8 + 1e-6);
        EXPECT_GE(v, 1.0 / 4 - 1e-6);
        EXPECT_LE(v, 2.0 / 4 + 1e-6);
    }
    // toWorld rotates the map: +y up turned to +z (rotation of 90 degrees about x).
    std::vector<RGB> top(32, RGB(0));
    for (int x = 0; x < 8; ++x) top[size_t(x)] = sun;  // the whole top row: the pole has no azimuth
    auto rot = make_envmap(8, 4, top, Transform::rotate(Vec3(1, 0, 0), 90));
    EXPECT_EQ(envmap_eval(*rot, Vec3(0, 0, 1)).r, sun.r);
    EXPECT_EQ(envmap_eval(*rot, Vec3(0, 1, 0)).r, 0.0f);
}

TEST(EnvLights, EnvmapPdfMatchesSampleLightAndIntegratesToOne) {
    std::vector<RGB> t(16 * 8);
    for (int i = 0; i < 16 * 8; ++i) t[size_t(i)] = RGB(0.1f + 0.05f * float(i % 16), 0.3f, 0.02f * float(i / 16));
    t[37] = RGB(50, 40, 30);
    Scene s = env_scene(make_envmap(16, 8, t, Transform::rotate(Vec3(1, 1, 0), 35)));
    const Light& env = s.lights[0];
    Rng rng(11, 1);
    for (int i = 0; i < 5000; ++i) {
        LightSample ls;
        ASSERT_TRUE(sample_light(s, Vec3(0.1f, 0.2f, 0.3f), rng.next_float(), {rng.next_float(), rng.next_float()}, &ls));
        EXPECT_FALSE(ls.delta);
        EXPECT_TRUE(std::isinf(ls.dist));
        EXPECT_EQ(ls.pdf, light_pdf(s, 0, 0, Vec3(0.1f, 0.2f, 0.3f), Vec3(0), Vec3(0), ls.wi));
        const RGB le = light_emitted(env, Vec3(0), -ls.wi);
        EXPECT_EQ(ls.radiance.r, le.r);
        EXPECT_EQ(ls.radiance.b, le.b);
    }
    // Midpoint rule over world directions (uniform in z and azimuth, cells of equal solid angle): the
    // density integrates to 1 and the radiance to the map's integral (its power), within the rule's
    // error at texel edges (cells cut by them are ~2 % of the area for this grid).
    const int nz = 500, nphi = 1000;
    double sum = 0, lum = 0;
    for (int i = 0; i < nz; ++i)
        for (int j = 0; j < nphi; ++j) {
            const double z = -1 + 2 * (i + 0.5) / nz, phi = 2 * M_PI * (j + 0.5) / nphi, r = std::sqrt(1 - z * z);
            const Vec3 d(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
            sum += envmap_pdf(*env.envmap, d);
            lum += envmap_eval(*env.envmap, d).g;
        }
    const double cell = 4 * M_PI / (double(nz) * nphi);
    EXPECT_NEAR(sum * cell, 1.0, 3e-3);
    EXPECT_NEAR(lum * cell / env.envmap->integral.g, 1.0, 3e-3);
}

// Caustic connections weigh a chain from the sky by p_e = p_select p(w) / (pi R^2) (light_emit_density):
// the density with which sample_emission makes its light path. A light path's flux is the radiance it
// carries over that density, so flux x p_e must give back the radiance, for every direction, or the
// weights would describe another sampler than the one that traced the pools.
TEST(EnvLights, ConnectionEmitDensityIsTheEmissionSamplersDensity) {
    std::vector<RGB> t(16 * 8);
    for (int i = 0; i < 16 * 8; ++i) t[size_t(i)] = RGB(0.2f + 0.1f * float(i % 5), 0.5f, 0.02f + 0.03f * float(i / 16));
    t[41] = RGB(80, 60, 40);
    Scene map = env_scene(make_envmap(16, 8, t, Transform::rotate(Vec3(0, 1, 1), 25)));
    Scene constant;
    Light c;
    c.type = LightType::Constant;
    c.radiance = RGB(2, 1, 0.5f);
    constant.lights.push_back(c);
    constant.bounds_min = Vec3(-2, -1, 0);
    constant.bounds_max = Vec3(3, 1, 2);
    lights_prepare(constant);
    for (const Scene* s : {&map, &constant}) {
        Rng rng(5, 3);
        for (int i = 0; i < 2000; ++i) {
            EmissionSample e;
            ASSERT_TRUE(sample_emission(*s, rng.next_float(), {rng.next_float(), rng.next_float()},
                                        {rng.next_float(), rng.next_float()}, &e));
            const float pe = light_emit_density(*s, e.light, -e.d);
            const RGB le = light_emitted(s->lights[e.light], Vec3(0), e.d);
            ASSERT_GT(pe, 0.0f);
            for (int k = 0; k < 3; ++k) ASSERT_NEAR(e.flux[k] * pe / le[k], 1.0, 1e-4) << i << " channel " << k;
        }
    }
}

TEST(EnvLights, ConstantMapHasPowerOfTheConstantEnvironment) {
    Scene s = env_scene(make_envmap(6, 3, std::vector<RGB>(18, RGB(2, 1, 0.5f)), Transform()));
    Light c;
    c.type = LightType::Constant;
    c.radiance = RGB(2, 1, 0.5f);
    const RGB pe = light_power(s, s.lights[0]), pc = light_power(s, c);
    EXPECT_NEAR(pe.r / pc.r, 1.0, 1e-5);
    EXPECT_NEAR(pe.b / pc.b, 1.0, 1e-5);
}

TEST(EnvLights, BlackMapsAndRowsGiveNoNaN) {
    Scene s = env_scene(make_envmap(4, 2, std::vector<RGB>(8, RGB(0)), Transform()));
    LightSample ls;
    EXPECT_FALSE(sample_light(s, Vec3(0), 0.5f, {0.5f, 0.5f}, &ls));
    EXPECT_EQ(envmap_pdf(*s.lights[0].envmap, Vec3(0, 0, 1)), 0.0f);
    EXPECT_EQ(light_pdf(s, 0, 0, Vec3(0), Vec3(0), Vec3(0), Vec3(0, 0, 1)), 0.0f);
    EXPECT_EQ(luminance(light_power(s, s.lights[0])), 0.0f);
    EmissionSample e;
    EXPECT_FALSE(sample_emission(s, 0.5f, {0.5f, 0.5f}, {0.5f, 0.5f}, &e));
    // Only the middle row lit: samples there, pdf finite everywhere (zero at the black rows and poles).
    std::vector<RGB> t(4 * 3, RGB(0));
    for (int x = 0; x < 4; ++x) t[size_t(4 + x)] = RGB(1);
    auto m = make_envmap(4, 3, t, Transform());
    Rng rng(5, 1);
    for (int i = 0; i < 1000; ++i) {
        Vec3 d = sample_uniform_sphere({rng.next_float(), rng.next_float()});
        float p = envmap_pdf(*m, d);
        EXPECT_TRUE(std::isfinite(p) && p >= 0);
        EXPECT_EQ(p > 0, std::abs(d.y) < 0.5f - 1e-4f || (std::abs(d.y) < 0.5f + 1e-4f && p > 0));
    }
    EXPECT_EQ(envmap_pdf(*m, Vec3(0, 1, 0)), 0.0f);
    EXPECT_EQ(envmap_pdf(*m, Vec3(0, -1, 0)), 0.0f);
}

TEST(EnvLights, BadMapsAreRefused) {
    EXPECT_THROW(make_envmap(0, 4, {}, Transform()), std::invalid_argument);
    EXPECT_THROW(make_envmap(4, 0, {}, Transform()), std::invalid_argument);
    EXPECT_THROW(make_envmap(2, 2, std::vector<RGB>(3), Transform()), std::invalid_argument);
    std::vector<RGB> t(4, RGB(1));
    t[2] = RGB(-1, 0, 0);
    EXPECT_THROW(make_envmap(2, 2, t, Transform()), std::invalid_argument);
    t[2] = RGB(NAN, 0, 0);
    EXPECT_THROW(make_envmap(2, 2, t, Transform()), std::invalid_argument);
}

Light spot_light(float cutoff_deg, float beam_deg) {
    Light l;
    l.type = LightType::Spot;
    l.position = Vec3(0, 0, 2);
    l.direction = Vec3(0, 0, -1);
    l.radiance = RGB(3, 2, 1);
    l.cutoff = cutoff_deg * float(M_PI / 180);
    l.beam_width = beam_deg * float(M_PI / 180);
    l.cos_cutoff = std::cos(l.cutoff);
    return l;
}

TEST(EnvLights, SpotFalloffIntensityAndPower) {
    Scene s;
    s.lights.push_back(spot_light(30, 20));
    s.bounds_min = Vec3(-1);
    s.bounds_max = Vec3(1);
    lights_prepare(s);
    const Light& l = s.lights[0];
    EXPECT_EQ(spot_falloff(l.cutoff, l.beam_width, l.cos_cutoff, std::cos(0.1f)), 1.0f);
    EXPECT_NEAR(spot_falloff(l.cutoff, l.beam_width, l.cos_cutoff, std::cos(25 * float(M_PI / 180))), 0.5f, 1e-4f);
    EXPECT_EQ(spot_falloff(l.cutoff, l.beam_width, l.cos_cutoff, std::cos(31 * float(M_PI / 180))), 0.0f);
    // Straight below at distance 2: I / d^2, a delta of mass 1 (times selection 1).
    LightSample ls;
    ASSERT_TRUE(sample_light(s, Vec3(0, 0, 0), 0.5f, {0.5f, 0.5f}, &ls));
    EXPECT_TRUE(ls.delta);
    EXPECT_FLOAT_EQ(ls.radiance.r, 3.0f / 4.0f);
    EXPECT_EQ(ls.pdf, 1.0f);
    EXPECT_FLOAT_EQ(ls.wi.z, 1.0f);
    EXPECT_EQ(light_pdf(s, 0, 0, Vec3(0), ls.p, ls.n, ls.wi), 1.0f);
    EXPECT_EQ(light_emitted(l, Vec3(0, 0, 1), Vec3(0, 0, 1)).r, 0.0f);
    // Outside the cone (45 degrees off the axis): nothing.
    EXPECT_FALSE(sample_light(s, Vec3(2, 0, 0), 0.5f, {0.5f, 0.5f}, &ls));
    // Power against a midpoint rule of 2 pi I int falloff sin.
    double num = 0;
    const int k = 200000;
    for (int i = 0; i < k; ++i) {
        double th = (i + 0.5) / k * M_PI;
        num += spot_falloff(l.cutoff, l.beam_width, l.cos_cutoff, float(std::cos(th))) * std::sin(th) * (M_PI / k);
    }
    EXPECT_NEAR(light_power(s, l).r / (3 * 2 * M_PI * num), 1.0, 1e-4);
    // Photon emission: the mean flux is the power (one light, selected with probability 1); every
    // photon leaves inside the cone.
    Rng rng(9, 1);
    double flux = 0;
    const int n = 200000;
    for (int i = 0; i < n; ++i) {
        EmissionSample e;
        if (!sample_emission(s, rng.next_float(), {rng.next_float(), rng.next_float()}, {rng.next_float(), rng.next_float()}, &e))
            continue;
        EXPECT_GT(-e.d.z, l.cos_cutoff - 1e-5f);
        flux += e.flux.r;
    }
    EXPECT_NEAR(flux / n / light_power(s, l).r, 1.0, 0.01);
}

TEST(EnvLights, DirectionalIsADeltaOfIrradiance) {
    Scene s;
    Light l;
    l.type = LightType::Directional;
    l.direction = normalize(Vec3(1, 0, -1));
    l.radiance = RGB(4, 2, 1);
    s.lights.push_back(l);
    s.bounds_min = Vec3(-1, -2, -2);
    s.bounds_max = Vec3(1, 2, 2);  // half diagonal 3
    lights_prepare(s);
    LightSample ls;
    ASSERT_TRUE(sample_light(s, Vec3(0.3f, 0.1f, 0), 0.2f, {0.1f, 0.9f}, &ls));
    EXPECT_TRUE(ls.delta);
    EXPECT_TRUE(std::isinf(ls.dist));
    EXPECT_EQ(ls.radiance.r, 4.0f);
    EXPECT_EQ(ls.pdf, 1.0f);
    EXPECT_FLOAT_EQ(ls.wi.x, -l.direction.x);
    EXPECT_FLOAT_EQ(ls.wi.z, -l.direction.z);
    EXPECT_EQ(light_emitted(s.lights[0], Vec3(0), -ls.wi).r, 0.0f);  // no ray hits it
    EXPECT_NEAR(light_power(s, s.lights[0]).r / (4 * M_PI * 9), 1.0, 1e-5);
    // Photons travel along the direction from a disk of radius 3 facing it, one radius before the
    // centre; each carries the whole power.
    Rng rng(2, 1);
    for (int i = 0; i < 100; ++i) {
        EmissionSample e;
        ASSERT_TRUE(sample_emission(s, rng.next_float(), {rng.next_float(), rng.next_float()}, {0.5f, 0.5f}, &e));
        EXPECT_FLOAT_EQ(e.d.x, l.direction.x);
        EXPECT_NEAR(dot(e.p, l.direction), -3.0f, 1e-4f);
        EXPECT_LE(length(e.p + l.direction * 3.0f), 3.0f + 1e-4f);
        EXPECT_NEAR(e.flux.r / light_power(s, s.lights[0]).r, 1.0f, 1e-6f);
    }
}

}  // namespace
}  // namespace iris
