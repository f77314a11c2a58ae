// Stress: lights of radiance 1e-20, 1e20 and 0.
//
// Guards the float range of everything downstream of a light: path throughput, the film's sums and
// the --variance layer (the square of a 1e20 sample is 1e40, beyond float), photon powers, cache maps.
// Radiance enters every estimate linearly and no sampling decision depends on it (one light: its
// selection probability is 1; Russian roulette looks at the throughput), so with the same seed the
// image at radiance r must equal r times the image at radiance 1 up to float rounding -- a much
// sharper check than "within noise". A scene whose only light is black renders black (not NaN), and
// trace-photons refuses it with one clear line (a photon map of a dark scene would be empty and every
// later stage useless: an error says so where the cause is). Every image must be finite with
// iris:nonfinite_samples = 0.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "formats/cache_atlas.h"
#include "formats/exr.h"
#include "formats/photon_map.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

namespace {

void expect_clean(const Image& img, const std::string& what) {
    auto it = img.metadata.find("iris:nonfinite_samples");
    ASSERT_NE(it, img.metadata.end()) << what;
    EXPECT_EQ(it->second, "0") << what << ": NaN/Inf samples reached the film";
    for (size_t c = 0; c < img.data.size(); ++c)
        for (size_t i = 0; i < img.data[c].size(); ++i)
            ASSERT_TRUE(std::isfinite(img.data[c][i]) && img.data[c][i] >= 0)
                << what << ": channel " << img.channels[c] << " pixel " << i << " = " << img.data[c][i];
}

Image render(const std::string& scene, const std::string& args, const std::string& out) {
    ToolResult r = run_command(tool("render") + " " + scene + " -o " + out + " --variance -q -t 2 " + args);
    EXPECT_EQ(r.status, 0) << args << ": " << r.output;
    if (r.status != 0) return Image{};
    return read_exr(out);
}

const std::vector<float>& channel(const Image& img, const char* name) {
    const int i = img.channel_index(name);
    EXPECT_GE(i, 0) << name;
    return img.data[size_t(std::max(i, 0))];
}

// A closed diffuse box with a glass sphere, and a square light (radiance $L) that the camera sees
// partly (its edge crosses pixels: those pixels have the largest variance).
std::string write_scene(const TempDir& dir, const std::string& extra_light = "") {
    const std::string path = dir.file("scene.xml");
    std::ofstream(path) << R"(<?xml version="1.0"?>
<scene version="0.5.0">
  <default name="L" value="1"/>
  <integrator type="path"><integer name="maxDepth" value="8"/></integrator>
  <shape type="cube">
    <boolean name="flipNormals" value="true"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.5, 0.4"/></bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" x="0.3" y="0.2" z="-0.6"/><float name="radius" value="0.35"/>
    <bsdf type="dielectric"><float name="intIOR" value="1.5"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="0.3" y="0.3"/><rotate x="1" angle="180"/><translate z="0.95"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.3, 0.3, 0.3"/></bsdf>
    <emitter type="area"><rgb name="radiance" value="$L, $L, $L"/></emitter>
  </shape>
)" + extra_light + R"(
  <sensor type="perspective">
    <float name="fov" value="80"/>
    <transform name="toWorld"><lookAt origin="0, -0.9, -0.3" target="0, 0, 0.6" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="16"/></sampler>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
  </sensor>
</scene>
)";
    return path;
}

}  // namespace

// Same seed: image(r) = r * image(1) per pixel and channel, for r = 1e-20 and 1e20, to float rounding.
// The variance layer stays finite: r^2 * var(1) where that fits a float, the largest float where not.
// 4 spp: a pixel on the light's edge then has a per-pixel variance of ~1e39 at r = 1e20.
TEST(ExtremeRadiance, ImagesScaleLinearlyAndStayFinite) {
    TempDir dir;
    const std::string scene = write_scene(dir);
    const std::string args = "--spp 4 --seed 5";
    Image one = render(scene, args + " -D L=1", dir.file("one.exr"));
    ASSERT_GT(one.width, 0);
    expect_clean(one, "L=1");
    for (double r : {1e-20, 1e20}) {
        char def[64];
        std::snprintf(def, sizeof def, " -D L=%g", r);
        Image img = render(scene, args + def, dir.file("r.exr"));
        ASSERT_GT(img.width, 0) << def;
        expect_clean(img, def);
        int mismatches = 0, saturated = 0, scaled = 0;
        for (const char* name : {"R", "G", "B"}) {
            const auto &a = channel(img, name), &b = channel(one, name);
            for (size_t i = 0; i < a.size(); ++i) {
                const double want = r * double(b[i]);
                if (std::abs(a[i] - want) > 1e-5 * want + 1e-30 * r && ++mismatches <= 5)
                    ADD_FAILURE() << def << " channel " << name << " pixel " << i << ": " << a[i] << " vs " << want;
            }
        }
        for (int c = 0; c < 3; ++c) {
            const char* name = std::array{"variance.R", "variance.G", "variance.B"}[size_t(c)];
            const auto &a = channel(img, name), &b = channel(one, name);
            const auto& mean = channel(one, std::array{"R", "G", "B"}[size_t(c)]);
            for (size_t i = 0; i < a.size(); ++i) {
                // The variance is E[x^2] - E[x]^2 of float samples: rounding of order 1e-7 of the mean
                // squared, amplified where the variance is small against it.
                const double m = r * double(mean[i]);
                const double want = r * r * double(b[i]);
                if (want > 0.5 * std::numeric_limits<float>::max()) {
                    // Beyond float: saturated at the largest float, never inf.
                    EXPECT_GE(a[i], 0.5f * std::numeric_limits<float>::max()) << def << " " << name << " pixel " << i;
                    saturated += a[i] == std::numeric_limits<float>::max();
                } else if (want > 1e-30) {
                    EXPECT_NEAR(a[i], want, 1e-4 * want + 1e-5 * m * m) << def << " " << name << " pixel " << i;
                    ++scaled;
                }
            }
        }
        // Some pixel's variance must exceed float's range (it did before film.cpp saturated it: the render
        // then failed, refusing to write an infinite value).
        if (r > 1) {
            EXPECT_GT(saturated, 0) << "the test must reach beyond the float range of the variance";
            EXPECT_GT(scaled, 0);
        }
        EXPECT_EQ(mismatches, 0) << def;
    }
}

