// A mask that hides half of what lies behind it halves the light that comes through, for every way iris
// finds that light: light samples (NEE: shadow rays, Scene::occluded), BSDF samples (closest-hit rays
// from the receiver, Scene::intersect) and photons (closest-hit rays from the light, trace_photons).
//
// The scene (written below, read by the real loader): a square light [-0.5, 0.5]^2 at z = 2 facing down,
// a mask [-2, 2]^2 at z = 1, and a receiver [-0.5, 0.5]^2 at z = 0; every surface black, so only
// direct light counts. Two masks hide half: opacity 0.5 everywhere, and a checkerboard whose two
// diagonal quadrants are opaque and the others transparent (opacity 0 and 1: Accel's filter is then
// exact, and the half comes from geometry). For the checkerboard the half is exact by symmetry: the
// scene is unchanged by a quarter turn about the z axis, which swaps opaque and transparent quadrants,
// and a straight path from the light to a point of the receiver crosses the mask in one quadrant. Each
// estimate is compared with half the estimate through a mask of opacity 0 (nothing hidden), by a
// z-test against both estimates' sample variances; 6 tests at |z| < 5 (false-alarm rate ~ 3e-6).
// Checked to fail (tests/mutants): shadow rays that ignore masks (mask_shadow_rays_opaque) leave NEE no
// light behind any mask (the open estimate is 0); a filter that keeps a hit with probability 1 - opacity
// (mask_opacity_inverted) makes the open mask and the checkerboard opaque everywhere (|z| 185-999). (An
// opacity of 0.5 alone could not tell the second.)
//
// The filter's numbers (mask_uniform) are checked too: uniform on [0, 1) over random rays, and
// independent between the two primitives one ray meets (chi-square).
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "formats/scene_xml.h"
#include "libcommon/accel.h"
#include "libcommon/lights.h"
#include "libcommon/rng.h"
#include "libcommon/sampling.h"
#include "libcommon/scene.h"
#include "support/chi2.h"
#include "tools/trace-photons/photon_tracer.h"

namespace fs = std::filesystem;

