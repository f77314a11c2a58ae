// Hybrid caches (render --set learn=on): the caches' maps refit from photons plus the radiance the render's
// paths receive. Their unbiasedness is tested per pixel in test_guiding_unbiased.cpp; here, what the
// refit must keep besides: the image is a function of the seed and the samples per pixel (not of the
// thread count), the refit changes the maps (else the per-pixel test proves nothing about them), the
// refit atlas is a valid stage file that render reads back, and the flags' errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "formats/cache_atlas.h"
#include "formats/exr.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

namespace {

bool build_atlas(const std::string& scene, const TempDir& dir) {
    auto run = [](const std::string& cmd) {
        ToolResult r = run_command(cmd);
        EXPECT_EQ(r.status, 0) << cmd << "\n" << r.output;
        return r.status == 0;
    };
    return run(tool("trace-photons") + " " + scene + " -q --set photon-paths=20000 --seed 1 -o " + dir.file("photons.h5")) &&
           run(tool("place-caches") + " " + scene + " -q --photon-map " + dir.file("photons.h5") + " --set cache-count=200 -o " +
               dir.file("caches.h5")) &&
           run(tool("fill-caches") + " " + dir.file("caches.h5") + " -q --photon-map " + dir.file("photons.h5") +
               " --set gather-count=200 -o " + dir.file("atlas.h5"));
}

Image render(const std::string& scene, const TempDir& dir, const std::string& name, const std::string& args) {
    const std::string out = dir.file(name + ".exr");
    const std::string cmd = tool("render") + " " + scene + " -q -o " + out + " " + args;
    ToolResult r = run_command(cmd);
    EXPECT_EQ(r.status, 0) << cmd << "\n" << r.output;
    return r.status == 0 ? read_exr(out) : Image{};
}

bool same_pixels(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height || a.data.size() != b.data.size()) return false;
    for (size_t c = 0; c < a.data.size(); ++c)
        if (a.data[c] != b.data[c]) return false;
    return true;
}

}  // namespace

TEST(HybridCaches, ImageDependsOnSeedAndSppOnlyAndRefitChangesIt) {
    TempDir dir;
    const std::string scene = data_file("guiding/caustic_box.xml");
    ASSERT_TRUE(build_atlas(scene, dir));
    const std::string args = "--spp 40 --seed 5 --set pilot=off --set guide-vertices=0 --atlas " + dir.file("atlas.h5");
    const Image one = render(scene, dir, "t1", args + " --set learn=on -t 1");
    const Image two = render(scene, dir, "t2", args + " --set learn=on -t 2 --write-atlas " + dir.file("refit.h5"));
    ASSERT_GT(one.width, 0);
    EXPECT_TRUE(same_pixels(one, two)) << "the refit maps depend on the thread count";
    EXPECT_NE(one.metadata.at("iris:hybrid_caches").find("6 refits"), std::string::npos)
        << one.metadata.at("iris:hybrid_caches");  // after 1, 2, 4, 8, 16, 32 spp
    const Image photons_only = render(scene, dir, "p", args);
    EXPECT_FALSE(same_pixels(one, photons_only)) << "the refits changed nothing";

    // The refit atlas: valid (read_cache_atlas validates), with path samples in some caches, and render
    // guides with it.
    const CacheAtlasFile photon = read_cache_atlas(dir.file("atlas.h5"));
    const CacheAtlasFile refit = read_cache_atlas(dir.file("refit.h5"));
    ASSERT_EQ(refit.atlas.size(), photon.atlas.size());
    size_t more = 0;
    for (size_t c = 0; c < refit.atlas.size(); ++c) more += refit.atlas.photon_count[c] > photon.atlas.photon_count[c];
    EXPECT_GT(more, 0u);
    EXPECT_NE(refit.atlas.pdf, photon.atlas.pdf);
    EXPECT_EQ(refit.header.provenance.tool, "render");
    const Image reused = render(scene, dir, "r", "--spp 4 --seed 5 --set pilot=off --atlas " + dir.file("refit.h5"));
    EXPECT_GT(reused.width, 0);
}

TEST(HybridCaches, FlagErrorsAreOneLineAndWriteNothing) {
    TempDir dir;
    const std::string scene = data_file("guiding/caustic_box.xml");
    struct Case {
        std::string args, message;
    };
    const Case cases[] = {{"--set learn=on", "setting learn=on needs --atlas"},
                          {"--write-atlas " + dir.file("a.h5"), "--write-atlas needs the setting learn=on"}};
    for (const Case& k : cases) {
        const std::string out = dir.file("bad.exr");
        ToolResult r = run_command(tool("render") + " " + scene + " -q --spp 1 -o " + out + " " + k.args);
        EXPECT_NE(r.status, 0) << k.args;
        EXPECT_NE(r.output.find("render: error: " + k.message), std::string::npos) << r.output;
        EXPECT_FALSE(std::filesystem::exists(out));
        EXPECT_FALSE(std::filesystem::exists(dir.file("a.h5")));
    }
}
