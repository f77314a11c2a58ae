// Caches point the right way (issue 46, item 4). A wrong but self-consistent fill-caches -- maps
// mirrored, or rotated into another frame -- keeps every guided estimator unbiased (the renderer
// samples and evaluates the same wrong map), so the agreement and chi-square tests cannot see it.
// This test looks at the maps themselves: on an open floor lit by one small sphere light, with a
// vertical mirror beside it, the light reaches the floor along two directions only, from the light and
// from its mirror image. With fill-caches counting the photons straight from the light (direct-photons=on), each
// usable cache's map must put its mode (its densest texel) within a stated angle of one of them.
//
// The angle, from the map's geometry and the fill's settings (all in radians):
//   texel     the largest angle between a texel's centre and its corners, over all texels (the mode's
//             centre stands for a direction anywhere in its texel), and once more for a neighbour
//             texel winning by the Gaussian filter (sigma 0.75 texels) and photon noise at an edge;
//   spread    atan(gather radius / distance to the light): photons are gathered from a disc around
//             the cache, each seeing the light from a slightly different direction;
//   size      asin(light radius / distance): the light is not a point.
// A mirrored map (mutant mirrored_cache_map: local (x, y, z) -> (-x, -y, z)) moves the mode by twice
// the light's angle from the normal: the test requires enough caches where that exceeds twice the
// bound, so that it has power, and fails the mutant.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "formats/cache_atlas.h"
#include "libcommon/math.h"
#include "libcommon/spheremap.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

namespace {

// Floor z = 0 (4 x 4, diffuse), a sphere light of radius kLightRadius at kLight, a mirror (silver) in
// the plane x = kMirrorX facing -x, the camera looking down.
const Vec3 kLight(0.0f, 0.0f, 1.0f);
constexpr float kLightRadius = 0.03f;
constexpr float kMirrorX = 1.2f;

const char* kScene = R"(<?xml version="1.0"?>
<scene version="0.5.0">
  <integrator type="path"><integer name="maxDepth" value="4"/></integrator>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="2" y="2"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale x="1" y="2"/><rotate y="1" angle="-90"/><translate x="1.2" z="1"/></transform>
    <bsdf type="conductor"><string name="material" value="Ag"/></bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" x="0" y="0" z="1"/>
    <float name="radius" value="0.03"/>
    <emitter type="area"><rgb name="radiance" value="100, 100, 100"/></emitter>
  </shape>
  <sensor type="perspective">
    <float name="fov" value="60"/>
    <transform name="toWorld"><lookAt origin="0, -0.01, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
  </sensor>
</scene>
)";

double angle(Vec3 a, Vec3 b) { return std::acos(std::clamp(double(dot(normalize(a), normalize(b))), -1.0, 1.0)); }

// Largest angle between a texel's centre and its corners, over all texels of an R x R map.
double texel_radius(int R) {
    double worst = 0;
    for (int j = 0; j < R; ++j)
        for (int i = 0; i < R; ++i) {
            const Vec3 c = sphere_texel_center(i, j, R);
            for (int dj = 0; dj <= 1; ++dj)
                for (int di = 0; di <= 1; ++di)
                    worst = std::max(worst, angle(c, square_to_sphere({float(i + di) / float(R), float(j + dj) / float(R)})));
        }
    return worst;
}

TEST(CacheOrientation, EachMapsModePointsToTheLightOrItsMirrorImage) {
    TempDir dir;
    const std::string scene = dir.file("scene.xml");
    std::ofstream(scene) << kScene;
    constexpr int R = 16, k = 200;
    auto run = [](const std::string& cmd) {
        const ToolResult r = run_command(cmd);
        EXPECT_EQ(r.status, 0) << cmd << "\n" << r.output;
        return r.status == 0;
    };
    ASSERT_TRUE(run(tool("trace-photons") + " " + scene + " -q " + cli::photon_paths(100000) + " --seed 3 -o " +
                    dir.file("p.h5")));
    ASSERT_TRUE(run(tool("place-caches") + " " + scene + " -q " + cli::photon_map(dir.file("p.h5")) + " " +
                    cli::cache_count(150) + " -o " + dir.file("c.h5")));
    ASSERT_TRUE(run(tool("fill-caches") + " " + dir.file("c.h5") + " -q " + cli::photon_map(dir.file("p.h5")) + " " +
                    cli::gather_count(k) + " " + cli::map_resolution(R) + " " + cli::direct_photons() + " -o " +
                    dir.file("a.h5")));
    const CacheAtlas a = read_cache_atlas(dir.file("a.h5")).atlas;
    ASSERT_EQ(a.resolution, R);
    const Vec3 image(2 * kMirrorX - kLight.x, kLight.y, kLight.z);  // the light's mirror image
    const double texel = texel_radius(R);
    int checked = 0, wrong = 0, discriminating = 0;
    double worst_excess = -1e9;
    std::string log;
    for (size_t c = 0; c < a.size(); ++c) {
        if (!a.usable[c] || a.position[c].z > 1e-3f || a.position[c].x > kMirrorX - 0.05f) continue;  // floor caches
        const Vec3 p = a.position[c], n = a.normal[c];
        const float* pdf = a.pdf_row(c);
        int mode = 0;
        for (int t = 1; t < R * R; ++t)
            if (pdf[t] > pdf[mode]) mode = t;
        const Vec3 d = Frame(n).to_world(sphere_texel_center(mode % R, mode / R, R));
        const Vec3 to_light = kLight - p, to_image = image - p;
        const double dist = std::min(length(to_light), length(to_image));
        const double bound = 2 * texel + std::atan(a.radius[c] / dist) + std::asin(kLightRadius / dist);
        const double off = std::min(angle(d, to_light), angle(d, to_image));
        ++checked;
        worst_excess = std::max(worst_excess, off - bound);
        // Power: where a mirrored map's mode (the light direction turned by 180 degrees about the normal)
        // lies more than twice the bound from both true directions.
        const Vec3 l = Frame(n).to_local(normalize(to_light));
        const Vec3 mirrored = Frame(n).to_world(Vec3(-l.x, -l.y, l.z));
        discriminating += std::min(angle(mirrored, to_light), angle(mirrored, to_image)) > 2 * bound;
        if (off > bound) {
            ++wrong;
            char buf[200];
            std::snprintf(buf, sizeof buf, "  cache %zu at (%.2f, %.2f): mode %.1f deg from the light or its image, bound %.1f deg\n",
                          c, p.x, p.y, off * 180 / M_PI, bound * 180 / M_PI);
            if (wrong <= 10) log += buf;
        }
    }
    std::printf("%d floor caches checked, %d discriminating; texel radius %.1f deg; %d beyond the bound "
                "(worst excess %.1f deg)\n", checked, discriminating, texel * 180 / M_PI, wrong, worst_excess * 180 / M_PI);
    ASSERT_GE(checked, 40) << "too few usable floor caches to test";
    EXPECT_GE(discriminating, checked / 2) << "the scene gives the test too little power against a mirrored map";
    EXPECT_EQ(wrong, 0) << "maps whose mode points away from the light:\n" << log;
}

}  // namespace
