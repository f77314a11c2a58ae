// Stress: guiding caches built from too few photons, at every map resolution.
//
// Guards fill-caches (tools/fill-caches/cache_filler.h) and the guided renderer against the corner
// cases of its inputs: a photon map with zero photons or exactly one, fewer photons than k, all photons
// at one point and one direction (a map that is a single texel), photons exactly on the map's poles
// and seams, zero-power photons, map resolutions 1..64 (odd ones included), no filter and a filter
// wider than the map, floors 1 and 1e-6. Each atlas must satisfy the file contract
// (validate_cache_atlas), every usable map's PDF must be finite and integrate to 1, samples from it
// must have a positive finite density; and guided renders with such atlases, made by the real tools,
// must have zero NaN/Inf samples.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "formats/cache_atlas.h"
#include "formats/exr.h"
#include "formats/photon_map.h"
#include "formats/scene_xml.h"
#include "libcommon/rng.h"
#include "libcommon/spheremap.h"
#include "support/run_tool.h"
#include "tools/fill-caches/cache_filler.h"

using namespace iris;
using namespace iris::test;

namespace {

Vec3 unit(double x, double y, double z) {
    const double l = std::sqrt(x * x + y * y + z * z);
    return Vec3(float(x / l), float(y / l), float(z / l));
}

// Photons on the floor z = 0 of a unit scene, arriving from the upper hemisphere (normal +z).
PhotonMap floor_photons(int n, uint64_t seed) {
    PhotonMap m;
    Rng rng = Rng::for_index(seed, Stream::Test, 0);
    for (int i = 0; i < n; ++i) {
        m.position.push_back(Vec3(rng.next_float() * 0.2f, rng.next_float() * 0.2f, 0));
        const float z = 0.05f + 0.95f * rng.next_float(), phi = 6.2831853f * rng.next_float();
        const float r = std::sqrt(1 - z * z);
        m.direction.push_back(Vec3(r * std::cos(phi), r * std::sin(phi), z));
        m.normal.push_back(Vec3(0, 0, 1));
        m.power.push_back(RGB(1e-3f, 2e-3f, 5e-4f));
        m.bounces.push_back(uint8_t(1 + i % 3));
    }
    m.emitted_paths = uint64_t(std::max(n, 1));
    m.max_depth = 8;
    return m;
}

CachePoints floor_caches(int n) {
    CachePoints c;
    for (int i = 0; i < n; ++i) {
        c.position.push_back(Vec3(0.02f * float(i), 0.1f, 0));
        c.normal.push_back(Vec3(0, 0, 1));
        c.origin.push_back(uint8_t(i % 2));
    }
    return c;
}

// The atlas contract, plus: usable maps integrate to 1 with finite densities, and sampling them gives
// unit directions with a positive density equal to pdf() (the floor is positive).
void check_atlas(const CacheAtlas& a, const std::string& what) {
    ASSERT_EQ(validate_cache_atlas(a), "") << what;
    const int R = a.resolution;
    const double texel_sr = 4 * M_PI / double(a.texels());
    for (size_t c = 0; c < a.size(); ++c) {
        const float* pdf = a.pdf_row(c);
        const float* cdf = a.cdf_row(c);
        double integral = 0;
        for (size_t k = 0; k < a.texels(); ++k) {
            ASSERT_TRUE(std::isfinite(pdf[k]) && pdf[k] >= 0) << what << " cache " << c << " texel " << k;
            integral += pdf[k] * texel_sr;
        }
        ASSERT_TRUE(std::isfinite(a.radius[c]) && a.radius[c] >= 0) << what;
        if (!a.usable[c] && integral == 0) continue;  // "no map" is allowed for unusable caches
        EXPECT_NEAR(integral, 1.0, 1e-4) << what << " cache " << c;
        Rng rng = Rng::for_index(1, Stream::Test, c);
        for (int s = 0; s < 64; ++s) {
            Vec2 u{rng.next_float(), rng.next_float()};
            if (s == 0) u = {0, 0};
            if (s == 1) u = {0x1.fffffep-1f, 0x1.fffffep-1f};
            float p = -1;
            const Vec3 w = SphereDistribution::sample(cdf, pdf, R, u, &p);
            ASSERT_NEAR(length(w), 1.0f, 1e-5f) << what;
            ASSERT_TRUE(std::isfinite(p) && p > 0) << what << " cache " << c << " pdf " << p;
            ASSERT_EQ(p, SphereDistribution::pdf(pdf, R, w)) << what;
        }
    }
}

}  // namespace

