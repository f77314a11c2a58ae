// Stress: the same scene at very different scales and far from the origin renders the same image.
//
// Guards the rule that ray offsets, epsilons and radii are relative to the scene's scale, never
// absolute (a fixed 1e-4 offset swallows a millimetre-sized scene; a fixed gather radius sees nothing
// in a 10-kilometre one). The scene -- a closed diffuse box with a small area light, a glass sphere
// and a rough gold sphere, camera inside -- is generated here with every coordinate, radius and clip
// distance multiplied by s (and optionally shifted by a large offset), rendered by the `render`
// binary with a fixed seed, and the per-channel image means are compared with the unscaled render
// within 5 combined standard errors (from the --variance layers). The guided pipeline
// (trace-photons, place-caches, fill-caches, render --atlas) is run on the scaled scenes too: its
// stages have their own distances (gather radius, cache lookup radius, placement grid). Every image
// must be finite with iris:nonfinite_samples = 0.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "formats/cache_atlas.h"
#include "formats/exr.h"
#include "support/image_stats.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

namespace {

// ---- helpers (image statistics: support/image_stats.h) ----

// Means agree within 5 combined standard errors per channel (plus float-rounding slack).
void expect_same_mean(const ImageStats& a, const ImageStats& b, const std::string& what) {
    for (int c = 0; c < 3; ++c) {
        const double se = std::sqrt(a.se[c] * a.se[c] + b.se[c] * b.se[c]);
        EXPECT_NEAR(a.mean[c], b.mean[c], 5 * se + 1e-5 * std::abs(b.mean[c]))
            << what << ", channel " << "RGB"[c] << " (combined standard error " << se << ")";
    }
}

Image run_render(const std::string& args, const std::string& out) {
    ToolResult r = run_command(tool("render") + " " + args + " -o " + out + " --variance -q -t 2");
    EXPECT_EQ(r.status, 0) << r.output;
    if (r.status != 0) return Image{};
    return read_exr(out);
}

std::string fmt(double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.9g", v);
    return b;
}

// ---- the scene ----

// The box [-1,1]^3 at scale s, shifted by s * shift * (1, -0.7, 0.4): walls as an OBJ (inward
// facing), the light as an OBJ quad, two analytic spheres. Writes scene.xml (+ OBJs) into `dir` and
// returns its path.
std::string write_scene(const TempDir& dir, const std::string& tag, double s, double shift) {
    const double off[3] = {s * shift, -0.7 * s * shift, 0.4 * s * shift};
    auto P = [&](double x, double y, double z) {
        return fmt(s * x + off[0]) + " " + fmt(s * y + off[1]) + " " + fmt(s * z + off[2]);
    };
    auto pt = [&](const char* name, double x, double y, double z) {
        return std::string("<point name=\"") + name + "\" x=\"" + fmt(s * x + off[0]) + "\" y=\"" +
               fmt(s * y + off[1]) + "\" z=\"" + fmt(s * z + off[2]) + "\"/>";
    };
    // Walls: one OBJ per colour group. Each face is a quad wound so that its normal points inwards.
    auto quad_obj = [&](const std::string& name, const double (*q)[3]) {
        std::ofstream f(dir.file(name));
        for (int i = 0; i < 4; ++i) f << "v " << P(q[i][0], q[i][1], q[i][2]) << "\n";
        f << "f 1 2 3\nf 1 3 4\n";
    };
    // Inward normals: floor z=-1 (+z), ceiling z=1 (-z), x=-1 (+x), x=1 (-x), y=-1 (+y), y=1 (-y).
    const double floor_q[4][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1}};
    const double ceil_q[4][3] = {{-1, -1, 1}, {-1, 1, 1}, {1, 1, 1}, {1, -1, 1}};
    const double left_q[4][3] = {{-1, -1, -1}, {-1, 1, -1}, {-1, 1, 1}, {-1, -1, 1}};
    const double right_q[4][3] = {{1, -1, -1}, {1, -1, 1}, {1, 1, 1}, {1, 1, -1}};
    const double front_q[4][3] = {{-1, -1, -1}, {-1, -1, 1}, {1, -1, 1}, {1, -1, -1}};
    const double back_q[4][3] = {{-1, 1, -1}, {1, 1, -1}, {1, 1, 1}, {-1, 1, 1}};
    // The light: 0.5 x 0.5 at z = 0.98, facing down.
    const double light_q[4][3] = {{-0.25, -0.1, 0.98}, {-0.25, 0.4, 0.98}, {0.25, 0.4, 0.98}, {0.25, -0.1, 0.98}};
    quad_obj(tag + "floor.obj", floor_q);
    quad_obj(tag + "ceil.obj", ceil_q);
    quad_obj(tag + "left.obj", left_q);
    quad_obj(tag + "right.obj", right_q);
    quad_obj(tag + "front.obj", front_q);
    quad_obj(tag + "back.obj", back_q);
    quad_obj(tag + "light.obj", light_q);
    auto wall = [&](const std::string& obj, const char* rgb) {
        return "<shape type=\"obj\"><string name=\"filename\" value=\"" + tag + obj +
               "\"/><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"" + rgb + "\"/></bsdf></shape>\n";
    };
    std::string xml = "<?xml version=\"1.0\"?>\n<scene version=\"0.5.0\">\n"
                      "<integrator type=\"path\"><integer name=\"maxDepth\" value=\"8\"/></integrator>\n";
    xml += wall("floor.obj", "0.7, 0.7, 0.7") + wall("ceil.obj", "0.7, 0.7, 0.7") + wall("left.obj", "0.7, 0.15, 0.1") +
           wall("right.obj", "0.1, 0.6, 0.15") + wall("front.obj", "0.6, 0.6, 0.6") + wall("back.obj", "0.6, 0.6, 0.6");
    xml += "<shape type=\"obj\"><string name=\"filename\" value=\"" + tag +
           "light.obj\"/><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.2, 0.2, 0.2\"/></bsdf>"
           "<emitter type=\"area\"><rgb name=\"radiance\" value=\"12, 11, 9\"/></emitter></shape>\n";
    xml += "<shape type=\"sphere\">" + pt("center", -0.35, 0.15, -0.62) + "<float name=\"radius\" value=\"" +
           fmt(0.38 * s) + "\"/><bsdf type=\"dielectric\"><float name=\"intIOR\" value=\"1.5\"/></bsdf></shape>\n";
    xml += "<shape type=\"sphere\">" + pt("center", 0.5, 0.45, -0.7) + "<float name=\"radius\" value=\"" +
           fmt(0.3 * s) + "\"/><bsdf type=\"roughconductor\"><string name=\"material\" value=\"Au\"/>"
           "<float name=\"alpha\" value=\"0.2\"/></bsdf></shape>\n";
    xml += "<sensor type=\"perspective\"><float name=\"fov\" value=\"70\"/>"
           "<float name=\"nearClip\" value=\"" + fmt(1e-2 * s) + "\"/><float name=\"farClip\" value=\"" +
           fmt(100 * s) + "\"/><transform name=\"toWorld\"><lookAt origin=\"" + P(0.1, -0.92, 0.3) +
           "\" target=\"" + P(0, 0.3, -0.6) + "\" up=\"0, 0, 1\"/></transform>"
           "<sampler type=\"independent\"><integer name=\"sampleCount\" value=\"16\"/></sampler>"
           "<film type=\"hdrfilm\"><integer name=\"width\" value=\"24\"/><integer name=\"height\" value=\"24\"/>"
           "<rfilter type=\"box\"/></film></sensor>\n</scene>\n";
    const std::string path = dir.file(tag + "scene.xml");
    std::ofstream(path) << xml;
    return path;
}