// A black light: a black image (exactly 0, variance 0), no NaN; trace-photons refuses the scene with
// one line naming it and writes nothing.
TEST(ExtremeRadiance, ZeroRadianceGivesBlackImageAndClearPhotonError) {
    TempDir dir;
    const std::string scene = write_scene(dir);
    Image img = render(scene, "--spp 8 -D L=0", dir.file("black.exr"));
    ASSERT_GT(img.width, 0);
    expect_clean(img, "L=0");
    for (size_t c = 0; c < img.data.size(); ++c)
        for (float v : img.data[c]) ASSERT_EQ(v, 0.0f) << img.channels[c];
    const std::string out = dir.file("photons.h5");
    ToolResult r = run_command(tool("trace-photons") + " " + scene + " -D L=0 --set photon-paths=1000 -q -o " + out);
    EXPECT_NE(r.status, 0) << r.output;
    EXPECT_EQ(r.output.rfind("trace-photons: error: ", 0), 0u) << r.output;
    EXPECT_NE(r.output.find("no light with power"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("scene.xml"), std::string::npos) << "the message names the scene: " << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << "one line: " << r.output;
    EXPECT_FALSE(std::filesystem::exists(out));
}

// Lights of 1e20 and 1e-20 (and a black one) in one scene: light selection spans 40 orders of
// magnitude (the faint light's probability underflows), and nothing may turn NaN, in the render or in
// the photons.
TEST(ExtremeRadiance, MixedExtremeLightsStayFinite) {
    TempDir dir;
    const std::string lights = R"(
  <shape type="sphere">
    <point name="center" x="-0.6" y="0.5" z="0.6"/><float name="radius" value="0.1"/>
    <emitter type="area"><rgb name="radiance" value="1e-20, 1e-20, 1e-20"/></emitter>
  </shape>
  <shape type="sphere">
    <point name="center" x="0.6" y="0.5" z="0.6"/><float name="radius" value="0.1"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>
    <emitter type="area"><rgb name="radiance" value="0, 0, 0"/></emitter>
  </shape>)";
    const std::string scene = write_scene(dir, lights);
    Image img = render(scene, "--spp 64 -D L=1e20", dir.file("mixed.exr"));
    ASSERT_GT(img.width, 0);
    expect_clean(img, "mixed");
    const std::string ph = dir.file("p.h5");
    ToolResult r = run_command(tool("trace-photons") + " " + scene + " -D L=1e20 --set photon-paths=5000 -q -t 2 -o " + ph);
    ASSERT_EQ(r.status, 0) << r.output;
    const PhotonMap map = read_photon_map(ph).photons;
    EXPECT_GT(map.size(), 1000u);
    for (const RGB& p : map.power)
        for (int c = 0; c < 3; ++c) ASSERT_TRUE(std::isfinite(p[c]) && p[c] >= 0);
}

// The photon pipeline at 1e-20 and 1e20: photon powers scale linearly (same seed: same paths), the
// atlas is valid, and guided renders are finite with no NaN/Inf sample.
TEST(ExtremeRadiance, GuidedPipelineAtExtremeRadiance) {
    TempDir dir;
    const std::string scene = write_scene(dir);
    double total_one = 0;
    for (double r : {1.0, 1e-20, 1e20}) {
        char def[64];
        std::snprintf(def, sizeof def, " -D L=%g", r);
        const std::string ph = dir.file("p.h5"), ca = dir.file("c.h5"), at = dir.file("a.h5");
        ToolResult t = run_command(tool("trace-photons") + " " + scene + def + " --set photon-paths=8000 --seed 2 -q -t 2 -o " + ph);
        ASSERT_EQ(t.status, 0) << def << t.output;
        const PhotonMap map = read_photon_map(ph).photons;
        ASSERT_GT(map.size(), 1000u);
        double total = 0;
        for (const RGB& p : map.power) {
            ASSERT_TRUE(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])) << def;
            total += double(p[0]) + p[1] + p[2];
        }
        if (r == 1.0) total_one = total;
        EXPECT_NEAR(total / r, total_one, 1e-4 * total_one) << def << ": photon power must scale with the radiance";
        t = run_command(tool("place-caches") + " " + scene + def + " --photon-map " + ph + " -o " + ca +
                        " --set cache-count=100 --set camera-stride=4 --seed 2 -q -t 2");
        ASSERT_EQ(t.status, 0) << def << t.output;
        t = run_command(tool("fill-caches") + " " + ca + " --photon-map " + ph + " -o " + at + " --set gather-count=64 --set map-resolution=8 -q -t 2");
        ASSERT_EQ(t.status, 0) << def << t.output;
        const CacheAtlas atlas = read_cache_atlas(at).atlas;
        EXPECT_EQ(validate_cache_atlas(atlas), "") << def;
        Image img = render(scene, std::string("--spp 16 --set pilot=off --atlas ") + at + def, dir.file("g.exr"));
        ASSERT_GT(img.width, 0) << def;
        expect_clean(img, std::string("guided") + def);
    }
}