// Library level: every corner case of photons x resolution x filter x floor gives a valid atlas.
TEST(GuidingCacheStress, FillCachesCornerCasesGiveValidAtlases) {
    struct PhotonCase {
        const char* name;
        PhotonMap map;
    };
    std::vector<PhotonCase> cases;
    cases.push_back({"zero photons", floor_photons(0, 1)});
    cases.push_back({"one photon", floor_photons(1, 2)});
    cases.push_back({"five photons", floor_photons(5, 3)});
    cases.push_back({"300 photons", floor_photons(300, 4)});
    {
        // All photons at one point from one direction: the map is a single texel before the filter.
        PhotonMap m = floor_photons(50, 5);
        for (size_t i = 0; i < m.size(); ++i) {
            m.position[i] = Vec3(0.02f, 0.1f, 0);
            m.direction[i] = unit(0.3, 0.1, 1);
        }
        cases.push_back({"coincident photons", m});
    }
    {
        // Directions on the map's poles and seams (local frame = world here: normal +z), and photons
        // of zero power (skipped: they carry nothing).
        PhotonMap m = floor_photons(40, 6);
        const Vec3 seams[] = {Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(-1, 0, 0), Vec3(0, -1, 0),
                              unit(1, 1, 0), unit(1, 0, 1), unit(0, -1, 1), unit(-1, 0, 1e-7), Vec3(0, 0, 1)};
        for (size_t i = 0; i < m.size(); ++i) {
            m.direction[i] = seams[i % 10];
            if (i % 7 == 0) m.power[i] = RGB(0.0f);
        }
        cases.push_back({"seam photons", m});
    }
    const int resolutions[] = {1, 2, 3, 4, 5, 7, 8, 13, 16, 31, 32, 64};
    const CachePoints caches = floor_caches(12);
    for (const PhotonCase& pc : cases)
        for (int R : resolutions)
            for (int variant = 0; variant < 3; ++variant) {
                // The filters cost O(R^4) to build: above R = 16 only the cases that matter there (one
                // photon, seams), and the all-texel-wide filter (variant 2) only up to R = 16.
                if (R > 16 && (variant == 2 || (pc.map.size() != 1 && std::string(pc.name) != "seam photons"))) continue;
                FillOptions o;
                o.resolution = R;
                o.k = variant == 0 ? 2000 : 1;  // k far above and at the bottom of the photon count
                o.min_photons = variant == 2 ? 32 : 1;
                o.filter_sigma = variant == 0 ? 0.75 : (variant == 1 ? 0.0 : 40.0);
                // Variant 1: the smallest floor a float CDF of R x R texels can hold (fill-caches
                // refuses smaller ones: their texels would get density 0).
                o.floor = variant == 1 ? double(R * R) * 0x1p-23 : (variant == 2 ? 1.0 : 0.1);
                o.direct = variant != 1;
                o.max_radius = 0.5;
                o.threads = 2;
                o.quiet = true;
                FillStats stats;
                const std::string what = std::string(pc.name) + " R=" + std::to_string(R) + " variant " + std::to_string(variant);
                CacheAtlas a;
                ASSERT_NO_THROW(a = fill_caches(caches, pc.map, 1.7, o, &stats)) << what;
                ASSERT_EQ(a.size(), caches.size()) << what;
                ASSERT_EQ(a.resolution, R);
                check_atlas(a, what);
                if (pc.map.size() == 0) {
                    EXPECT_EQ(stats.usable, 0u) << what;
                }
                if (pc.map.size() >= 1 && variant == 1) {
                    EXPECT_GT(stats.usable, 0u) << what;
                }
                EXPECT_TRUE(std::isfinite(stats.mean_radius) && std::isfinite(stats.mean_photons)) << what;
            }
}

// A floor too small for the float CDF (texels would get density 0, against the floor's promise) is
// refused with a clear message, not silently written.
TEST(GuidingCacheStress, FloorBelowFloatResolutionIsRefused) {
    const PhotonMap m = floor_photons(1, 2);
    const CachePoints caches = floor_caches(2);
    for (int R : {8, 64}) {
        FillOptions o;
        o.resolution = R;
        o.k = 1;
        o.min_photons = 1;
        o.filter_sigma = 0;
        o.floor = 1e-6;
        o.quiet = true;
        try {
            fill_caches(caches, m, 1.0, o, nullptr);
            ADD_FAILURE() << "R=" << R << ": a floor of 1e-6 was accepted";
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find("floor "), std::string::npos) << e.what();
        }
    }
}