struct Variant {
    const char* name;
    double s, shift;
};
// shift is in units of the scene's own size: 1e4 puts a 2-unit box at ~1e4 (float ULP there is
// ~1e-3, i.e. 5e-4 of the box: the geometry itself is still resolved to 0.1 %).
const Variant kVariants[] = {
    {"s=1e-3", 1e-3, 0}, {"s=1e4", 1e4, 0}, {"s=1,shift=1e4", 1, 1e4}, {"s=1e-3,shift=1e4", 1e-3, 1e4},
    {"s=1e4,shift=1e4", 1e4, 1e4},
};
constexpr int kSpp = 256;

}  // namespace

// Unguided: every variant's image mean equals the unit scene's within noise.
TEST(ScaleInvariance, UnguidedRenderIndependentOfScaleAndPosition) {
    TempDir dir;
    const std::string common = " --spp " + std::to_string(kSpp) + " --seed 7";
    Image ref_img = run_render(write_scene(dir, "unit_", 1, 0) + common, dir.file("unit.exr"));
    ASSERT_GT(ref_img.width, 0);
    expect_no_nonfinite(ref_img, "s=1");
    const ImageStats ref = image_stats(ref_img);
    ASSERT_GT(ref.mean[0], 0.05) << "the reference scene must be lit";
    for (const Variant& v : kVariants) {
        const std::string tag = std::string("v") + std::to_string(&v - kVariants) + "_";
        Image img = run_render(write_scene(dir, tag, v.s, v.shift) + common, dir.file(tag + ".exr"));
        ASSERT_GT(img.width, 0) << v.name;
        expect_no_nonfinite(img, v.name);
        expect_same_mean(image_stats(img), ref, v.name);
    }
}

