// The render binary end to end on scenes with known answers, plus its command-line contract.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "formats/exr.h"
#include "support/image_stats.h"
#include "support/run_tool.h"

namespace fs = std::filesystem;
using namespace iris;
using namespace iris::test;

namespace {


Image render_scene(const std::string& scene, const std::string& extra, const TempDir& dir) {
    std::string out = dir.file("out.exr");
    ToolResult r = run_command(tool("render") + " " + scene + " -o " + out + " --variance -q " + extra);
    EXPECT_EQ(r.status, 0) << r.output;
    return read_exr(out);
}

// |mean - expected| within 4.5 standard errors (one deterministic, seeded test per channel) plus a
// small relative allowance for float rounding over long paths.
void expect_mean(const ImageStats& m, const double expected[3]) {
    for (int c = 0; c < 3; ++c) {
        double tol = 4.5 * m.se[c] + 1e-4 * expected[c];
        EXPECT_NEAR(m.mean[c], expected[c], tol) << "channel " << c << ", standard error " << m.se[c];
    }
}

}  // namespace

TEST(RenderAnalytic, FurnaceSphereEmitsAndReflects) {
    TempDir dir;
    Image img = render_scene(data_file("render/furnace_sphere.xml"), "--spp 64 --seed 3", dir);
    const double expected[3] = {5, 5, 5};  // Le / (1 - rho) = 1 / 0.2
    expect_mean(image_stats(img), expected);
}

TEST(RenderAnalytic, FurnaceSphereParameterOverride) {
    TempDir dir;
    Image img = render_scene(data_file("render/furnace_sphere.xml"), "--spp 64 -D rho=0.5 -D Le=3", dir);
    const double expected[3] = {6, 6, 6};
    expect_mean(image_stats(img), expected);
}

TEST(RenderAnalytic, FurnaceBoxMesh) {
    TempDir dir;
    Image img = render_scene(data_file("render/furnace_box.xml"), "--spp 64", dir);
    const double expected[3] = {1 / 0.5, 2 / 0.75, 0.5 / 0.25};
    expect_mean(image_stats(img), expected);
}

TEST(RenderAnalytic, SphereLightOverPlane) {
    TempDir dir;
    Image img = render_scene(data_file("render/sphere_light_over_plane.xml"), "--spp 256", dir);
    const double expected[3] = {0.3125, 0.3125, 0.3125};
    expect_mean(image_stats(img), expected);
}

// A thin pane (thindielectric) at 60 degrees between the camera and a red emitter, a green one in the
// mirror direction (tests/data/render/thin_pane.xml): red T' = 1 - R', green R' = 2R / (1 + R), with R
// one face's Fresnel reflectance from the textbook formulas (s and p polarisation). A model that counted
// one face only (R' = R = 0.089 instead of 0.164) is off by 50 standard errors.
TEST(RenderAnalytic, ThinPaneReflectsAndTransmits) {
    TempDir dir;
    Image img = render_scene(data_file("render/thin_pane.xml"), "--spp 256 --seed 5", dir);
    const double n = 1.5, cos_i = 0.5, sin_t = std::sqrt(1 - cos_i * cos_i) / n, cos_t = std::sqrt(1 - sin_t * sin_t);
    const double rs = (cos_i - n * cos_t) / (cos_i + n * cos_t), rp = (n * cos_i - cos_t) / (n * cos_i + cos_t);
    const double R = 0.5 * (rs * rs + rp * rp), R_pane = 2 * R / (1 + R);
    const double expected[3] = {1 - R_pane, R_pane, 0};
    expect_mean(image_stats(img), expected);
}

// Rough glass (roughdielectric, alpha 0.001) in its smooth limit: a slab between the camera and an
// emitter of radiance 1 lets (1 - R) / (1 + R) through at normal incidence, R = 0.04 per face
// (tests/data/render/rough_slab.xml), for both microfacet distributions. Refraction's radiance scaling
// must cancel between the two faces: leaving it out on one side would give 0.41 or 2.08.
TEST(RenderAnalytic, RoughGlassSlabInTheSmoothLimit) {
    TempDir dir;
    const double R = 0.04, T = (1 - R) / (1 + R);
    const double expected[3] = {T, T, T};
    for (const char* d : {"beckmann", "ggx"}) {
        SCOPED_TRACE(d);
        Image img = render_scene(data_file("render/rough_slab.xml"), std::string("--spp 1024 --seed 7 -D distribution=") + d, dir);
        expect_mean(image_stats(img), expected);
    }
}