namespace {

// A small closed box with a light and a diffuse floor, for the tool-level runs.
std::string write_scene(const TempDir& dir) {
    const std::string path = dir.file("scene.xml");
    std::ofstream(path) << R"(<?xml version="1.0"?>
<scene version="0.5.0">
  <integrator type="path"><integer name="maxDepth" value="6"/></integrator>
  <shape type="cube">
    <boolean name="flipNormals" value="true"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.5, 0.4"/></bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" x="0.2" y="0.1" z="-0.6"/><float name="radius" value="0.35"/>
    <bsdf type="dielectric"><float name="intIOR" value="1.5"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="0.3" y="0.3"/><rotate x="1" angle="180"/><translate z="0.95"/></transform>
    <emitter type="area"><rgb name="radiance" value="10, 10, 10"/></emitter>
  </shape>
  <sensor type="perspective">
    <float name="fov" value="70"/>
    <transform name="toWorld"><lookAt origin="0.5, -0.9, 0.3" target="0, 0, -0.7" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="8"/></sampler>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
  </sensor>
</scene>
)";
    return path;
}

void write_photons(const std::string& path, const PhotonMap& m, const std::string& fingerprint) {
    Provenance p;
    p.tool = "stress-test";
    p.tool_version = "0";
    p.command_line = "test_guiding_caches";
    p.inputs = "scene.xml " + fingerprint;
    write_photon_map(path, m, fingerprint, p);
}

}  // namespace

// Tool level: photon maps with 0, 1 and a handful of photons, and real ones, through place-caches,
// fill-caches (k above the photon count, resolutions 1..64) and a guided render: zero NaN/Inf samples.
TEST(GuidingCacheStress, GuidedRendersWithDegenerateAtlasesAreFinite) {
    TempDir dir;
    const std::string scene = write_scene(dir);
    const Scene sc = load_scene(scene);
    struct MapCase {
        std::string name, file;
    };
    std::vector<MapCase> maps;
    {
        PhotonMap empty;
        empty.emitted_paths = 1000;
        empty.max_depth = 8;
        write_photons(dir.file("empty.h5"), empty, sc.fingerprint);
        maps.push_back({"zero photons", dir.file("empty.h5")});
        // One photon on the floor under the light, arriving straight down (the map's pole).
        PhotonMap one;
        one.position = {Vec3(0.1f, -0.2f, -1.0f)};
        one.direction = {Vec3(0, 0, 1)};
        one.normal = {Vec3(0, 0, 1)};
        one.power = {RGB(0.5f)};
        one.bounces = {1};
        one.emitted_paths = 1;
        one.max_depth = 8;
        write_photons(dir.file("one.h5"), one, sc.fingerprint);
        maps.push_back({"one photon", dir.file("one.h5")});
    }
    for (int paths : {3, 2000}) {
        const std::string f = dir.file("traced" + std::to_string(paths) + ".h5");
        ToolResult r = run_command(tool("trace-photons") + " " + scene + " --set photon-paths=" + std::to_string(paths) +
                                   " --seed 4 -q -t 2 -o " + f);
        ASSERT_EQ(r.status, 0) << r.output;
        maps.push_back({std::to_string(paths) + " paths", f});
    }
    int renders = 0;
    for (const MapCase& m : maps) {
        const std::string ca = dir.file("caches.h5");
        ToolResult r = run_command(tool("place-caches") + " " + scene + " --photon-map " + m.file + " -o " + ca +
                                   " --set cache-count=64 --set camera-stride=4 --seed 1 -q -t 2");
        ASSERT_EQ(r.status, 0) << m.name << ": " << r.output;
        // Resolutions 1..64 spread over the maps (each fill + render is a few process starts).
        const std::vector<int> rs = m.name == "2000 paths" ? std::vector<int>{2, 4, 8, 17, 32} : std::vector<int>{1, 3, 16, 64};
        for (int R : rs) {
            const std::string at = dir.file("atlas.h5");
            r = run_command(tool("fill-caches") + " " + ca + " --photon-map " + m.file + " -o " + at +
                            " --set gather-count=500 --set min-photons=1 --set direct-photons=on --set map-resolution=" + std::to_string(R) + " -q -t 2");
            ASSERT_EQ(r.status, 0) << m.name << " R=" << R << ": " << r.output;
            const CacheAtlas atlas = read_cache_atlas(at, sc.fingerprint).atlas;
            check_atlas(atlas, m.name + " R=" + std::to_string(R));
            const std::string out = dir.file("g.exr");
            r = run_command(tool("render") + " " + scene + " --set pilot=off --atlas " + at + " --spp 4 --seed 3 -q -t 2 -o " + out);
            ASSERT_EQ(r.status, 0) << m.name << " R=" << R << ": " << r.output;
            const Image img = read_exr(out);
            EXPECT_EQ(img.metadata.at("iris:nonfinite_samples"), "0") << m.name << " R=" << R;
            for (const auto& ch : img.data)
                for (float v : ch) ASSERT_TRUE(std::isfinite(v)) << m.name << " R=" << R;
            ++renders;
        }
    }
    EXPECT_EQ(renders, 17);
}