// Guided: the whole pipeline on each scale; the guided render's mean equals the unguided unit render's.
TEST(ScaleInvariance, GuidedPipelineIndependentOfScaleAndPosition) {
    TempDir dir;
    const std::string common = " --spp " + std::to_string(kSpp) + " --seed 11";
    Image ref_img = run_render(write_scene(dir, "unit_", 1, 0) + common, dir.file("unit.exr"));
    ASSERT_GT(ref_img.width, 0);
    const ImageStats ref = image_stats(ref_img);
    const Variant guided_variants[] = {{"s=1", 1, 0}, {"s=1e-3", 1e-3, 0}, {"s=1e4", 1e4, 0}, {"s=1e-3,shift=1e4", 1e-3, 1e4}};
    for (const Variant& v : guided_variants) {
        const std::string tag = std::string("g") + std::to_string(&v - guided_variants) + "_";
        const std::string scene = write_scene(dir, tag, v.s, v.shift);
        const std::string ph = dir.file(tag + "photons.h5"), ca = dir.file(tag + "caches.h5"),
                          at = dir.file(tag + "atlas.h5");
        ToolResult r = run_command(tool("trace-photons") + " " + scene + " -o " + ph + " --set photon-paths=20000 --seed 3 -q -t 2");
        ASSERT_EQ(r.status, 0) << v.name << ": " << r.output;
        r = run_command(tool("place-caches") + " " + scene + " --photon-map " + ph + " -o " + ca +
                        " --set cache-count=300 --set camera-stride=4 --resolution 24x24 --seed 3 -q -t 2");
        ASSERT_EQ(r.status, 0) << v.name << ": " << r.output;
        r = run_command(tool("fill-caches") + " " + ca + " --photon-map " + ph + " -o " + at +
                        " --set gather-count=100 --set map-resolution=8 --set min-photons=8 -q -t 2");
        ASSERT_EQ(r.status, 0) << v.name << ": " << r.output;
        // The caches must actually guide: most of them usable (a radius that is absolute would leave
        // them empty at s = 1e-3 or give every one the same far-away photons at s = 1e4).
        const CacheAtlas atlas = read_cache_atlas(at).atlas;
        EXPECT_EQ(validate_cache_atlas(atlas), "") << v.name;
        size_t usable = 0;
        for (uint8_t u : atlas.usable) usable += u;
        EXPECT_GT(usable, atlas.size() * 3 / 4) << v.name << ": " << usable << " of " << atlas.size() << " caches usable";
        Image img = run_render(scene + common + " --set pilot=off --atlas " + at, dir.file(tag + ".exr"));
        ASSERT_GT(img.width, 0) << v.name;
        expect_no_nonfinite(img, std::string("guided ") + v.name);
        expect_same_mean(image_stats(img), ref, std::string("guided ") + v.name);
    }
}