namespace iris {
namespace {

std::string scene_with_mask(const std::string& mask_bsdf) {
    return R"(<?xml version="1.0"?>
<scene version="0.5.0">
  <sensor type="perspective">
    <transform name="toWorld"><lookAt origin="0, -5, 0.5" target="0, 0, 0.5" up="0, 0, 1"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="0.5" y="0.5"/><translate z="2"/></transform>
    <boolean name="flipNormals" value="true"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0, 0, 0"/></bsdf>
    <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="2" y="2"/><translate z="1"/></transform>
    )" + mask_bsdf + R"(
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="0.5" y="0.5"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0, 0, 0"/></bsdf>
  </shape>
</scene>
)";
}

std::string constant_mask(float opacity) {
    return "<bsdf type=\"mask\"><spectrum name=\"opacity\" value=\"" + std::to_string(opacity) +
           "\"/><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0, 0, 0\"/></bsdf></bsdf>";
}
const char* kCheckerMask =
    "<bsdf type=\"mask\"><texture name=\"opacity\" type=\"checkerboard\"><rgb name=\"color0\" value=\"0, 0, 0\"/>"
    "<rgb name=\"color1\" value=\"1, 1, 1\"/></texture><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0, 0, 0\"/></bsdf></bsdf>";

Scene load_text(const std::string& text) {
    static std::atomic<int> counter{0};
    const fs::path path = fs::temp_directory_path() / ("iris_mask_irr_" + std::to_string(::getpid()) + "_" +
                                                       std::to_string(counter++) + ".xml");
    std::ofstream(path) << text;
    std::vector<std::string> warnings;
    SceneLoadOptions o;
    o.warnings = &warnings;
    Scene s = load_scene(path.string(), o);
    fs::remove(path);
    return s;
}

// A mean and the variance of that mean.
struct Estimate {
    double mean = 0, var = 0;
};
Estimate from_sums(double sum, double sum2, double n) {
    const double m = sum / n;
    return {m, std::max(0.0, sum2 / n - m * m) / n};
}

const Vec3 kReceiver(0.0f, 0.0f, 0.0f);  // centre of the receiver, normal +z
const Vec3 kOrigin(0.0f, 0.0f, 1e-5f);   // just above it: rays leave from here
constexpr int kSamples = 1000000;  // per estimate: photons and BSDF samples reach the light or the receiver 4-8 % of the time

// Irradiance at the receiver's centre from light samples: L cos / pdf where the shadow ray is free.
Estimate nee(const Scene& s, uint64_t seed) {
    Rng rng(seed, 1);
    double sum = 0, sum2 = 0;
    for (int i = 0; i < kSamples; ++i) {
        LightSample ls;
        const float u_sel = rng.next_float();
        const Vec2 u{rng.next_float(), rng.next_float()};
        if (!sample_light(s, kReceiver, u_sel, u, &ls) || ls.wi.z <= 0) continue;
        if (s.occluded(kOrigin, offset_ray_origin(ls.p, ls.n, -ls.wi))) continue;
        const double x = double(ls.radiance.r) * ls.wi.z / ls.pdf;
        sum += x;
        sum2 += x * x;
    }
    return from_sums(sum, sum2, kSamples);
}

// The same from cosine-distributed directions: pi times the radiance of the light where a ray hits it.
Estimate bsdf_sampling(const Scene& s, uint64_t seed) {
    Rng rng(seed, 2);
    double sum = 0, sum2 = 0;
    for (int i = 0; i < kSamples; ++i) {
        Ray r;
        r.o = kOrigin;
        r.d = sample_cosine_hemisphere({rng.next_float(), rng.next_float()});
        SurfaceHit h;
        if (!s.intersect(r, &h) || h.light < 0) continue;
        const double x = kPi * double(light_emitted(s.lights[size_t(h.light)], h.ng, -r.d).r);
        sum += x;
        sum2 += x * x;
    }
    return from_sums(sum, sum2, kSamples);
}

// The flux (W) that photons bring straight from the light onto the receiver (a path's first hit only:
// photon depth 1), with the variance of the sum (each path stores at most one such photon).
Estimate photon_flux(const Scene& s, uint64_t seed) {
    PhotonOptions o;
    o.paths = kSamples;
    o.max_depth = 1;
    o.seed = seed;
    o.quiet = true;
    PhotonStats stats;
    const PhotonMap m = trace_photons(s, o, &stats);
    Estimate e;
    for (size_t i = 0; i < m.size(); ++i)
        if (std::abs(m.position[i].z) < 1e-3f) {
            e.mean += m.power[i].r;
            e.var += double(m.power[i].r) * m.power[i].r;
        }
    // Var of a sum of N independent path contributions x_k: N Var(x) <= sum x_k^2 (the mean term is
    // small: a few % of paths reach the receiver); the bound keeps the test conservative.
    return e;
}

double z_half(const Estimate& masked, const Estimate& open) {
    return (masked.mean - 0.5 * open.mean) / std::sqrt(masked.var + 0.25 * open.var);
}

TEST(MaskIrradiance, HalfHiddenHalvesNeeBsdfSamplingAndPhotons) {
    const Scene open = load_text(scene_with_mask(constant_mask(0.0f)));
    const Scene half = load_text(scene_with_mask(constant_mask(0.5f)));
    const Scene checker = load_text(scene_with_mask(kCheckerMask));
    ASSERT_EQ(open.accel->masked_shapes(), 1u);
    struct Method {
        const char* name;
        Estimate (*estimate)(const Scene&, uint64_t);
    };
    const Method methods[] = {{"NEE", nee}, {"BSDF sampling", bsdf_sampling}, {"photons", photon_flux}};
    uint64_t seed = 11;
    for (const Method& m : methods) {
        const Estimate o = m.estimate(open, seed++);
        EXPECT_GT(o.mean, 0) << m.name << ": no light through a mask of opacity 0";
        for (const auto& [label, scene] : {std::pair<const char*, const Scene*>{"opacity 0.5", &half}, {"checkerboard", &checker}}) {
            const Estimate e = m.estimate(*scene, seed++);
            const double z = z_half(e, o);
            std::printf("%-14s %-12s open %.5f, masked %.5f (ratio %.4f), z = %.2f\n", m.name, label, o.mean, e.mean,
                        e.mean / o.mean, z);
            EXPECT_LT(std::abs(z), 5.0) << m.name << ", " << label << ": " << e.mean << " is not half of " << o.mean;
        }
    }
}

// mask_uniform over random rays: uniform in 64 bins, and the numbers of one ray at two primitives
// independent (8 x 8 bins of the pair). Pearson's statistic against the chi-square distribution, at
// significance 1e-4 each.
TEST(MaskIrradiance, FilterNumbersAreUniformAndIndependent) {
    Rng rng(5, 6);
    constexpr int n = 200000;
    std::vector<double> one(64, 0), pair(64, 0);
    for (int i = 0; i < n; ++i) {
        const Vec3 o(rng.next_float() * 10 - 5, rng.next_float() * 10 - 5, rng.next_float() * 10 - 5);
        const Vec3 d = sample_uniform_sphere({rng.next_float(), rng.next_float()});
        const uint32_t prim = rng.next_u32() % 1000;
        const float a = mask_uniform(o, d, 2, prim, false), b = mask_uniform(o, d, 2, prim + 1, false);
        ASSERT_GE(a, 0.0f);
        ASSERT_LT(a, 1.0f);
        one[size_t(a * 64)] += 1;
        pair[size_t(int(a * 8) * 8 + int(b * 8))] += 1;
    }
    for (const auto& [name, counts] : {std::pair<const char*, std::vector<double>*>{"uniform", &one}, {"pairs", &pair}}) {
        const double expected = double(n) / 64;
        double chi2 = 0;
        for (double c : *counts) chi2 += (c - expected) * (c - expected) / expected;
        const double p = test::gamma_q(63 / 2.0, chi2 / 2);
        std::printf("%s: chi2 = %.1f (63 dof), p = %.3g\n", name, chi2, p);
        EXPECT_GT(p, 1e-4) << name;
    }
}

}  // namespace
}  // namespace iris
