// export-scene (the scene as iris loaded it, for scripts/cycles_render.py): the JSON carries the numbers
// the loader produced (sizes, spheres, the RGB radiance derived from the file's spectrum, the camera
// prepared for the requested film), and bad input gets one error line and no file.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "formats/scene_xml.h"
#include "libcommon/camera.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

namespace {

std::string kugeln() { return std::string(IRIS_SOURCE_DIR) + "/scenes/thesis/cbox_kugeln.xml"; }

std::string slurp(const std::string& path) {
    std::ifstream f(path);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
}

std::string g9(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.9g", v);
    return b;
}

}  // namespace

TEST(ExportScene, CarriesTheLoadedScene) {
    TempDir d;
    const std::string out = (d.path / "scene.json").string();
    ToolResult r = run_command(tool("export-scene") + " " + kugeln() + " -o " + out + " --resolution 256x128");
    ASSERT_EQ(r.status, 0) << r.output;
    const std::string j = slurp(out);
    SceneLoadOptions quiet;
    std::vector<std::string> warnings;
    quiet.warnings = &warnings;
    Scene s = parse_scene(kugeln(), quiet);
    EXPECT_NE(j.find("\"width\":256,\"height\":128,\"max_depth\":" + std::to_string(s.defaults.max_depth)),
              std::string::npos) << j.substr(0, 300);
    ASSERT_EQ(s.spheres.size(), 2u);
    EXPECT_NE(j.find("\"spheres\":[{\"center\":[200,380,300],\"radius\":90,\"bsdf\":" +
                     std::to_string(s.spheres[0].bsdf)), std::string::npos);
    ASSERT_EQ(s.lights.size(), 1u);
    const RGB L = s.lights[0].radiance;
    EXPECT_NE(j.find("\"lights\":[{\"radiance\":[" + g9(L.r) + "," + g9(L.g) + "," + g9(L.b) + "]}]"),
              std::string::npos);
    // The camera as render prepares it for 256 x 128: half-height tangent half the width's (square pixels).
    Camera c = s.camera;
    camera_prepare(c, 256, 128);
    EXPECT_NE(j.find("\"tan_half_x\":" + g9(c.tan_half_x) + ",\"tan_half_y\":" + g9(c.tan_half_y)),
              std::string::npos);
    EXPECT_NE(j.find("\"right\":[" + g9(c.right.x) + "," + g9(c.right.y) + "," + g9(c.right.z) + "]"),
              std::string::npos);
    EXPECT_NE(j.find("\"type\":\"dielectric\""), std::string::npos);
    EXPECT_NE(j.find("\"ior\":" + g9(s.bsdfs[s.spheres[0].bsdf].ior)), std::string::npos);
}

TEST(ExportScene, RefusesWhatItCannotTranslate) {
    TempDir d;
    const std::string out = (d.path / "ring.json").string();
    // The metal ring's rough diffuse and conductor have no translation here.
    ToolResult r = run_command(tool("export-scene") + " " + std::string(IRIS_SOURCE_DIR) +
                               "/scenes/thesis/metal_ring/ring.xml -o " + out);
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.output.find("export-scene: error: "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("ring.xml"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(out));
    ToolResult b = run_command(tool("export-scene") + " " + kugeln() + " -o " + out + " --resolution 256");
    EXPECT_NE(b.status, 0);
    EXPECT_NE(b.output.find("export-scene: error: --resolution must be WxH"), std::string::npos) << b.output;
    EXPECT_FALSE(std::filesystem::exists(out));
    // A textured diffuse BSDF: refused, not exported as its mean (the peer would render another picture).
    const std::string tex = (d.path / "tex.xml").string();
    std::ofstream(tex) << "<?xml version=\"1.0\"?>\n<scene version=\"0.5.0\">\n"
                          "  <shape type=\"rectangle\"><bsdf type=\"diffuse\"><texture type=\"checkerboard\" "
                          "name=\"reflectance\"/></bsdf>\n    <emitter type=\"area\"/></shape>\n"
                          "  <sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n</scene>\n";
    ToolResult t = run_command(tool("export-scene") + " " + tex + " -o " + out);
    EXPECT_NE(t.status, 0);
    EXPECT_NE(t.output.find("export-scene: error: " + tex + ": a textured BSDF parameter"), std::string::npos) << t.output;
    EXPECT_FALSE(std::filesystem::exists(out));
    // A mask: refused likewise (the peer would render the surface opaque).
    const std::string masked = (d.path / "mask.xml").string();
    std::ofstream(masked) << "<?xml version=\"1.0\"?>\n<scene version=\"0.5.0\">\n"
                             "  <shape type=\"rectangle\"><bsdf type=\"mask\"><bsdf type=\"diffuse\"/></bsdf></shape>\n"
                             "  <shape type=\"sphere\"><emitter type=\"area\"/></shape>\n"
                             "  <sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n</scene>\n";
    ToolResult m = run_command(tool("export-scene") + " " + masked + " -o " + out);
    EXPECT_NE(m.status, 0);
    EXPECT_NE(m.output.find("export-scene: error: " + masked + ": a mask BSDF"), std::string::npos) << m.output;
    EXPECT_FALSE(std::filesystem::exists(out));
}
