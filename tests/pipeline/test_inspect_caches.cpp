// inspect-caches on the golden stage files (tests/golden/): the statistics it prints agree with the
// files, and the image of a cache's PDF is that PDF (it integrates to 1 over the sphere in both layouts).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "formats/cache_atlas.h"
#include "formats/exr.h"
#include "formats/photon_map.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

namespace {

std::string golden(const std::string& name) { return std::string(IRIS_SOURCE_DIR) + "/tests/golden/" + name; }

// The value printed after `name` on its own line ("name   value").
std::string field(const std::string& output, const std::string& name) {
    const std::string text = "\n" + output;
    size_t at = text.find("\n" + name + "  ");
    if (at == std::string::npos) return "";
    at = text.find_first_not_of(' ', at + 1 + name.size());
    return text.substr(at, text.find('\n', at) - at);
}

TEST(InspectCaches, PhotonMapStatisticsMatchTheFile) {
    ToolResult r = run_command(tool("inspect-caches") + " " + golden("photons.h5"));
    ASSERT_EQ(r.status, 0) << r.output;
    const PhotonMap m = read_photon_map(golden("photons.h5")).photons;
    EXPECT_EQ(field(r.output, "photons"), std::to_string(m.size())) << r.output;
    EXPECT_EQ(field(r.output, "emitted paths"), std::to_string(m.emitted_paths));
    EXPECT_NE(field(r.output, "format"), "");
}

TEST(InspectCaches, AtlasStatisticsMatchTheFile) {
    ToolResult r = run_command(tool("inspect-caches") + " " + golden("atlas.h5"));
    ASSERT_EQ(r.status, 0) << r.output;
    const CacheAtlas a = read_cache_atlas(golden("atlas.h5")).atlas;
    EXPECT_EQ(field(r.output, "caches"), std::to_string(a.size())) << r.output;
    size_t usable = 0;
    for (uint8_t u : a.usable) usable += u;
    EXPECT_EQ(field(r.output, "usable"), std::to_string(usable));
    ToolResult c = run_command(tool("inspect-caches") + " " + golden("caches.h5"));
    ASSERT_EQ(c.status, 0) << c.output;
    EXPECT_EQ(field(c.output, "caches"), std::to_string(a.size())) << c.output;
}

// The EXR of a cache's PDF integrates to 1: in lat-long, sum of pdf * sin(theta) dtheta dphi; in the
// octahedral layout, every pixel is an equal share of 4 pi sr.
TEST(InspectCaches, PdfImagesIntegrateToOne) {
    TempDir d;
    const CacheAtlas a = read_cache_atlas(golden("atlas.h5")).atlas;
    size_t c = 0;
    while (c < a.size() && !a.usable[c]) ++c;
    ASSERT_LT(c, a.size());
    const std::string base = tool("inspect-caches") + " " + golden("atlas.h5") + " --cache " + std::to_string(c);
    ToolResult r = run_command(base + " --size 256 -o " + d.file("ll.exr"));
    ASSERT_EQ(r.status, 0) << r.output;
    Image ll = read_exr(d.file("ll.exr"));
    ASSERT_EQ(ll.width, 512);
    double sum = 0;
    for (int y = 0; y < ll.height; ++y)
        for (int x = 0; x < ll.width; ++x) {
            const double theta = M_PI * (y + 0.5) / ll.height;
            sum += ll.data[0][size_t(y) * ll.width + x] * std::sin(theta) * (M_PI / ll.height) * (2 * M_PI / ll.width);
        }
    EXPECT_NEAR(sum, 1.0, 0.02);  // (texel edges cut through lat-long pixels: a quadrature error)

    r = run_command(base + " --layout octahedral --size 2 -o " + d.file("oct.exr"));
    ASSERT_EQ(r.status, 0) << r.output;
    Image oct = read_exr(d.file("oct.exr"));
    ASSERT_EQ(oct.width, 2 * a.resolution);
    double s2 = 0;
    for (float v : oct.data[0]) s2 += v * 4 * M_PI / double(oct.data[0].size());
    EXPECT_NEAR(s2, 1.0, 1e-4);

    r = run_command(base + " -o " + d.file("pdf.png"));
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_TRUE(std::filesystem::exists(d.file("pdf.png")));
}

// --pixel finds the cache the renderer would use: one that exists and lies near the scene's surfaces.
TEST(InspectCaches, PixelFindsTheServingCache) {
    const std::string scene = std::string(IRIS_SOURCE_DIR) + "/tests/data/guiding/caustic_box.xml";
    ToolResult r = run_command(tool("inspect-caches") + " " + golden("atlas.h5") + " --scene " + scene + " --pixel 16,24");
    ASSERT_EQ(r.status, 0) << r.output;
    const std::string c = field(r.output, "cache");
    ASSERT_FALSE(c.empty()) << r.output;
    EXPECT_LT(std::stoul(c), read_cache_atlas(golden("atlas.h5")).atlas.size());
}

}  // namespace