TEST(RenderCli, SameSeedSameImageForAnyThreadCount) {
    TempDir dir;
    std::string scene = data_file("render/furnace_box.xml");
    auto a = run_command(tool("render") + " " + scene + " -o " + dir.file("a.exr") + " -q --spp 8 -t 1 --seed 9");
    auto b = run_command(tool("render") + " " + scene + " -o " + dir.file("b.exr") + " -q --spp 8 -t 2 --seed 9");
    ASSERT_EQ(a.status, 0) << a.output;
    ASSERT_EQ(b.status, 0) << b.output;
    Image ia = read_exr(dir.file("a.exr")), ib = read_exr(dir.file("b.exr"));
    ASSERT_EQ(ia.data.size(), ib.data.size());
    for (size_t c = 0; c < ia.data.size(); ++c) EXPECT_EQ(ia.data[c], ib.data[c]) << ia.channels[c];
    auto c = run_command(tool("render") + " " + scene + " -o " + dir.file("c.exr") + " -q --spp 8 -t 2 --seed 10");
    ASSERT_EQ(c.status, 0);
    EXPECT_NE(read_exr(dir.file("c.exr")).data[0], ia.data[0]) << "a different seed must change the noise";
}

// The caustic light tracer's splats are summed in path order whatever the threads (caustics.h): the
// caustic box (a glass sphere, a Gaussian-free box filter) with caustics=on gives identical images.
TEST(RenderCli, LightTracedCausticsAreTheSameForAnyThreadCount) {
    TempDir dir;
    const std::string scene = data_file("guiding/caustic_box.xml");
    auto a = run_command(tool("render") + " " + scene + " -o " + dir.file("a.exr") + " -q --spp 8 -t 1 --seed 9 --set caustics=on");
    auto b = run_command(tool("render") + " " + scene + " -o " + dir.file("b.exr") +
                         " -q --spp 8 -t 2 --seed 9 --set caustics=on --variance");
    ASSERT_EQ(a.status, 0) << a.output;
    ASSERT_EQ(b.status, 0) << b.output;
    Image ia = read_exr(dir.file("a.exr")), ib = read_exr(dir.file("b.exr"));
    for (const char* ch : {"R", "G", "B"})
        EXPECT_EQ(ia.data[size_t(ia.channel_index(ch))], ib.data[size_t(ib.channel_index(ch))]) << ch;
    EXPECT_EQ(ia.metadata.at("iris:light_paths"), std::to_string(8 * 32 * 32));
    EXPECT_EQ(ib.metadata.at("iris:caustics"), "light-traced, 1024 light paths per sample pass");
    // Where no area light can reach a surface through a Dirac bounce, nothing is traced.
    auto c = run_command(tool("render") + " " + data_file("render/furnace_box.xml") + " -o " + dir.file("c.exr") +
                         " -q --spp 2 --set caustics=on");
    ASSERT_EQ(c.status, 0) << c.output;
    EXPECT_EQ(read_exr(dir.file("c.exr")).metadata.at("iris:light_paths"), "0");
}

TEST(RenderCli, TimeBudgetAndLayers) {
    TempDir dir;
    std::string out = dir.file("t.exr");
    auto r = run_command(tool("render") + " " + data_file("render/furnace_box.xml") + " -o " + out +
                         " -q --time 0.5 --resolution 24x12 --set samples-layer=on --variance");
    ASSERT_EQ(r.status, 0) << r.output;
    Image img = read_exr(out);
    EXPECT_EQ(img.width, 24);
    EXPECT_EQ(img.height, 12);
    int s = img.channel_index("samples");
    ASSERT_GE(s, 0);
    int spp = std::stoi(img.metadata.at("iris:spp"));
    EXPECT_GE(spp, 1);
    EXPECT_EQ(img.data[s][0], float(spp));
    EXPECT_GE(img.channel_index("variance.G"), 0);
    EXPECT_EQ(img.metadata.at("iris:tool"), "render");
    EXPECT_NE(img.metadata.at("iris:command_line").find("--time 0.5"), std::string::npos);
    EXPECT_FALSE(img.metadata.at("iris:scene_fingerprint").empty());
}

